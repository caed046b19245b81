//! Interval evaluation of the IR: conservative bounds (in `f64`) of every node over a 4D box.
//! Pruning (`prune.rs`) decides `min`/`max` branches with them, and the marcher proves with
//! them that a ray has left every object, or that a stretch of it meets none
//! (`Intervals::along`: over the ray itself, not the box it spans, so a plane the ray moves
//! away from is seen to stay behind it).

use super::{Bin, Graph, Id, Node, Un, Var};
use crate::math::kernel as k;

/// A closed interval `lo..=hi` of a node's values, and whether the node may also be NaN there
/// (`nan`). No node's bounds are ever NaN (`Intervals`): where they would be (a logarithm or
/// an arcsine over a range past its domain, `inf - inf`), nothing is known and they are the
/// whole line, possibly NaN (`I::known`). A NaN bound would not be conservative: `min` and
/// `max` (`f64::min`) drop a NaN operand, so `min(log(y), |p| - 1)` beside the ball would read
/// as positive though the slab `0 < y <= 1` is solid, and a proof or a pruning decision read
/// from it would be wrong. The kernel's own `min`, `max`, comparisons and `sign` drop NaN
/// values too (`max(a, b)` is `a` where `b` is NaN, and NaN where `a` is), so the flag follows
/// a possible NaN up the graph to where one is dropped, and the bounds there take in what the
/// kernel returns instead.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct I {
    pub lo: f64,
    pub hi: f64,
    /// The node may be NaN (undefined) somewhere in the box, besides its values in `lo..=hi`.
    pub nan: bool,
}

impl I {
    pub const ALL: I = I {
        lo: f64::NEG_INFINITY,
        hi: f64::INFINITY,
        nan: false,
    };
    /// Nothing known, NaN included: past a function's domain.
    const UNDEFINED: I = I {
        nan: true,
        ..I::ALL
    };

