//! What every operation computes: one definition per operation, generic over `f32` and `f64`,
//! shared by the checker's constant evaluation, the IR's constant folding, the reference
//! evaluator and the VM.

use super::{Bin, Un};

/// The float operations the kernels need, for `f32` (the VM) and `f64` (folding, reference).
pub trait Real:
    Copy
    + PartialOrd
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::Div<Output = Self>
    + std::ops::Neg<Output = Self>
{
    fn of(x: f64) -> Self;
    fn abs(self) -> Self;
    fn sqrt(self) -> Self;
    fn floor(self) -> Self;
    fn ceil(self) -> Self;
    fn trunc(self) -> Self;
    fn sin(self) -> Self;
    fn cos(self) -> Self;
    fn tan(self) -> Self;
    fn asin(self) -> Self;
    fn acos(self) -> Self;
    fn atan(self) -> Self;
    fn exp(self) -> Self;
    fn ln(self) -> Self;
    fn powf(self, y: Self) -> Self;
    fn atan2(self, x: Self) -> Self;
    fn min(self, y: Self) -> Self;
    fn max(self, y: Self) -> Self;
}

macro_rules! real {
    ($t:ty) => {
        impl Real for $t {
            #[inline(always)]
            fn of(x: f64) -> Self {
                x as $t
            }
            #[inline(always)]
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            #[inline(always)]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline(always)]
            fn floor(self) -> Self {
                <$t>::floor(self)
            }
            #[inline(always)]
            fn ceil(self) -> Self {
                <$t>::ceil(self)
            }
            #[inline(always)]
            fn trunc(self) -> Self {
                <$t>::trunc(self)
            }
            #[inline(always)]
            fn sin(self) -> Self {
                <$t>::sin(self)
            }
            #[inline(always)]
            fn cos(self) -> Self {
                <$t>::cos(self)
            }
            #[inline(always)]
            fn tan(self) -> Self {
                <$t>::tan(self)
            }
            #[inline(always)]
            fn asin(self) -> Self {
                <$t>::asin(self)
            }
            #[inline(always)]
            fn acos(self) -> Self {
                <$t>::acos(self)
            }
            #[inline(always)]
            fn atan(self) -> Self {
                <$t>::atan(self)
            }
            #[inline(always)]
            fn exp(self) -> Self {
                <$t>::exp(self)
            }
            #[inline(always)]
            fn ln(self) -> Self {
                <$t>::ln(self)
            }
            #[inline(always)]
            fn powf(self, y: Self) -> Self {
                <$t>::powf(self, y)
            }
            #[inline(always)]
            fn atan2(self, x: Self) -> Self {
                <$t>::atan2(self, x)
            }
            #[inline(always)]
            fn min(self, y: Self) -> Self {
                if y < self { y } else { self }
            }
            #[inline(always)]
            fn max(self, y: Self) -> Self {
                if y > self { y } else { self }
            }
        }
    };
}
real!(f32);
real!(f64);

#[inline(always)]
fn truth<T: Real>(b: bool) -> T {
    if b { T::of(1.0) } else { T::of(0.0) }
}

/// Round half away from zero, written with `trunc` so that it compiles to one instruction
/// (SSE4.1 `roundps`) instead of a library call, and with selects, not branches: the
/// points rounded (a lattice's, along random rays) go either way as often.
#[inline(always)]
pub fn round<T: Real>(x: T) -> T {
    let t = x.trunc();
    let d = x - t;
    // Selects of `t` itself, not `t + 0`: that would turn -0 into +0.
    let half = T::of(0.5);
    let r = if d >= half { t + T::of(1.0) } else { t };
    if d <= -half { t - T::of(1.0) } else { r }
}

#[inline(always)]
pub fn un<T: Real>(op: Un, x: T) -> T {
    let zero = T::of(0.0);
    match op {
        Un::Neg => -x,
        Un::Abs => x.abs(),
        Un::Sqrt => x.sqrt(),
        Un::Floor => x.floor(),
        Un::Ceil => x.ceil(),
        Un::Round => round(x),
        Un::Fract => x - x.floor(),
        Un::Sign => {
            if x > zero {
                T::of(1.0)
            } else if x < zero {
                T::of(-1.0)
            } else {
                zero
            }
        }
        Un::Sin => x.sin(),
        Un::Cos => x.cos(),
        Un::Tan => x.tan(),
        Un::Asin => x.asin(),
        Un::Acos => x.acos(),
        Un::Atan => x.atan(),
        Un::Exp => x.exp(),
        Un::Ln => x.ln(),
        Un::Not => truth(x == zero),
    }
}

#[inline(always)]
pub fn bin<T: Real>(op: Bin, a: T, b: T) -> T {
    let zero = T::of(0.0);
    match op {
        Bin::Add => a + b,
        Bin::Sub => a - b,
        Bin::Mul => a * b,
        Bin::Div => a / b,
        Bin::Mod => floor_mod(a, b),
        Bin::Min => a.min(b),
        Bin::Max => a.max(b),
        Bin::Pow => a.powf(b),
        Bin::Atan2 => a.atan2(b),
        Bin::Lt => truth(a < b),
        Bin::Le => truth(a <= b),
        Bin::Eq => truth(a == b),
        Bin::Ne => truth(a != b),
        Bin::And => truth(a != zero && b != zero),
        Bin::Or => truth(a != zero || b != zero),
    }
}

