//! The interpreter: one dispatch per instruction for a whole packet of `N` lanes (registers are
//! `[T; N]`), so the inner loops are straight-line lane loops the compiler vectorises. The same
//! code runs one point (`N = 1`) and forward-mode derivatives (`T = Dual`).

use super::tape::{Instr, Tape};
use crate::ir::{Bin, Un, Var};
use crate::math::kernel::{self as eval, Real};
use crate::simd;

/// Registers of one packet.
pub struct Regs<T, const N: usize> {
    pub(crate) r: Vec<[T; N]>,
}

impl<T: Real, const N: usize> Regs<T, N> {
    pub fn new(tape: &Tape) -> Self {
        Regs {
            r: vec![[T::of(0.0); N]; tape.regs],
        }
    }

    /// Make room for `tape` (registers are reused between tapes).
    pub fn fit(&mut self, tape: &Tape) {
        if self.r.len() < tape.regs {
            self.r.resize(tape.regs, [T::of(0.0); N]);
        }
    }

    pub fn input(&mut self, i: usize) -> &mut [T; N] {
        &mut self.r[i]
    }

    /// Every lane's time input.
    pub fn set_time(&mut self, t: T) {
        *self.input(Var::T.index()) = [t; N];
    }

    /// Lane `lane`'s point and normal inputs.
    pub fn set_point(&mut self, lane: usize, p: [T; 4], n: [T; 4]) {
        for axis in 0..4 {
            self.input(Var::POINT[axis].index())[lane] = p[axis];
            self.input(Var::NORMAL[axis].index())[lane] = n[axis];
        }
    }

    pub fn get(&self, reg: super::tape::Reg) -> &[T; N] {
        &self.r[reg as usize]
    }
}

/// Run `tape` over the packet in `regs`, whose input registers are already filled.
pub fn run<T: Real, const N: usize>(tape: &Tape, regs: &mut Regs<T, N>) {
    assert!(regs.r.len() >= tape.regs, "registers sized for the tape");
    // One lane has nothing to vectorise: no feature check per point.
    simd::wide!(N > 1, run_code(&tape.code, &mut regs.r))
}

/// Lanes of a destination and its operands. Registers written by an instruction are never
/// among those it reads (the allocator gives destinations fresh registers), and every index
/// is below `r.len()` (checked in `run`), which is what makes the raw accesses sound.
struct View<T, const N: usize>(*mut [T; N], usize);

impl<T, const N: usize> View<T, N> {
    #[inline(always)]
    fn a(&self, i: u16) -> &[T; N] {
        debug_assert!((i as usize) < self.1);
        // SAFETY: in bounds (see the type's comment); shared reads may alias each other.
        unsafe { &*self.0.add(i as usize) }
    }
    #[inline(always)]
    #[allow(clippy::mut_from_ref)]
    fn d(&self, i: u16) -> &mut [T; N] {
        debug_assert!((i as usize) < self.1);
        // SAFETY: in bounds, and no operand of the running instruction is this register.
        unsafe { &mut *self.0.add(i as usize) }
    }
}

