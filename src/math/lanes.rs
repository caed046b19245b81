//! Arithmetic written once for one number (`f64`) and for four at a time (`F4`, the lanes of
//! one AVX2 vector inside `simd::wide!`). A function generic over [`Lane`] runs the same IEEE
//! operations in the same order in every lane, so each lane of its `F4` result is bit for bit
//! what the `f64` version gives for that lane's inputs: the samplers serve one path or four
//! with one piece of code.
//!
//! Branches become selects: both sides are computed in every lane, and where a lane's input is
//! outside a formula's domain (a NaN, a subnormal) it computes on a stand-in and the select
//! throws that away.

use std::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Not, Sub};

/// One number or several, with the `f64` operations the samplers use, lane by lane.
pub trait Lane:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// Lane-wise truth values: `bool` for `f64`.
    type Mask: Copy
        + BitAnd<Output = Self::Mask>
        + BitOr<Output = Self::Mask>
        + Not<Output = Self::Mask>;
    /// How many lanes.
    const N: usize;
    /// `x` in every lane.
    fn splat(x: f64) -> Self;
    /// Lane `l`.
    fn at(self, l: usize) -> f64;
    /// The lanes `f(0), f(1), ...`: for what has no lane-wise operator (bit tricks).
    fn each(f: impl Fn(usize) -> f64) -> Self;
    fn sqrt(self) -> Self;
    fn abs(self) -> Self;
    /// `f64::min`: where one side is NaN, the other.
    fn min(self, o: Self) -> Self;
    /// `f64::max`: where one side is NaN, the other.
    fn max(self, o: Self) -> Self;
    fn lt(self, o: Self) -> Self::Mask;
    fn gt(self, o: Self) -> Self::Mask;
    fn le(self, o: Self) -> Self::Mask;
    fn ge(self, o: Self) -> Self::Mask;
    fn eq(self, o: Self) -> Self::Mask;
    fn is_finite(self) -> Self::Mask;
    fn is_nan(self) -> Self::Mask;
    /// `f64::copysign`: the size of `self`, the sign bit of `sign`.
    fn copysign(self, sign: Self) -> Self;
    /// Whether `m` holds in every lane.
    fn all(m: Self::Mask) -> bool;
    /// `a` where `m` holds, else `b`.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
}

impl Lane for f64 {
    type Mask = bool;
    const N: usize = 1;
    #[inline(always)]
    fn splat(x: f64) -> f64 {
        x
    }
    #[inline(always)]
    fn at(self, _: usize) -> f64 {
        self
    }
    #[inline(always)]
    fn each(f: impl Fn(usize) -> f64) -> f64 {
        f(0)
    }
    #[inline(always)]
    fn sqrt(self) -> f64 {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> f64 {
        f64::abs(self)
    }
    #[inline(always)]
    fn min(self, o: f64) -> f64 {
        f64::min(self, o)
    }
    #[inline(always)]
    fn max(self, o: f64) -> f64 {
        f64::max(self, o)
    }
    #[inline(always)]
    fn lt(self, o: f64) -> bool {
        self < o
    }
    #[inline(always)]
    fn gt(self, o: f64) -> bool {
        self > o
    }
    #[inline(always)]
    fn le(self, o: f64) -> bool {
        self <= o
    }
    #[inline(always)]
    fn ge(self, o: f64) -> bool {
        self >= o
    }
    #[inline(always)]
    fn eq(self, o: f64) -> bool {
        self == o
    }
    #[inline(always)]
    fn is_finite(self) -> bool {
        f64::is_finite(self)
    }
    #[inline(always)]
    fn is_nan(self) -> bool {
        f64::is_nan(self)
    }
    #[inline(always)]
    fn copysign(self, sign: f64) -> f64 {
        f64::copysign(self, sign)
    }
    #[inline(always)]
    fn all(m: bool) -> bool {
        m
    }
    #[inline(always)]
    fn select(m: bool, a: f64, b: f64) -> f64 {
        if m { a } else { b }
    }
}

/// Four `f64`s, operated on lane by lane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct F4(pub [f64; 4]);

/// Four truth values, one per lane of an `F4`: all ones or all zeros, as a vector compare
/// leaves them, so that selects and the masks' logic stay in the lanes of vectors (`bool`s
/// went through bytes and back, lane by lane).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct M4([u64; 4]);

impl M4 {
    /// Lane `l`.
    #[inline(always)]
    pub fn at(self, l: usize) -> bool {
        self.0[l] != 0
    }

