//! Interval evaluation: conservative bounds of every output of a tape over a 4D box, the basis
//! for pruning min/max branches and skipping empty space per tile.

use super::tape::{INPUTS, Instr, Tape};
use crate::ir::{Bin, Un};
use crate::math::kernel as eval;

/// A closed interval `lo..=hi`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct I {
    pub lo: f32,
    pub hi: f32,
}

const ALL: I = I {
    lo: f32::NEG_INFINITY,
    hi: f32::INFINITY,
};

impl I {
    pub fn new(lo: f32, hi: f32) -> I {
        I { lo, hi }
    }
    pub fn point(x: f32) -> I {
        I { lo: x, hi: x }
    }
    pub fn contains(self, x: f32) -> bool {
        (self.lo <= x && x <= self.hi) || x.is_nan() || self.lo.is_nan() || self.hi.is_nan()
    }
    fn is_point(self) -> bool {
        self.lo == self.hi
    }
    fn union(self, o: I) -> I {
        I::new(self.lo.min(o.lo), self.hi.max(o.hi))
    }
    /// The image under a nondecreasing function.
    fn up(self, f: impl Fn(f32) -> f32) -> I {
        I::new(f(self.lo), f(self.hi))
    }
    fn add(self, o: I) -> I {
        I::new(self.lo + o.lo, self.hi + o.hi)
    }
    fn neg(self) -> I {
        I::new(-self.hi, -self.lo)
    }
    fn mul(self, o: I) -> I {
        let p = [
            self.lo * o.lo,
            self.lo * o.hi,
            self.hi * o.lo,
            self.hi * o.hi,
        ];
        if p.iter().any(|x| x.is_nan()) {
            return ALL;
        }
        I::new(
            p.iter().cloned().fold(f32::INFINITY, f32::min),
            p.iter().cloned().fold(f32::NEG_INFINITY, f32::max),
        )
    }
    fn abs(self) -> I {
        if self.lo >= 0.0 {
            self
        } else if self.hi <= 0.0 {
            self.neg()
        } else {
            I::new(0.0, (-self.lo).max(self.hi))
        }
    }
    fn square(self) -> I {
        let a = self.abs();
        I::new(a.lo * a.lo, a.hi * a.hi)
    }
    fn min(self, o: I) -> I {
        I::new(self.lo.min(o.lo), self.hi.min(o.hi))
    }
    fn max(self, o: I) -> I {
        I::new(self.lo.max(o.lo), self.hi.max(o.hi))
    }
    /// A truth value: certainly false, certainly true, or either.
    fn truth(always: bool, never: bool) -> I {
        match (always, never) {
            (true, _) => I::point(1.0),
            (_, true) => I::point(0.0),
            _ => I::new(0.0, 1.0),
        }
    }
}

fn un(op: Un, a: I) -> I {
    if a.is_point() {
        return I::point(eval::un(op, a.lo));
    }
    match op {
        Un::Neg => a.neg(),
        Un::Abs => a.abs(),
        Un::Sqrt => I::new(a.lo.max(0.0).sqrt(), a.hi.max(0.0).sqrt()),
        Un::Floor => a.up(f32::floor),
        Un::Ceil => a.up(f32::ceil),
        Un::Round => a.up(eval::round),
        Un::Fract if a.lo.floor() == a.hi.floor() => a.up(|x| x - x.floor()),
        Un::Fract => I::new(0.0, 1.0),
        Un::Sign => a.up(|x| eval::un(Un::Sign, x)),
        Un::Sin | Un::Cos => I::new(-1.0, 1.0),
        Un::Tan => ALL,
        Un::Asin | Un::Atan | Un::Exp | Un::Ln => a.up(|x| eval::un(op, x)),
        Un::Acos => I::new(a.hi.acos(), a.lo.acos()),
        Un::Not => I::truth(false, a.lo > 0.0 || a.hi < 0.0),
    }
}

fn bin(op: Bin, a: I, b: I) -> I {
    if a.is_point() && b.is_point() {
        return I::point(eval::bin(op, a.lo, b.lo));
    }
    match op {
        Bin::Add => a.add(b),
        Bin::Sub => a.add(b.neg()),
        Bin::Mul => a.mul(b),
        Bin::Div if b.lo > 0.0 || b.hi < 0.0 => a.mul(I::new(1.0 / b.hi, 1.0 / b.lo)),
        Bin::Div => ALL,
        Bin::Mod => {
            let m = b.abs().hi;
            I::new(-m, m)
        }
        Bin::Min => a.min(b),
        Bin::Max => a.max(b),
        Bin::Pow | Bin::Atan2 => ALL,
        Bin::Lt => I::truth(a.hi < b.lo, a.lo >= b.hi),
        Bin::Le => I::truth(a.hi <= b.lo, a.lo > b.hi),
        Bin::Eq => I::truth(false, a.hi < b.lo || a.lo > b.hi),
        Bin::Ne => I::truth(a.hi < b.lo || a.lo > b.hi, false),
        Bin::And | Bin::Or => {
            let yes = |x: I| x.lo > 0.0 || x.hi < 0.0;
            let no = |x: I| x == I::point(0.0);
            if op == Bin::And {
                I::truth(yes(a) && yes(b), no(a) || no(b))
            } else {
                I::truth(yes(a) || yes(b), no(a) && no(b))
            }
        }
    }
}