    pub fn new(lo: f64, hi: f64) -> I {
        I { lo, hi, nan: false }
    }
    pub fn point(x: f64) -> I {
        I::new(x, x)
    }
    /// These bounds, possibly NaN as well where `nan`.
    fn or_nan(self, nan: bool) -> I {
        I {
            nan: self.nan || nan,
            ..self
        }
    }
    /// These bounds, or the whole line, possibly NaN, where either is NaN. Applied to each
    /// node's bounds (and each line along a ray, `Line::known`) as they are stored, not in
    /// every operation: a check in `I::new` made escape proofs 6-8% slower. Within one node's
    /// operations a NaN drops out only where an operand is infinite, and only where the
    /// result stays sound (a grid's offset within half a cell); `mul` turns a NaN product into
    /// the whole line.
    fn known(self) -> I {
        if self.lo.is_nan() || self.hi.is_nan() {
            I::UNDEFINED
        } else {
            self
        }
    }
    /// Whether `x` is in the interval; a NaN value (the evaluators' "undefined") is in every one.
    pub fn contains(self, x: f64) -> bool {
        (self.lo <= x && x <= self.hi) || x.is_nan()
    }
    /// Whether every value is nonzero.
    pub fn excludes_zero(self) -> bool {
        self.lo > 0.0 || self.hi < 0.0
    }
    /// Whether every value is positive and none NaN: a distance that proves a ray clear.
    pub fn positive(self) -> bool {
        self.lo > 0.0 && !self.nan
    }
    /// Whether every value is nonzero and none NaN: an unsigned distance that proves it.
    pub fn nonzero(self) -> bool {
        self.excludes_zero() && !self.nan
    }
    /// A single number, and never NaN.
    fn is_point(self) -> bool {
        self.lo == self.hi && !self.nan
    }
    fn union(self, o: I) -> I {
        I::new(self.lo.min(o.lo), self.hi.max(o.hi)).or_nan(self.nan || o.nan)
    }
    /// The image under a nondecreasing function.
    fn up(self, f: impl Fn(f64) -> f64) -> I {
        I::new(f(self.lo), f(self.hi)).or_nan(self.nan)
    }
    fn add(self, o: I) -> I {
        I::new(self.lo + o.lo, self.hi + o.hi).or_nan(self.nan || o.nan)
    }
    fn neg(self) -> I {
        I::new(-self.hi, -self.lo).or_nan(self.nan)
    }
    fn mul(self, o: I) -> I {
        let p = [
            self.lo * o.lo,
            self.lo * o.hi,
            self.hi * o.lo,
            self.hi * o.hi,
        ];
        let nan = self.nan || o.nan;
        // An infinity that is a value (`1 / 0` folded to a point) times an operand that may be
        // 0. (Infinite bounds are most often limits, along a ray that goes on for ever, which
        // no point reaches: their products with 0 leave the whole line, not a NaN. Values
        // that may be infinite elsewhere are not followed: see `docs/ir-and-vm.md`.)
        let infinity = |x: I, y: I| x.lo == x.hi && x.lo.is_infinite() && y.contains(0.0);
        if infinity(self, o) || infinity(o, self) {
            return I::UNDEFINED;
        }
        if p.iter().any(|x| x.is_nan()) {
            return I::ALL.or_nan(nan);
        }
        I::new(
            p.iter().cloned().fold(f64::INFINITY, f64::min),
            p.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
        )
        .or_nan(nan)
    }
    fn abs(self) -> I {
        if self.lo >= 0.0 {
            self
        } else if self.hi <= 0.0 {
            self.neg()
        } else {
            I::new(0.0, (-self.lo).max(self.hi)).or_nan(self.nan)
        }
    }
    fn square(self) -> I {
        let a = self.abs();
        I::new(a.lo * a.lo, a.hi * a.hi).or_nan(a.nan)
    }
    fn min(self, o: I) -> I {
        I::new(self.lo.min(o.lo), self.hi.min(o.hi)).dropping(self, o)
    }
    fn max(self, o: I) -> I {
        I::new(self.lo.max(o.lo), self.hi.max(o.hi)).dropping(self, o)
    }
    /// The bounds `self` of a `min` or `max` of `a` and `b` (for numbers), with what the kernel
    /// makes of a NaN operand: `max(a, b)` is `a` where `b` is NaN and NaN where `a` is. The
    /// graph treats them as commutative (it orders their operands by id, and tapes put a
    /// constant second), so either operand may be the one kept: both are taken in.
    fn dropping(self, a: I, b: I) -> I {
        let i = self.or_nan(a.nan || b.nan);
        let i = if a.nan { i.union(b) } else { i };
        if b.nan { i.union(a) } else { i }
    }
    /// A truth value: certainly true, certainly false, or either.
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
        return I::point(k::un(op, a.lo));
    }
    match op {
        Un::Neg => a.neg(),
        Un::Abs => a.abs(),
        // NaN below zero, which a `min` or `max` would drop: nothing is known there.
        Un::Sqrt if a.lo < 0.0 => I::UNDEFINED,
        Un::Sqrt => I::new(a.lo.sqrt(), a.hi.sqrt()).or_nan(a.nan),
        Un::Floor => a.up(f64::floor),
        Un::Ceil => a.up(f64::ceil),
        Un::Round => a.up(k::round),
        Un::Fract if a.lo.floor() == a.hi.floor() => a.up(|x| x - x.floor()),
        Un::Fract => I::new(0.0, 1.0).or_nan(a.nan),
        // The sign of NaN is 0.
        Un::Sign if a.nan => I::new(a.lo, a.hi)
            .up(|x| k::un(Un::Sign, x))
            .union(I::point(0.0)),
        Un::Sign => a.up(|x| k::un(Un::Sign, x)),
        Un::Sin | Un::Cos => I::new(-1.0, 1.0).or_nan(a.nan),
        Un::Tan => I::ALL.or_nan(a.nan),
        // `log(0)` is `-inf`, which a product with 0 or a difference makes NaN.
        Un::Asin | Un::Atan | Un::Exp | Un::Ln => a.up(|x| k::un(op, x)),
        Un::Acos => I::new(a.hi.acos(), a.lo.acos()).or_nan(a.nan),
        // `!NaN` is 0, as `!x` for any `x` that is not 0.
        Un::Not => I::truth(false, a.excludes_zero()),
    }
}