    #[inline(always)]
    fn of(f: impl Fn(usize) -> bool) -> M4 {
        M4(each(|l| if f(l) { u64::MAX } else { 0 }))
    }
}

/// `[f(0), f(1), f(2), f(3)]`, the form the compiler puts in one vector (loops over lanes and
/// `array::from_fn` with large closures it left scalar).
#[inline(always)]
pub fn each<T>(f: impl Fn(usize) -> T) -> [T; 4] {
    [f(0), f(1), f(2), f(3)]
}

macro_rules! lane_op {
    ($tr:ident, $f:ident, $t:ty, $op:tt) => {
        impl $tr for $t {
            type Output = $t;
            #[inline(always)]
            fn $f(self, o: $t) -> $t {
                Self(each(|l| self.0[l] $op o.0[l]))
            }
        }
    };
}
lane_op!(Add, add, F4, +);
lane_op!(Sub, sub, F4, -);
lane_op!(Mul, mul, F4, *);
lane_op!(Div, div, F4, /);
lane_op!(BitAnd, bitand, M4, &);
lane_op!(BitOr, bitor, M4, |);

impl Not for M4 {
    type Output = M4;
    #[inline(always)]
    fn not(self) -> M4 {
        M4(each(|l| !self.0[l]))
    }
}

impl Neg for F4 {
    type Output = F4;
    #[inline(always)]
    fn neg(self) -> F4 {
        F4(each(|l| -self.0[l]))
    }
}

impl Lane for F4 {
    type Mask = M4;
    const N: usize = 4;
    #[inline(always)]
    fn splat(x: f64) -> F4 {
        F4([x; 4])
    }
    #[inline(always)]
    fn at(self, l: usize) -> f64 {
        self.0[l]
    }
    #[inline(always)]
    fn each(f: impl Fn(usize) -> f64) -> F4 {
        F4(each(f))
    }
    #[inline(always)]
    fn sqrt(self) -> F4 {
        F4(each(|l| self.0[l].sqrt()))
    }
    #[inline(always)]
    fn abs(self) -> F4 {
        F4(each(|l| self.0[l].abs()))
    }
    #[inline(always)]
    fn min(self, o: F4) -> F4 {
        F4(each(|l| self.0[l].min(o.0[l])))
    }
    #[inline(always)]
    fn max(self, o: F4) -> F4 {
        F4(each(|l| self.0[l].max(o.0[l])))
    }
    #[inline(always)]
    fn lt(self, o: F4) -> M4 {
        M4::of(|l| self.0[l] < o.0[l])
    }
    #[inline(always)]
    fn gt(self, o: F4) -> M4 {
        M4::of(|l| self.0[l] > o.0[l])
    }
    #[inline(always)]
    fn le(self, o: F4) -> M4 {
        M4::of(|l| self.0[l] <= o.0[l])
    }
    #[inline(always)]
    fn ge(self, o: F4) -> M4 {
        M4::of(|l| self.0[l] >= o.0[l])
    }
    #[inline(always)]
    fn eq(self, o: F4) -> M4 {
        M4::of(|l| self.0[l] == o.0[l])
    }
    #[inline(always)]
    fn is_finite(self) -> M4 {
        M4::of(|l| self.0[l].is_finite())
    }
    #[inline(always)]
    fn is_nan(self) -> M4 {
        M4::of(|l| self.0[l].is_nan())
    }
    #[inline(always)]
    fn copysign(self, sign: F4) -> F4 {
        F4(each(|l| self.0[l].copysign(sign.0[l])))
    }
    #[inline(always)]
    fn all(m: M4) -> bool {
        m.0[0] & m.0[1] & m.0[2] & m.0[3] != 0
    }
    #[inline(always)]
    fn select(m: M4, a: F4, b: F4) -> F4 {
        let bits = |x: F4, l: usize| x.0[l].to_bits();
        F4(each(|l| {
            f64::from_bits((bits(a, l) & m.0[l]) | (bits(b, l) & !m.0[l]))
        }))
    }
}

/// `a . b`, in glam's order (`DVec4::dot`).
#[inline(always)]
pub fn dot<L: Lane>(a: [L; 4], b: [L; 4]) -> L {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
}

/// `x * s`, coordinate by coordinate.
#[inline(always)]
pub fn scale<L: Lane, const D: usize>(x: [L; D], s: L) -> [L; D] {
    x.map(|c| c * s)
}

/// `v / |v|`, as glam's `normalize` computes it (times the reciprocal of the length).
#[inline(always)]
pub fn normalize<L: Lane>(v: [L; 4]) -> [L; 4] {
    scale(v, L::splat(1.0) / dot(v, v).sqrt())
}

/// `y` where it is below `x`, else `x` (so `x` where a comparison with NaN fails): one
/// `vminpd` a vector, where `F4::min`'s care for NaN takes three instructions.
#[inline(always)]
pub fn lesser(x: F4, y: F4) -> F4 {
    F4(each(|l| if y.0[l] < x.0[l] { y.0[l] } else { x.0[l] }))
}

/// `y` where it is above `x`, else `x`: `lesser`'s twin, one `vmaxpd`.
#[inline(always)]
pub fn greater(x: F4, y: F4) -> F4 {
    F4(each(|l| if y.0[l] > x.0[l] { y.0[l] } else { x.0[l] }))
}

/// Lane `l` of a vector of lanes.
#[inline(always)]
pub fn lane<L: Lane, const D: usize>(x: [L; D], l: usize) -> [f64; D] {
    x.map(|c| c.at(l))
}

/// Vectors of four lanes from four vectors.
#[inline(always)]
pub fn gather<const D: usize>(x: [[f64; D]; 4]) -> [F4; D] {
    std::array::from_fn(|i| F4(each(|l| x[l][i])))
}
