//! The number type every benchmark formula is written against.
//!
//! Each scene's distance function is written once, generically over [`Num`], and instantiated three
//! times: with `f32` (the native scalar closure), with [`F8`](crate::packet::F8) (the native
//! 8-lane packet) and with fidget's [`Tree`] (an expression graph that fidget compiles). So the
//! three contenders evaluate the same formula, operation for operation, by construction.
//!
//! The primitives are the ones all three can express without branches: arithmetic, min/max, abs,
//! sqrt, round (half away from zero), floor, a comparison that yields 1.0 or 0.0, and a select on
//! such a mask.

use fidget::context::Tree;
use std::ops::{Add, Mul, Neg, Sub};

pub trait Num:
    Clone
    + From<f32>
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Neg<Output = Self>
{
    fn min(&self, o: &Self) -> Self;
    fn max(&self, o: &Self) -> Self;
    fn abs(&self) -> Self;
    fn sqrt(&self) -> Self;
    /// Round half away from zero (as `f32::round`).
    fn round(&self) -> Self;
    fn floor(&self) -> Self;
    /// 1.0 where `self > o`, else 0.0.
    fn gt(&self, o: &Self) -> Self;
    /// `t` where `mask` (a result of [`Num::gt`]) is 1.0, else `f`.
    fn select(mask: &Self, t: &Self, f: &Self) -> Self;
}

/// Scalar lanes. `min`/`max` are written as compare-and-select (x86 `minss`/`maxss` semantics)
/// rather than `f32::min`, whose NaN rule costs extra instructions; the packet type does the same,
/// so the two native contenders agree bit for bit.
impl Num for f32 {
    #[inline(always)]
    fn min(&self, o: &Self) -> Self {
        if *self < *o { *self } else { *o }
    }
    #[inline(always)]
    fn max(&self, o: &Self) -> Self {
        if *self > *o { *self } else { *o }
    }
    #[inline(always)]
    fn abs(&self) -> Self {
        f32::abs(*self)
    }
    #[inline(always)]
    fn sqrt(&self) -> Self {
        f32::sqrt(*self)
    }
    #[inline(always)]
    fn round(&self) -> Self {
        f32::round(*self)
    }
    #[inline(always)]
    fn floor(&self) -> Self {
        f32::floor(*self)
    }
    #[inline(always)]
    fn gt(&self, o: &Self) -> Self {
        if *self > *o { 1.0 } else { 0.0 }
    }
    #[inline(always)]
    fn select(mask: &Self, t: &Self, f: &Self) -> Self {
        if *mask != 0.0 { *t } else { *f }
    }
}

/// Expression building: every call adds a node to fidget's graph (shared subexpressions are
/// shared `Arc`s, which fidget deduplicates when it imports the tree into a `Context`).
impl Num for Tree {
    fn min(&self, o: &Self) -> Self {
        Tree::min(self, o.clone())
    }
    fn max(&self, o: &Self) -> Self {
        Tree::max(self, o.clone())
    }
    fn abs(&self) -> Self {
        Tree::abs(self)
    }
    fn sqrt(&self) -> Self {
        Tree::sqrt(self)
    }
    fn round(&self) -> Self {
        // fidget's `round` rounds half away from zero, like `f32::round` (the JIT inlines it as
        // `vroundps(x + copysign(0.49999997, x), truncate)`).
        Tree::round(self)
    }
    fn floor(&self) -> Self {
        Tree::floor(self)
    }
    fn gt(&self, o: &Self) -> Self {
        // compare(a, b) is -1, 0 or 1; clamping at 0 leaves 1 exactly where a > b.
        self.compare(o.clone()).max(0.0)
    }
    fn select(mask: &Self, t: &Self, f: &Self) -> Self {
        // fidget's `and`/`or` pass values through: and(m, t) is t where m != 0 (else 0), so this
        // is exact even where t or f are 0 or infinite (unlike m*t + (1-m)*f).
        mask.and(t.clone()).or(mask.not().and(f.clone()))
    }
}