fn bin(op: Bin, a: I, b: I) -> I {
    // A point at 0 may be either zero (`0 * -x`), which these tell apart: `1 / -0` is `-inf`.
    let signed = matches!(op, Bin::Div | Bin::Pow | Bin::Atan2);
    if a.is_point() && b.is_point() && !(signed && (a.lo == 0.0 || b.lo == 0.0)) {
        return I::point(k::bin(op, a.lo, b.lo));
    }
    let nan = a.nan || b.nan;
    match op {
        Bin::Add => a.add(b),
        Bin::Sub => a.add(b.neg()),
        Bin::Mul => a.mul(b),
        Bin::Div if b.excludes_zero() => a.mul(I::new(1.0 / b.hi, 1.0 / b.lo).or_nan(b.nan)),
        // `0 / 0`.
        Bin::Div => I::ALL.or_nan(nan || a.contains(0.0)),
        // `x mod 0` is NaN, and `x mod inf`.
        Bin::Mod => {
            let m = b.abs().hi;
            I::new(-m, m).or_nan(nan || !b.excludes_zero() || m.is_infinite())
        }
        Bin::Min => a.min(b),
        Bin::Max => a.max(b),
        // A negative number to a power that is not a whole number.
        Bin::Pow => {
            let whole = b.is_point() && b.lo.fract() == 0.0;
            I::ALL.or_nan(nan || (a.lo < 0.0 && !whole))
        }
        Bin::Atan2 => I::ALL.or_nan(nan),
        // A comparison with NaN is false (0), `!=` true: never certainly the other.
        Bin::Lt => I::truth(a.hi < b.lo && !nan, a.lo >= b.hi),
        Bin::Le => I::truth(a.hi <= b.lo && !nan, a.lo > b.hi),
        Bin::Eq => I::truth(false, a.hi < b.lo || a.lo > b.hi),
        Bin::Ne => I::truth(a.hi < b.lo || a.lo > b.hi, false),
        Bin::And | Bin::Or => {
            // NaN is not 0, so it is true: an operand that may be NaN is not certainly 0.
            let no = |x: I| x == I::point(0.0);
            if op == Bin::And {
                I::truth(a.excludes_zero() && b.excludes_zero(), no(a) || no(b))
            } else {
                I::truth(a.excludes_zero() || b.excludes_zero(), no(a) && no(b))
            }
        }
    }
}

/// Bounds of every node of a graph, filled in id order (children before parents).
#[derive(Clone, Debug, Default)]
pub struct Intervals {
    vals: Vec<I>,
    /// Where each node's outputs start in `outs` when it is a tuple bounded here (read
    /// through `Proj`), `u32::MAX` otherwise: flat, since a union of a thousand objects is a
    /// thousand min-with-id tuples and every cell bounds them.
    start: Vec<u32>,
    outs: Vec<I>,
}

/// The buffers of `Intervals::along`, kept between rays: an escape proof is tried for many
/// rays, and allocating them each time was a sixth of its cost.
#[derive(Default)]
pub struct Along {
    iv: Intervals,
    lines: Vec<Line>,
    /// The outputs of tuples followed exactly (`cell`), and where each node's start
    /// (`u32::MAX` for none).
    tuples: Vec<Line>,
    tuple_start: Vec<u32>,
}

impl Along {
    /// Where the stretch last bounded (`Intervals::along` over `len` on `g`) crosses a side of
    /// a tiling's cell, in order, into `out`: the first `most` of them, and `len` after them
    /// unless there were more. Bounded piece by piece between them, each piece lies in one cell
    /// of every tiling, where `cell` follows it exactly. False, leaving `out` empty, where a
    /// tiling's operands are not lines through points along the stretch, or it crosses no side.
    pub fn crossings(&self, g: &Graph, len: f64, most: usize, out: &mut Vec<f64>) -> bool {
        out.clear();
        let line = |x: Id| {
            let l = self.lines[x.0 as usize];
            (l.base.is_point() && l.slope.is_finite()).then_some((l.base.lo, l.slope))
        };
        for i in 0..g.len() {
            match g.get(Id(i as u32)) {
                Node::D4(v) => {
                    let [Some(x), Some(y), Some(z), Some(w)] = v.map(line) else {
                        out.clear();
                        return false;
                    };
                    let base = [x.0, y.0, z.0, w.0];
                    let slope = [x.1, y.1, z.1, w.1];
                    d4_crossings(base, slope, len, most + 1, out);
                }
                Node::Rep(x, l) => {
                    let Some((base, slope)) = line(x) else {
                        out.clear();
                        return false;
                    };
                    rep_crossings(base, slope, l.get(), len, most + 1, out);
                }
                _ => {}
            }
        }
        if out.is_empty() || !len.is_finite() {
            out.clear();
            return false;
        }
        out.sort_by(f64::total_cmp);
        out.dedup();
        if out.len() > most {
            out.truncate(most);
        } else {
            out.push(len);
        }
        true
    }
}

/// A node's value along a ray as `base + slope * s` for every `s` in `0..=len` (the distance
/// from the ray's start; `len` may be infinite): exact for the linear parts of a graph
/// (planes, turned and moved points).
#[derive(Clone, Copy, Debug)]
struct Line {
    base: I,
    slope: f64,
}