/// Bounds of every output of `tape` for inputs in the given intervals (indexed by `Var::index`).
pub fn eval(tape: &Tape, inputs: &[I; INPUTS]) -> Vec<I> {
    let mut r = vec![I::point(0.0); tape.regs];
    r[..INPUTS].copy_from_slice(inputs);
    for ins in &tape.code {
        let g = |i: u16| r[i as usize];
        let v4 = |v: [u16; 4]| v.map(g);
        let out: Vec<I> = match *ins {
            Instr::Const { k, .. } => vec![I::point(k)],
            Instr::Un { op, a, .. } => vec![un(op, g(a))],
            Instr::Bin { op, a, b, .. } => vec![bin(op, g(a), g(b))],
            Instr::BinImm { op, a, k, .. } => vec![bin(op, g(a), I::point(k))],
            Instr::ImmBin { op, k, b, .. } => vec![bin(op, I::point(k), g(b))],
            Instr::Select { c, a, b, .. } => {
                let c = g(c);
                vec![if c == I::point(0.0) {
                    g(b)
                } else if c.lo > 0.0 || c.hi < 0.0 {
                    g(a)
                } else {
                    g(a).union(g(b))
                }]
            }
            Instr::Length { v, r: row, .. } => {
                let s = (0..4).fold(I::point(0.0), |acc, i| {
                    acc.add(g(v[i]).add(I::point(row[i])).square())
                });
                vec![un(Un::Sqrt, s).add(I::point(-row[4]))]
            }
            Instr::Affine { v, r: row, .. } => {
                let s = v4(v)
                    .iter()
                    .zip(&row)
                    .fold(I::point(row[4]), |acc, (x, c)| acc.add(x.mul(I::point(*c))));
                vec![s]
            }
            Instr::Box { v, r: row, .. } => {
                let q: Vec<I> = (0..4)
                    .map(|i| {
                        g(v[i])
                            .add(I::point(row[i]))
                            .abs()
                            .add(I::point(-row[4 + i]))
                    })
                    .collect();
                let o = q.iter().fold(I::point(0.0), |acc, x| {
                    acc.add(x.max(I::point(0.0)).square())
                });
                let m = q[1..].iter().fold(q[0], |acc, x| acc.max(*x));
                vec![
                    un(Un::Sqrt, o)
                        .add(m.min(I::point(0.0)))
                        .add(I::point(-row[8])),
                ]
            }
            // Smooth min is nondecreasing in a and b and nonincreasing in k.
            Instr::SMin { a, b, k, .. } => {
                let (a, b, k) = (g(a), g(b), g(k));
                vec![I::new(
                    eval::smin(a.lo, b.lo, k.hi),
                    eval::smin(a.hi, b.hi, k.lo),
                )]
            }
            Instr::SMax { a, b, k, .. } => {
                let (a, b, k) = (g(a), g(b), g(k));
                vec![I::new(
                    -eval::smin(-a.lo, -b.lo, k.lo),
                    -eval::smin(-a.hi, -b.hi, k.hi),
                )]
            }
            Instr::D4 { v, .. } => {
                let v = v4(v);
                if v.iter().all(|x| x.is_point()) {
                    eval::d4(v.map(|x| x.lo))
                        .iter()
                        .map(|x| I::point(*x))
                        .collect()
                } else {
                    // Offsets stay inside the Voronoi cell (|x_i| <= 1); points are near.
                    let mut out = vec![I::new(-1.0, 1.0); 4];
                    out.extend(
                        v.iter()
                            .map(|x| I::new(x.lo.floor() - 1.0, x.hi.ceil() + 1.0)),
                    );
                    out
                }
            }
            Instr::Rep { a, l, .. } => {
                let a = g(a);
                let (clo, chi) = (eval::rep(a.lo, l)[1], eval::rep(a.hi, l)[1]);
                if clo == chi {
                    vec![a.add(I::point(-clo)), I::point(clo)]
                } else {
                    vec![
                        I::new((-0.5f32).min(a.lo - clo), 0.5f32.max(a.hi - chi)),
                        I::new(clo, chi),
                    ]
                }
            }
            Instr::MinId { a, b, c, id, .. } => {
                let (best, best_id, d) = (g(a), g(b), g(c));
                let id = if d.hi < best.lo {
                    I::point(id)
                } else if d.lo >= best.hi {
                    best_id
                } else {
                    best_id.union(I::point(id))
                };
                vec![best.min(d), id]
            }
        };
        for (reg, val) in ins.writes().iter().zip(out) {
            r[*reg as usize] = val;
        }
    }
    tape.outputs.iter().map(|o| r[*o as usize]).collect()
}
