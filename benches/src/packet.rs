//! `F8`: eight `f32` lanes, the native packet type.
//!
//! Every operation is a plain loop over `[f32; 8]`, marked `#[inline(always)]`, so that once a
//! whole formula is inlined into a kernel compiled with AVX2 (see `native.rs`) LLVM turns each
//! loop into one 256-bit instruction. Masks are 1.0/0.0 numbers (as in [`Num`]), which keeps the
//! generic formulas branch-free; LLVM folds `select(gt(a, b), t, f)` into compare + blend.

// Indexed loops over the lanes are the shape LLVM's vectoriser handles best.
#![allow(clippy::needless_range_loop)]

use crate::num::Num;
use std::ops::{Add, Mul, Neg, Sub};

pub const LANES: usize = 8;

#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct F8(pub [f32; LANES]);

impl F8 {
    #[inline(always)]
    pub fn load(s: &[f32]) -> F8 {
        F8(s[..LANES].try_into().unwrap())
    }

    #[inline(always)]
    fn map(self, f: impl Fn(f32) -> f32) -> F8 {
        let mut o = [0.0; LANES];
        for i in 0..LANES {
            o[i] = f(self.0[i]);
        }
        F8(o)
    }

    #[inline(always)]
    fn zip(self, b: F8, f: impl Fn(f32, f32) -> f32) -> F8 {
        let mut o = [0.0; LANES];
        for i in 0..LANES {
            o[i] = f(self.0[i], b.0[i]);
        }
        F8(o)
    }
}

impl From<f32> for F8 {
    #[inline(always)]
    fn from(v: f32) -> F8 {
        F8([v; LANES])
    }
}

macro_rules! lanewise_op {
    ($tr:ident, $f:ident, $op:tt) => {
        impl $tr for F8 {
            type Output = F8;
            #[inline(always)]
            fn $f(self, b: F8) -> F8 {
                self.zip(b, |x, y| x $op y)
            }
        }
    };
}
lanewise_op!(Add, add, +);
lanewise_op!(Sub, sub, -);
lanewise_op!(Mul, mul, *);

impl Neg for F8 {
    type Output = F8;
    #[inline(always)]
    fn neg(self) -> F8 {
        self.map(|x| -x)
    }
}

/// Each lane does exactly what the `f32` implementation does.
impl Num for F8 {
    #[inline(always)]
    fn min(&self, o: &Self) -> Self {
        self.zip(*o, |a, b| Num::min(&a, &b))
    }
    #[inline(always)]
    fn max(&self, o: &Self) -> Self {
        self.zip(*o, |a, b| Num::max(&a, &b))
    }
    #[inline(always)]
    fn abs(&self) -> Self {
        self.map(f32::abs)
    }
    #[inline(always)]
    fn sqrt(&self) -> Self {
        self.map(f32::sqrt)
    }
    #[inline(always)]
    fn round(&self) -> Self {
        self.map(f32::round)
    }
    #[inline(always)]
    fn floor(&self) -> Self {
        self.map(f32::floor)
    }
    #[inline(always)]
    fn gt(&self, o: &Self) -> Self {
        self.zip(*o, |a, b| Num::gt(&a, &b))
    }
    #[inline(always)]
    fn select(mask: &Self, t: &Self, f: &Self) -> Self {
        let mut o = [0.0; LANES];
        for i in 0..LANES {
            o[i] = <f32 as Num>::select(&mask.0[i], &t.0[i], &f.0[i]);
        }
        F8(o)
    }
}