impl Line {
    fn point(x: f64) -> Line {
        Line {
            base: I::point(x),
            slope: 0.0,
        }
    }
    /// This line, or a constant of unknown value where its base or slope is NaN: a parent
    /// reads its operands' lines (`line`, `pick`), and a NaN there would drop out of a
    /// comparison as the bounds' `min` and `max` drop it (`I::known`).
    fn known(self) -> Line {
        if self.base.lo.is_nan() || self.base.hi.is_nan() || self.slope.is_nan() {
            Line {
                base: I::UNDEFINED,
                slope: 0.0,
            }
        } else {
            self
        }
    }
    /// Every value over `0..=len`.
    fn range(self, len: f64) -> I {
        match self.slope {
            m if m > 0.0 => I::new(self.base.lo, self.base.hi + m * len).or_nan(self.base.nan),
            m if m < 0.0 => I::new(self.base.lo + m * len, self.base.hi).or_nan(self.base.nan),
            0.0 => self.base,
            _ => I::UNDEFINED,
        }
    }
    fn add(self, o: Line) -> Line {
        Line {
            base: self.base.add(o.base),
            slope: self.slope + o.slope,
        }
    }
    fn scale(self, c: f64) -> Line {
        Line {
            base: self.base.mul(I::point(c)),
            slope: self.slope * c,
        }
    }
    /// A constant, if this is one.
    fn constant(self) -> Option<f64> {
        (self.slope == 0.0 && self.base.is_point() && self.base.lo.is_finite())
            .then_some(self.base.lo)
    }
    /// Whether `self <= o - margin` for every `s` in `0..=len`: at both ends, the far one at
    /// infinity a matter of slopes.
    fn below(self, o: Line, margin: f64, len: f64) -> bool {
        let far = if len.is_finite() {
            self.base.hi + self.slope * len + margin <= o.base.lo + o.slope * len
        } else {
            self.slope <= o.slope
        };
        far && self.base.hi + margin <= o.base.lo
    }
}

/// The linear form of node `n` along the ray from `o` along `d` for `s` in `0..=len`, where it
/// has one.
fn line(n: &Node, f: &[Line], o: [f64; 4], d: [f64; 4], len: f64) -> Option<Line> {
    let g = |x: Id| f[x.0 as usize];
    // Linear forms hold for numbers: an operand that may be NaN is bounded (`Intervals::node`),
    // which knows where the kernel drops a NaN.
    if n.children().iter().any(|&x| g(x).base.nan) {
        return None;
    }
    let row = |v: [Id; 4], r: [super::K; 5]| {
        (0..4).fold(Line::point(r[4].get()), |acc, i| {
            acc.add(g(v[i]).scale(r[i].get()))
        })
    };
    Some(match *n {
        Node::Var(v) if v.index() < 4 => Line {
            base: I::point(o[v.index()]),
            slope: d[v.index()],
        },
        Node::Const(c) => Line::point(c.get()),
        Node::Un(Un::Neg, a) => g(a).scale(-1.0),
        Node::Un(Un::Abs, a) => match g(a).range(len) {
            r if r.lo >= 0.0 => g(a),
            r if r.hi <= 0.0 => g(a).scale(-1.0),
            _ => return None,
        },
        Node::Bin(Bin::Add, a, b) => g(a).add(g(b)),
        Node::Bin(Bin::Sub, a, b) => g(a).add(g(b).scale(-1.0)),
        Node::Bin(Bin::Mul, a, b) => match (g(a).constant(), g(b).constant()) {
            (Some(c), _) => g(b).scale(c),
            (_, Some(c)) => g(a).scale(c),
            _ => return None,
        },
        Node::Bin(Bin::Div, a, b) => match g(b).constant() {
            Some(c) if c != 0.0 => g(a).scale(1.0 / c),
            _ => return None,
        },
        // A branch that wins all along the ray (by the blend width, for smooth ones).
        Node::Bin(op @ (Bin::Min | Bin::Max), a, b) => pick(op == Bin::Min, g(a), g(b), 0.0, len)?,
        Node::SMin(a, b, k) => pick(true, g(a), g(b), g(k).constant()?.max(0.0), len)?,
        Node::SMax(a, b, k) => pick(false, g(a), g(b), g(k).constant()?.max(0.0), len)?,
        Node::Select(c, a, b) => match g(c).range(len) {
            c if c == I::point(0.0) => g(b),
            c if c.excludes_zero() => g(a),
            _ => return None,
        },
        Node::Affine(v, r) => row(v, r),
        _ => return None,
    })
}

