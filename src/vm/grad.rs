//! Forward-mode derivatives: a dual number carries a value and its four partial derivatives
//! with respect to x, y, z, w, and the interpreter runs on it unchanged, so a normal costs one
//! pass instead of eight extra evaluations.

use crate::math::kernel::Real;
use std::cmp::Ordering;
use std::ops::{Add, Div, Mul, Neg, Sub};

#[derive(Clone, Copy, Debug, Default)]
pub struct Dual {
    pub v: f32,
    pub g: [f32; 4],
}

impl Dual {
    /// Input `axis` (0..4) at value `v`: its derivative is the unit vector of that axis.
    pub fn var(v: f32, axis: usize) -> Dual {
        let mut g = [0.0; 4];
        g[axis] = 1.0;
        Dual { v, g }
    }

    fn chain(self, v: f32, dv: f32) -> Dual {
        Dual {
            v,
            g: self.g.map(|x| x * dv),
        }
    }
}

impl PartialEq for Dual {
    fn eq(&self, o: &Dual) -> bool {
        self.v == o.v
    }
}

impl PartialOrd for Dual {
    fn partial_cmp(&self, o: &Dual) -> Option<Ordering> {
        self.v.partial_cmp(&o.v)
    }
}

impl Add for Dual {
    type Output = Dual;
    #[inline(always)]
    fn add(self, o: Dual) -> Dual {
        Dual {
            v: self.v + o.v,
            g: std::array::from_fn(|i| self.g[i] + o.g[i]),
        }
    }
}

impl Sub for Dual {
    type Output = Dual;
    #[inline(always)]
    fn sub(self, o: Dual) -> Dual {
        Dual {
            v: self.v - o.v,
            g: std::array::from_fn(|i| self.g[i] - o.g[i]),
        }
    }
}

#[allow(clippy::suspicious_arithmetic_impl)] // the product rule
impl Mul for Dual {
    type Output = Dual;
    #[inline(always)]
    fn mul(self, o: Dual) -> Dual {
        Dual {
            v: self.v * o.v,
            g: std::array::from_fn(|i| self.g[i] * o.v + self.v * o.g[i]),
        }
    }
}

#[allow(clippy::suspicious_arithmetic_impl)] // the quotient rule
impl Div for Dual {
    type Output = Dual;
    #[inline(always)]
    fn div(self, o: Dual) -> Dual {
        let v = self.v / o.v;
        Dual {
            v,
            g: std::array::from_fn(|i| (self.g[i] - v * o.g[i]) / o.v),
        }
    }
}

impl Neg for Dual {
    type Output = Dual;
    #[inline(always)]
    fn neg(self) -> Dual {
        Dual {
            v: -self.v,
            g: self.g.map(|x| -x),
        }
    }
}

impl Real for Dual {
    fn of(x: f64) -> Self {
        Dual {
            v: x as f32,
            g: [0.0; 4],
        }
    }
    fn abs(self) -> Self {
        if self.v < 0.0 { -self } else { self }
    }
    fn sqrt(self) -> Self {
        let s = self.v.sqrt();
        // The derivative at 0 is infinite; 0 keeps normals finite at a ball's centre.
        self.chain(s, if s > 0.0 { 0.5 / s } else { 0.0 })
    }
    fn floor(self) -> Self {
        self.chain(self.v.floor(), 0.0)
    }
    fn ceil(self) -> Self {
        self.chain(self.v.ceil(), 0.0)
    }
    fn trunc(self) -> Self {
        self.chain(self.v.trunc(), 0.0)
    }
    fn sin(self) -> Self {
        self.chain(self.v.sin(), self.v.cos())
    }
    fn cos(self) -> Self {
        self.chain(self.v.cos(), -self.v.sin())
    }
    fn tan(self) -> Self {
        let t = self.v.tan();
        self.chain(t, 1.0 + t * t)
    }
    fn asin(self) -> Self {
        self.chain(self.v.asin(), 1.0 / (1.0 - self.v * self.v).sqrt())
    }
    fn acos(self) -> Self {
        self.chain(self.v.acos(), -1.0 / (1.0 - self.v * self.v).sqrt())
    }
    fn atan(self) -> Self {
        self.chain(self.v.atan(), 1.0 / (1.0 + self.v * self.v))
    }
    fn exp(self) -> Self {
        let e = self.v.exp();
        self.chain(e, e)
    }
    fn ln(self) -> Self {
        self.chain(self.v.ln(), 1.0 / self.v)
    }
    fn powf(self, y: Self) -> Self {
        let v = self.v.powf(y.v);
        let da = if self.v == 0.0 { 0.0 } else { y.v * v / self.v };
        let db = if self.v > 0.0 { v * self.v.ln() } else { 0.0 };
        Dual {
            v,
            g: std::array::from_fn(|i| da * self.g[i] + db * y.g[i]),
        }
    }
    fn atan2(self, x: Self) -> Self {
        let r2 = self.v * self.v + x.v * x.v;
        let s = if r2 > 0.0 { 1.0 / r2 } else { 0.0 };
        Dual {
            v: self.v.atan2(x.v),
            g: std::array::from_fn(|i| (x.v * self.g[i] - self.v * x.g[i]) * s),
        }
    }
    fn min(self, y: Self) -> Self {
        if y < self { y } else { self }
    }
    fn max(self, y: Self) -> Self {
        if y > self { y } else { self }
    }
}