/// Floored modulo: the result has the sign of the divisor, so cell indices map into 0..m.
#[inline(always)]
pub fn floor_mod<T: Real>(a: T, b: T) -> T {
    a - b * (a / b).floor()
}

#[inline(always)]
pub fn select<T: Real>(c: T, a: T, b: T) -> T {
    if c != T::of(0.0) { a } else { b }
}

#[inline(always)]
pub fn smin<T: Real>(a: T, b: T, k: T) -> T {
    let m = a.min(b);
    if k > T::of(0.0) {
        let h = (k - (a - b).abs()).max(T::of(0.0)) / k;
        m - h * h * k * T::of(0.25)
    } else {
        m
    }
}

#[inline(always)]
pub fn length<T: Real>(v: [T; 4]) -> T {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3]).sqrt()
}

#[inline(always)]
pub fn affine<T: Real>(v: [T; 4], r: [T; 5]) -> T {
    r[0] * v[0] + r[1] * v[1] + r[2] * v[2] + r[3] * v[3] + r[4]
}

/// |v + offset| - sub, with `r` = offset (4), sub.
#[inline(always)]
pub fn norm<T: Real>(v: [T; 4], r: [T; 5]) -> T {
    length(std::array::from_fn(|i| v[i] + r[i])) - r[4]
}

/// The hyperbox distance at `v + offset` minus `sub`; `r` = offset (4), half (4), sub.
#[inline(always)]
pub fn box_dist<T: Real>(v: [T; 4], r: [T; 9]) -> T {
    let zero = T::of(0.0);
    let q: [T; 4] = std::array::from_fn(|i| (v[i] + r[i]).abs() - r[4 + i]);
    let o = length(q.map(|x| x.max(zero)));
    o + q[0].max(q[1]).max(q[2].max(q[3])).min(zero) - r[8]
}

/// Conway and Sloane's D4 decoder: round every coordinate; if the sum is odd, re-round the
/// coordinate with the largest rounding error the other way. Returns (v - nearest, nearest).
#[inline(always)]
pub fn d4<T: Real>(v: [T; 4]) -> [T; 8] {
    let one = T::of(1.0);
    let r = v.map(round);
    let e: [T; 4] = std::array::from_fn(|i| v[i] - r[i]);
    let a = e.map(T::abs);
    // Index of the largest error, first on ties; written as selects so it vectorises.
    let k01 = if a[1] > a[0] { 1 } else { 0 };
    let k23 = if a[3] > a[2] { 3 } else { 2 };
    let k = if a[k23] > a[k01] { k23 } else { k01 };
    let sum = r[0] + r[1] + r[2] + r[3];
    let odd = sum - T::of(2.0) * (sum * T::of(0.5)).floor() != T::of(0.0);
    let mut out = [T::of(0.0); 8];
    for i in 0..4 {
        let step = if e[i] > T::of(0.0) { one } else { -one };
        let n = if odd && i == k { r[i] + step } else { r[i] };
        out[i] = v[i] - n;
        out[4 + i] = n;
    }
    out
}

/// Repetition with cells -l..=l: (x - cell, cell).
#[inline(always)]
pub fn rep<T: Real>(x: T, l: T) -> [T; 2] {
    let c = round(x).max(-l).min(l);
    [x - c, c]
}

#[inline(always)]
pub fn min_id<T: Real>(best: T, best_id: T, d: T, id: T) -> [T; 2] {
    if d < best { [d, id] } else { [best, best_id] }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `round` is the standard library's, bit for bit (the sign of zero too), in `f64` and
    /// `f32`, at ties, beside them and where every number is an integer.
    #[test]
    fn round_is_the_standard_round() {
        let mut x = 0.123_f64;
        let mut values = vec![0.0, -0.0, 0.5, -0.5, 1.5, -2.5, 0.49999999999999994, -0.3];
        values.extend([f64::MAX, 4503599627370497.0, -4503599627370497.5, 1e300]);
        values.extend([f64::INFINITY, f64::NEG_INFINITY]);
        for _ in 0..10_000 {
            x = (x * 7919.0 + 0.37).fract();
            values.push((x - 0.5) * 64.0);
        }
        for v in values {
            assert_eq!(round(v).to_bits(), v.round().to_bits(), "{v}");
            let f = v as f32;
            assert_eq!(round(f).to_bits(), f.round().to_bits(), "{f}");
        }
        assert!(round(f64::NAN).is_nan());
    }

    fn dist(a: [f64; 4], b: [f64; 4]) -> f64 {
        (0..4).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt()
    }

    #[test]
    fn d4_decoder_matches_brute_force() {
        let mut seed = 12345u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 20.0
        };
        for _ in 0..2000 {
            let p = [rnd(), rnd(), rnd(), rnd()];
            let out = d4(p);
            let got: [f64; 4] = std::array::from_fn(|i| out[4 + i]);
            let mut best = f64::INFINITY;
            for m in 0..81usize {
                let q: [f64; 4] = std::array::from_fn(|i| {
                    p[i].round() + ((m / 3usize.pow(i as u32)) % 3) as f64 - 1.0
                });
                if (q.iter().sum::<f64>() as i64).rem_euclid(2) == 0 {
                    best = best.min(dist(p, q));
                }
            }
            assert!(
                (got.iter().sum::<f64>() as i64).rem_euclid(2) == 0,
                "{got:?} not in D4"
            );
            assert!(
                dist(p, got) <= best + 1e-12,
                "{p:?}: got {got:?} at {} but best is {best}",
                dist(p, got)
            );
        }
    }
}