/// The operand of a min (`min`) or max that it returns all along the ray (to `len`), if one
/// does by at least `margin`.
fn pick(min: bool, a: Line, b: Line, margin: f64, len: f64) -> Option<Line> {
    let (lo, hi) = if a.below(b, margin, len) {
        (a, b)
    } else if b.below(a, margin, len) {
        (b, a)
    } else {
        return None;
    };
    Some(if min { lo } else { hi })
}

/// How far outside a tiling's cell (in cell units) an end of a stretch may lie and still count
/// as in it: a stretch split at the cells' sides (`Along::crossings`) ends on one, where
/// rounding may put it either way; a tiled field that is continuous across the side (its
/// pieces fit in their cells) moves by no more than this there.
const SIDE: f64 = 1e-9;

/// The outputs of a tiling's node (`D4`, `Rep`) as lines, where its operands are lines through
/// points and both ends of the stretch fall in the cell of its midpoint (to within `SIDE`): the
/// cells are convex, so the whole stretch is in it, and the offset from its centre is the
/// operand less a constant.
fn cell(n: &Node, f: &[Line], len: f64) -> Option<[Line; 8]> {
    if !matches!(n, Node::D4(_) | Node::Rep(..)) {
        return None;
    }
    let g = |x: Id| f[x.0 as usize];
    let ends = |l: Line| {
        (l.base.is_point() && l.slope.is_finite() && len.is_finite())
            .then_some((l.base.lo, l.base.lo + l.slope * len))
    };
    let mut out = [Line::point(0.0); 8];
    match *n {
        Node::D4(v) => {
            let v = v.map(g);
            let e: [(f64, f64); 4] = [ends(v[0])?, ends(v[1])?, ends(v[2])?, ends(v[3])?];
            let mid = k::d4(e.map(|x| 0.5 * (x.0 + x.1)));
            let c: [f64; 4] = std::array::from_fn(|i| mid[4 + i]);
            if !(d4_holds(c, e.map(|x| x.0)) && d4_holds(c, e.map(|x| x.1))) {
                return None;
            }
            for i in 0..4 {
                out[i] = Line {
                    base: I::point(e[i].0 - c[i]),
                    slope: v[i].slope,
                };
                out[4 + i] = Line::point(c[i]);
            }
        }
        Node::Rep(x, l) => {
            let (x, l) = (g(x), l.get());
            let (s, e) = ends(x)?;
            let c = k::rep(0.5 * (s + e), l)[1];
            let holds =
                |x: f64| (c >= l || x - c <= 0.5 + SIDE) && (c <= -l || c - x <= 0.5 + SIDE);
            if !(holds(s) && holds(e)) {
                return None;
            }
            out[0] = Line {
                base: I::point(s - c),
                slope: x.slope,
            };
            out[1] = Line::point(c);
        }
        _ => return None,
    }
    Some(out)
}

/// Whether `x` lies in the cell of D4 point `c` (to within `SIDE`): the cell (a 24-cell) is
/// bounded by the planes `(x - c) . v = 1` of the 24 shortest vectors `v = +-e_i +-e_j`, so `x`
/// is in it when no two coordinates of `x - c` sum to more than 1 in magnitude.
fn d4_holds(c: [f64; 4], x: [f64; 4]) -> bool {
    let (mut first, mut second) = (0.0f64, 0.0f64);
    for i in 0..4 {
        let a = (x[i] - c[i]).abs();
        if a > first {
            (first, second) = (a, first);
        } else if a > second {
            second = a;
        }
    }
    first + second <= 1.0 + SIDE
}

/// The D4 shortest vectors `+-e_i +-e_j` (as `(i, j, sign_i, sign_j)`).
const D4_SHORTEST: [(usize, usize, f64, f64); 24] = {
    let mut out = [(0, 0, 0.0, 0.0); 24];
    let mut n = 0;
    let mut i = 0;
    while i < 4 {
        let mut j = i + 1;
        while j < 4 {
            out[n] = (i, j, 1.0, 1.0);
            out[n + 1] = (i, j, 1.0, -1.0);
            out[n + 2] = (i, j, -1.0, 1.0);
            out[n + 3] = (i, j, -1.0, -1.0);
            n += 4;
            j += 1;
        }
        i += 1;
    }
    out
};