#[inline(always)]
fn run_code<T: Real, const N: usize>(code: &[Instr], r: &mut [[T; N]]) {
    let v = View(r.as_mut_ptr(), r.len());
    for ins in code {
        match *ins {
            Instr::Const { d, k } => *v.d(d) = [T::of(k as f64); N],
            Instr::Un { op, d, a } => {
                let (d, a) = (v.d(d), v.a(a));
                macro_rules! go { ($($o:ident)*) => { match op {
                    $(Un::$o => for i in 0..N { d[i] = eval::un(Un::$o, a[i]) },)*
                } } }
                go!(Neg Abs Sqrt Floor Ceil Round Fract Sign Sin Cos Tan Asin Acos Atan Exp Ln Not)
            }
            Instr::Bin { op, d, a, b } => {
                let (d, a, b) = (v.d(d), v.a(a), v.a(b));
                macro_rules! go { ($($o:ident)*) => { match op {
                    $(Bin::$o => for i in 0..N { d[i] = eval::bin(Bin::$o, a[i], b[i]) },)*
                } } }
                go!(Add Sub Mul Div Mod Min Max Pow Atan2 Lt Le Eq Ne And Or)
            }
            Instr::BinImm { op, d, a, k } => {
                let (d, a, k) = (v.d(d), v.a(a), T::of(k as f64));
                macro_rules! go { ($($o:ident)*) => { match op {
                    $(Bin::$o => for i in 0..N { d[i] = eval::bin(Bin::$o, a[i], k) },)*
                } } }
                go!(Add Sub Mul Div Mod Min Max Pow Atan2 Lt Le Eq Ne And Or)
            }
            Instr::ImmBin { op, d, k, b } => {
                let (d, b, k) = (v.d(d), v.a(b), T::of(k as f64));
                macro_rules! go { ($($o:ident)*) => { match op {
                    $(Bin::$o => for i in 0..N { d[i] = eval::bin(Bin::$o, k, b[i]) },)*
                } } }
                go!(Add Sub Mul Div Mod Min Max Pow Atan2 Lt Le Eq Ne And Or)
            }
            Instr::Select { d, c, a, b } => {
                let (d, c, a, b) = (v.d(d), v.a(c), v.a(a), v.a(b));
                for i in 0..N {
                    d[i] = eval::select(c[i], a[i], b[i]);
                }
            }
            Instr::Length { d, v: s, r } => {
                let (d, s, r) = (v.d(d), s.map(|x| v.a(x)), r.map(|x| T::of(x as f64)));
                for i in 0..N {
                    d[i] = eval::norm([s[0][i], s[1][i], s[2][i], s[3][i]], r);
                }
            }
            Instr::Affine { d, v: s, r } => {
                let (d, s, r) = (v.d(d), s.map(|x| v.a(x)), r.map(|x| T::of(x as f64)));
                for i in 0..N {
                    d[i] = eval::affine([s[0][i], s[1][i], s[2][i], s[3][i]], r);
                }
            }
            Instr::Box { d, v: s, r } => {
                let (d, s, r) = (v.d(d), s.map(|x| v.a(x)), r.map(|x| T::of(x as f64)));
                for i in 0..N {
                    d[i] = eval::box_dist([s[0][i], s[1][i], s[2][i], s[3][i]], r);
                }
            }
            Instr::SMin { d, a, b, k } => {
                let (d, a, b, k) = (v.d(d), v.a(a), v.a(b), v.a(k));
                for i in 0..N {
                    d[i] = eval::smin(a[i], b[i], k[i]);
                }
            }
            Instr::SMax { d, a, b, k } => {
                let (d, a, b, k) = (v.d(d), v.a(a), v.a(b), v.a(k));
                for i in 0..N {
                    d[i] = -eval::smin(-a[i], -b[i], k[i]);
                }
            }
            Instr::D4 { d, v: s } => {
                let (d, s) = (d.map(|x| v.d(x)), s.map(|x| v.a(x)));
                for i in 0..N {
                    let o = eval::d4([s[0][i], s[1][i], s[2][i], s[3][i]]);
                    for j in 0..8 {
                        d[j][i] = o[j];
                    }
                }
            }
            Instr::Rep { d, a, l } => {
                let (d0, d1, a, l) = (v.d(d[0]), v.d(d[1]), v.a(a), T::of(l as f64));
                for i in 0..N {
                    [d0[i], d1[i]] = eval::rep(a[i], l);
                }
            }
            Instr::MinId { d, a, b, c, id } => {
                let (d0, d1, id) = (v.d(d[0]), v.d(d[1]), T::of(id as f64));
                let (a, b, c) = (v.a(a), v.a(b), v.a(c));
                for i in 0..N {
                    [d0[i], d1[i]] = eval::min_id(a[i], b[i], c[i], id);
                }
            }
        }
    }
}