/// Where the line `base + slope * s` (in lattice units) crosses from one D4 cell into the next,
/// for `s` in `(0, len)`: from the cell of `base`, through the side it leaves by, to the cell
/// beyond it; at most `most` crossings, pushed onto `out`. Only candidates: `cell` checks each
/// piece between them, so a corner crossed into the wrong neighbour costs a loose bound, never
/// a wrong one.
fn d4_crossings(base: [f64; 4], slope: [f64; 4], len: f64, most: usize, out: &mut Vec<f64>) {
    let at = k::d4(base);
    let mut c: [f64; 4] = std::array::from_fn(|i| at[4 + i]);
    let mut s = 0.0f64;
    for _ in 0..most {
        let y: [f64; 4] = std::array::from_fn(|i| base[i] - c[i]);
        let mut exit = (f64::INFINITY, 0);
        for (k, &(i, j, a, b)) in D4_SHORTEST.iter().enumerate() {
            let rate = a * slope[i] + b * slope[j];
            if rate > 0.0 {
                let t = (1.0 - a * y[i] - b * y[j]) / rate;
                if t < exit.0 {
                    exit = (t, k);
                }
            }
        }
        if exit.0.is_nan() || exit.0 >= len {
            break;
        }
        s = s.max(exit.0);
        out.push(s);
        let (i, j, a, b) = D4_SHORTEST[exit.1];
        (c[i], c[j]) = (c[i] + a, c[j] + b);
    }
}

/// Where the line `base + slope * s` (in cell units) crosses from one cell of a repetition
/// with cells `-l..=l` into the next, for `s` in `(0, len)`; at most `most`, onto `out`.
fn rep_crossings(base: f64, slope: f64, l: f64, len: f64, most: usize, out: &mut Vec<f64>) {
    let mut c = k::rep(base, l)[1];
    let dir = if slope > 0.0 { 1.0 } else { -1.0 };
    for _ in 0..most {
        // The last cell on this side reaches to infinity.
        if slope == 0.0 || c * dir >= l {
            break;
        }
        let t = (c + 0.5 * dir - base) / slope;
        if t.is_nan() || t >= len {
            break;
        }
        out.push(t.max(0.0));
        c += dir;
    }
}

/// The values of `|v + offset| - sub` (a `Length` node's `r`) for `s` in `0..=len` when every
/// coordinate is a line through points (`base` a point): the square is a quadratic in `s`,
/// least at its vertex (clamped to the stretch) and greatest at an end.
fn sphere(v: [Line; 4], r: [super::K; 5], len: f64) -> Option<I> {
    if !len.is_finite() || v.iter().any(|l| !l.base.is_point()) {
        return None;
    }
    let c: [f64; 4] = std::array::from_fn(|i| v[i].base.lo + r[i].get());
    let (mut a, mut b) = (0.0, 0.0);
    for i in 0..4 {
        a += v[i].slope * v[i].slope;
        b += v[i].slope * c[i];
    }
    // Evaluated as a sum of squares at each point, not expanded, so no cancellation.
    let at = |s: f64| {
        (0..4)
            .map(|i| (c[i] + v[i].slope * s).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let vertex = if a > 0.0 {
        (-b / a).clamp(0.0, len)
    } else {
        0.0
    };
    let (lo, hi) = (at(vertex), at(0.0).max(at(len)));
    (lo.is_finite() && hi.is_finite()).then(|| I::new(lo, hi).add(I::point(-r[4].get())))
}

impl Intervals {
    /// Bounds of every node over the ray from `o` along `d` (`s` in `0..=len`, `len` infinite
    /// for the rest of the ray), in `along`'s buffers: linear parts are followed exactly along
    /// it, a translated sphere's distance exactly too (its square is a quadratic in `s`), the
    /// rest bounded over the values their operands take there. At least as tight as bounds over
    /// the box the ray spans, and tighter wherever the ray's coordinates are correlated (a
    /// plane turned out of the axes, a sphere the ray passes).
    pub fn along<'a>(
        along: &'a mut Along,
        g: &Graph,
        o: [f64; 4],
        d: [f64; 4],
        len: f64,
    ) -> &'a Intervals {
        let span = |a: usize| {
            Line {
                base: I::point(o[a]),
                slope: d[a],
            }
            .range(len)
        };
        let vars = |v: Var| match v.index() {
            a @ 0..4 => span(a),
            _ => I::ALL,
        };
        let Along {
            iv,
            lines,
            tuples,
            tuple_start,
        } = along;
        iv.vals.clear();
        iv.start.clear();
        iv.outs.clear();
        lines.clear();
        tuples.clear();
        tuple_start.clear();
        for (i, n) in g.nodes().iter().enumerate() {
            let outs = iv.outs.len();
            // A projection of a tuple followed exactly is its output's line.
            let l = match *n {
                Node::Proj(t, j) if tuple_start[t.0 as usize] != u32::MAX => {
                    Some(tuples[tuple_start[t.0 as usize] as usize + j as usize])
                }
                _ => line(n, lines, o, d, len),
            };
            tuple_start.push(u32::MAX);
            if let Some(exact) = cell(n, lines, len) {
                let exact = exact.map(Line::known);
                tuple_start[i] = tuples.len() as u32;
                tuples.extend_from_slice(&exact[..n.arity()]);
                // A line's range may still meet `inf - inf` at an infinite `len`.
                iv.outs
                    .extend(exact[..n.arity()].iter().map(|l| l.range(len).known()));
                iv.vals.push(I::ALL);
                iv.start.push(outs as u32);
                lines.push(Line::point(f64::NAN));
                continue;
            }
            let l = match l {
                Some(l) => l,
                None => Line {
                    base: match *n {
                        Node::Length(v, r) => sphere(v.map(|x| lines[x.0 as usize]), r, len)
                            .unwrap_or_else(|| iv.node(*n, &vars)),
                        _ => iv.node(*n, &vars),
                    },
                    slope: 0.0,
                },
            }
            .known();
            iv.vals.push(l.range(len).known());
            iv.start.push(if iv.outs.len() > outs {
                outs as u32
            } else {
                u32::MAX
            });
            lines.push(l);
        }
        iv
    }

    /// Bounds of the nodes `live` marks (all when `None`) for inputs in `vars`.
    pub fn of(g: &Graph, vars: &impl Fn(Var) -> I, live: Option<&[bool]>) -> Intervals {
        let mut iv = Intervals::default();
        iv.extend(g, vars, live);
        iv
    }

    /// Bound the nodes added to `g` since the last call.
    pub fn extend(&mut self, g: &Graph, vars: &impl Fn(Var) -> I, live: Option<&[bool]>) {
        self.vals.reserve(g.len().saturating_sub(self.vals.len()));
        self.start.reserve(g.len().saturating_sub(self.start.len()));
        for i in self.vals.len()..g.len() {
            let outs = self.outs.len();
            let v = if live.is_none_or(|l| l[i]) {
                self.node(g.get(Id(i as u32)), vars).known()
            } else {
                I::ALL
            };
            self.vals.push(v);
            self.start.push(if self.outs.len() > outs {
                outs as u32
            } else {
                u32::MAX
            });
        }
    }

    pub fn get(&self, id: Id) -> I {
        self.vals[id.0 as usize]
    }

    /// The bounds of scalar node `n`; a tuple's go to `outs`, and it gets `I::ALL`.
    fn node(&mut self, n: Node, vars: &impl Fn(Var) -> I) -> I {
        let g = |x: Id| self.vals[x.0 as usize];
        let v4 = |v: [Id; 4]| v.map(g);
        let row = |r: &[super::K]| -> [f64; 9] {
            let mut out = [0.0; 9];
            for (o, x) in out.iter_mut().zip(r) {
                *o = x.get();
            }
            out
        };
        let tuple: Vec<I> = match n {
            Node::Var(v) => return vars(v),
            Node::Const(c) => return I::point(c.get()),
            Node::Un(op, a) => return un(op, g(a)),
            // A number times itself is a square, never negative (`sqrt(x * x + y * y)`).
            Node::Bin(Bin::Mul, a, b) if a == b => return g(a).square(),
            Node::Bin(op, a, b) => return bin(op, g(a), g(b)),
            Node::Proj(t, i) => {
                let start = self.start[t.0 as usize];
                return if start == u32::MAX {
                    I::ALL
                } else {
                    self.outs[start as usize + i as usize]
                };
            }
            Node::Select(c, a, b) => {
                let c = g(c);
                return if c == I::point(0.0) {
                    g(b)
                } else if c.excludes_zero() {
                    g(a)
                } else {
                    g(a).union(g(b))
                };
            }
            Node::Length(v, r) => {
                let r = row(&r);
                let s = (0..4).fold(I::point(0.0), |acc, i| {
                    acc.add(g(v[i]).add(I::point(r[i])).square())
                });
                return un(Un::Sqrt, s).add(I::point(-r[4]));
            }
            Node::Affine(v, r) => {
                let r = row(&r);
                // A slot of coefficient 0 (a row of fewer than four inputs repeats its first)
                // adds 0, or NaN where its input is NaN or an infinity itself (a constant one
                // folded in): not the whole line that `0 * x` over an unbounded `x` gives.
                return (0..4).fold(I::point(r[4]), |acc, i| {
                    let x = g(v[i]);
                    match r[i] == 0.0 {
                        true if x.lo == x.hi && x.lo.is_infinite() => I::UNDEFINED,
                        true => acc.or_nan(x.nan),
                        false => acc.add(x.mul(I::point(r[i]))),
                    }
                });
            }
            // A NaN face makes the distance NaN (the kernel's `max(q, 0)` keeps it), which the
            // bounds' `max` of the faces below would drop.
            Node::BoxDist(v, _) if v.iter().any(|&x| g(x).nan) => return I::UNDEFINED,
            Node::BoxDist(v, r) => {
                let r = row(&r);
                let q: [I; 4] = std::array::from_fn(|i| {
                    g(v[i]).add(I::point(r[i])).abs().add(I::point(-r[4 + i]))
                });
                let o = q.iter().fold(I::point(0.0), |acc, x| {
                    acc.add(x.max(I::point(0.0)).square())
                });
                let m = q[1..].iter().fold(q[0], |acc, x| acc.max(*x));
                return un(Un::Sqrt, o)
                    .add(m.min(I::point(0.0)))
                    .add(I::point(-r[8]));
            }
            // Smooth min is nondecreasing in a and b and nonincreasing in k.
            // A NaN operand makes the blend NaN; with no blend (`k <= 0`, or a NaN `k`, for
            // which `k > 0` is false) they are `min` and `max`, which may drop it.
            Node::SMin(a, b, kk) => {
                let (a, b, kk) = (g(a), g(b), g(kk));
                let least = if kk.nan { kk.lo.min(0.0) } else { kk.lo };
                let i = I::new(smin(a.lo, b.lo, kk.hi), smin(a.hi, b.hi, least));
                return i.or_nan(kk.nan).dropping(a, b);
            }
            Node::SMax(a, b, kk) => {
                let (a, b, kk) = (g(a), g(b), g(kk));
                let least = if kk.nan { kk.lo.min(0.0) } else { kk.lo };
                let i = I::new(-smin(-a.lo, -b.lo, least), -smin(-a.hi, -b.hi, kk.hi));
                return i.or_nan(kk.nan).dropping(a, b);
            }
            Node::D4(v) => {
                let v = v4(v);
                if v.iter().all(|x| x.is_point()) {
                    k::d4(v.map(|x| x.lo)).map(I::point).to_vec()
                } else {
                    // Offsets stay inside the Voronoi cell (|x_i| <= 1); points are near.
                    let near = v.map(|x| I::new(x.lo.floor() - 1.0, x.hi.ceil() + 1.0));
                    [[I::new(-1.0, 1.0); 4], near].concat()
                }
            }
            Node::Rep(a, l) => {
                let (a, l) = (g(a), l.get());
                let (clo, chi) = (k::rep(a.lo, l)[1], k::rep(a.hi, l)[1]);
                if clo == chi {
                    vec![a.add(I::point(-clo)), I::point(clo)]
                } else {
                    vec![
                        I::new((-0.5f64).min(a.lo - clo), 0.5f64.max(a.hi - chi)),
                        I::new(clo, chi),
                    ]
                }
            }
            Node::MinId(a, b, c, id) => {
                let (best, best_id, d) = (g(a), g(b), g(c));
                let id = match min_id_choice(best, d) {
                    Some(true) => I::point(id.get()),
                    Some(false) => best_id,
                    None => best_id.union(I::point(id.get())),
                };
                self.outs.extend([best.min(d), id]);
                return I::ALL;
            }
        };
        let nan = n.children().iter().any(|&x| g(x).nan);
        self.outs
            .extend(tuple.into_iter().map(|x| x.or_nan(nan).known()));
        I::ALL
    }
}

/// The smooth min at bounds, which may be infinite: where an operand is, the blend is zero
/// and it is the plain min (the kernel's `|a - b|` is NaN for two alike infinities, and a
/// NaN bound of a halfspace's blend over all space read as a min's `+inf` cut it from the
/// cells outside the cube).
fn smin(a: f64, b: f64, kk: f64) -> f64 {
    if a.is_infinite() || b.is_infinite() {
        a.min(b)
    } else {
        k::smin(a, b, kk)
    }
}

/// Which operand `min_id(best, _, d, _)` returns over the bounds: `Some(true)` for `d`
/// (`d < best` everywhere, neither NaN: a comparison with NaN is false), `Some(false)` for
/// `best`, `None` when it varies.
pub fn min_id_choice(best: I, d: I) -> Option<bool> {
    if d.hi < best.lo && !best.nan && !d.nan {
        Some(true)
    } else if d.lo >= best.hi {
        Some(false)
    } else {
        None
    }
}
