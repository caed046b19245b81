//! Forms of a cell's graph that `f32` evaluates as precisely as the cell needs. Tapes run in
//! `f32` in coordinates local to their cell, which keeps the point's own bits; but a distance
//! that is the difference of two large numbers loses them anyway: `|v + q| - R` for a
//! hypersphere of radius 1e5 is quantised to about 0.008 however small `v` is. Where that
//! rounding would exceed a fraction of the cell's precision (`quantum`), such nodes are
//! rewritten into forms whose error scales with `v`, not with `R`:
//!
//! - a hypersphere, `|v + q| - R = (|q|^2 - R^2 + 2 q.v + v.v) / (|v + q| + R)`, with the
//!   constant `|q|^2 - R^2 = (|q| - R)(|q| + R)` computed in `f64`;
//! - a hyperbox, whose `|v_i + o_i| - h_i` is `s v_i + (|o_i| - h_i)` wherever `v_i + o_i`
//!   keeps its sign `s`: the same instruction, with the offset folded into the half-extent.
//!
//! The graph the children of a cell are pruned from keeps the plain forms (its constants are
//! `f64`, and intervals bound them more tightly); only the tapes use these.

use super::interval::{I, Intervals};
use super::{Bin, Graph, Id, K, Node, Un, Var};

/// The rounding of one `f32` operation, relative to the size of its result.
const ULP: f64 = 1.0 / (1u64 << 24) as f64;
/// The share of the cell's precision that the rounding of one node may take.
const SHARE: f64 = 0.125;

/// `roots` of `g`, with the large-offset nodes rewritten where their `f32` rounding would
/// exceed `SHARE * quantum` for points in `region`; `None` when no node needs it.
pub fn precise(g: &Graph, roots: &[Id], region: [I; 4], quantum: f64) -> Option<(Graph, Vec<Id>)> {
    let coarse = |x: f64| 2.0 * x.abs() * ULP > SHARE * quantum;
    let live = g.live(roots);
    // Large offsets in the operands cancel against the node's own (an object turned about
    // a far point); a large radius cancels against the length, and a box's large offset
    // against its half-extent.
    let far = |v: [Id; 4]| v.iter().any(|x| coarse(offset(g, *x)));
    let large = |r: &[K]| r.iter().any(|x| coarse(x.get()));
    let wants = |i: usize| match g.get(Id(i as u32)) {
        Node::Length(v, r) => far(v) || (r[4].get() > 0.0 && large(&r[4..])),
        Node::BoxDist(v, r) => far(v) || large(&r[..4]),
        _ => false,
    };
    if !(0..g.len()).any(|i| live[i] && wants(i)) {
        return None;
    }
    let vars = |v: Var| match v {
        Var::X | Var::Y | Var::Z | Var::W => region[v.index()],
        Var::NX | Var::NY | Var::NZ | Var::NW => I::new(-1.0, 1.0),
        Var::T => I::ALL,
    };
    let iv = Intervals::of(g, &vars, Some(&live));
    let mut out = Graph::new();
    let mut map = vec![Id(u32::MAX); g.len()];
    for i in (0..g.len()).filter(|i| live[*i]) {
        let n = g.get(Id(i as u32));
        let m = n.map(|c| map[c.0 as usize]);
        map[i] = match (m, wants(i)) {
            (Node::Length(v, r), true) => {
                let (v, q) = centred(&mut out, v, std::array::from_fn(|a| r[a].get()));
                let radius = r[4].get();
                if radius > 0.0 && coarse(radius) {
                    sphere(&mut out, v, q, radius)
                } else {
                    let k = |x: f64| K::new(x);
                    out.intern(Node::Length(v, [k(q[0]), k(q[1]), k(q[2]), k(q[3]), r[4]]))
                }
            }
            (Node::BoxDist(v, r), true) => {
                let mut r = r.map(K::get);
                let span: [I; 4] = std::array::from_fn(|a| iv.get(n.children()[a]));
                let (v, o) = centred(&mut out, v, std::array::from_fn(|a| r[a]));
                for a in 0..4 {
                    // The operand lost the offset `o - r` to the box's.
                    let moved = o[a] - r[a];
                    r[a] = o[a];
                    let s = I::new(span[a].lo - moved, span[a].hi - moved);
                    if coarse(r[a]) {
                        fold_face(&mut r, a, s);
                    }
                }
                out.intern(Node::BoxDist(v, r.map(K::new)))
            }
            (m, _) => out.intern(m),
        };
    }
    Some((out, roots.iter().map(|r| map[r.0 as usize]).collect()))
}

/// The constant an affine operand adds (0 for others).
fn offset(g: &Graph, x: Id) -> f64 {
    match g.get(x) {
        Node::Affine(_, row) => row[4].get(),
        _ => 0.0,
    }
}

/// Operands `v` with offsets `off` (`|v + off|`), with the offsets of affine operands moved
/// into `off`: the operands are then as small as the cell, and `off` holds the large part.
fn centred(g: &mut Graph, v: [Id; 4], off: [f64; 4]) -> ([Id; 4], [f64; 4]) {
    let (mut v, mut off) = (v, off);
    for a in 0..4 {
        if let Node::Affine(x, mut row) = g.get(v[a])
            && offset(g, v[a]) != 0.0
        {
            off[a] += offset(g, v[a]);
            row[4] = K::new(0.0);
            v[a] = g.intern(Node::Affine(x, row));
        }
    }
    (v, off)
}

/// `|v + q| - R` as `(|q|^2 - R^2 + 2 q.v + v.v) / (|v + q| + R)`: each term of the
/// numerator is rounded relative to `R |v|` at most, and the division by about `2R` leaves
/// an error relative to `|v|`.
fn sphere(g: &mut Graph, v: [Id; 4], q: [f64; 4], radius: f64) -> Id {
    let norm = q.iter().map(|x| x * x).sum::<f64>().sqrt();
    let c = (norm - radius) * (norm + radius);
    let k = |x: f64| K::new(x);
    let linear = g.intern(Node::Affine(
        v,
        [
            k(2.0 * q[0]),
            k(2.0 * q[1]),
            k(2.0 * q[2]),
            k(2.0 * q[3]),
            k(c),
        ],
    ));
    let len = g.intern(Node::Length(v, [k(0.0); 5]));
    let square = g.intern(Node::Bin(Bin::Mul, len, len));
    let num = g.intern(Node::Bin(Bin::Add, linear, square));
    let den = g.intern(Node::Length(
        v,
        [k(q[0]), k(q[1]), k(q[2]), k(q[3]), k(-radius)],
    ));
    g.intern(Node::Bin(Bin::Div, num, den))
}

/// Axis `a` of a hyperbox (`r`: offset, half-extents, rounding) whose operand spans `s`: if
/// `x + o` keeps one sign `sign` there, `|x + o| - h = sign x + sign o - h`, which is also
/// `|x + sign m| - (m - sign o + h)` for any `m >= 0` that keeps `x + sign m` of that sign:
/// small constants, exact in `f64`. (The sign is that of `x + o`, not of `o`: a tiled box's
/// operand can lie past `-o`. Where `x` has the sign already, `m` is 0.)
fn fold_face(r: &mut [f64; 9], a: usize, s: I) {
    let (o, h) = (r[a], r[4 + a]);
    let shifted = I::new(s.lo + o, s.hi + o);
    if !(shifted.excludes_zero() && s.lo.is_finite() && s.hi.is_finite()) {
        return;
    }
    let sign = shifted.lo.signum();
    // The least of `sign x` over the span; `m` must exceed its negative. A power of two,
    // exact in `f32`.
    let least = if sign > 0.0 { s.lo } else { -s.hi };
    let m = if least > 0.0 {
        0.0
    } else {
        (-2.0 * least).max(f64::MIN_POSITIVE).log2().ceil().exp2()
    };
    r[a] = sign * m;
    r[4 + a] = m - sign * o + h;
}

/// A bound of how far `f32` evaluation of `root` of `g` strays from its exact value for
/// points in `region` (in `f32` already, so rounded like the tape's inputs): each operation
/// rounds its result by `ULP` of it and passes its operands' errors on as far as its slope
/// over the region allows. Infinite where that is unknown (a discontinuous step, a division
/// by what may be zero).
pub fn rounding(g: &Graph, root: Id, region: [I; 4]) -> f64 {
    let live = g.live(&[root]);
    let vars = |v: Var| match v {
        Var::X | Var::Y | Var::Z | Var::W => region[v.index()],
        Var::NX | Var::NY | Var::NZ | Var::NW => I::new(-1.0, 1.0),
        Var::T => I::ALL,
    };
    let iv = Intervals::of(g, &vars, Some(&live));
    let size = |x: I| x.lo.abs().max(x.hi.abs());
    // Scalars' errors by node, and the outputs' of tuples.
    let mut err = vec![0.0f64; g.len()];
    let mut outs: Vec<[f64; 8]> = vec![[0.0; 8]; g.len()];
    for i in (0..g.len()).filter(|i| live[*i]) {
        let n = g.get(Id(i as u32));
        let (e, m) = (|x: Id| err[x.0 as usize], |x: Id| size(iv.get(x)));
        let round = ULP * size(iv.get(Id(i as u32)));
        err[i] = match n {
            Node::Var(v) => ULP * size(vars(v)),
            // The running min's start, +infinity, is exact.
            Node::Const(k) if k.get().is_infinite() => 0.0,
            Node::Const(k) => ULP * k.get().abs(),
            Node::Un(op, a) => match op {
                Un::Neg | Un::Abs => e(a),
                // 1-Lipschitz.
                Un::Sin | Un::Cos | Un::Atan => e(a) + round,
                Un::Sqrt => {
                    let lo = iv.get(a).lo.max(0.0).sqrt();
                    (e(a) / (2.0 * lo)).min(e(a).sqrt()) + round
                }
                _ => f64::INFINITY,
            },
            Node::Bin(op, a, b) => match op {
                Bin::Add | Bin::Sub => e(a) + e(b) + round,
                Bin::Mul => m(a) * e(b) + m(b) * e(a) + e(a) * e(b) + round,
                Bin::Div => {
                    let (x, y) = (iv.get(b), e(b));
                    let least = if x.excludes_zero() {
                        x.lo.abs().min(x.hi.abs())
                    } else {
                        0.0
                    };
                    if least > y {
                        (e(a) + m(a) / least * y) / (least - y) + round
                    } else {
                        f64::INFINITY
                    }
                }
                Bin::Min | Bin::Max => e(a).max(e(b)),
                _ => f64::INFINITY,
            },
            // Decided in the region, or not continuous.
            Node::Select(c, a, b) => match iv.get(c) {
                c if c.excludes_zero() => e(a),
                c if c == I::point(0.0) => e(b),
                _ => f64::INFINITY,
            },
            // The operands' errors through a 1-Lipschitz norm, and the rounding of the sum
            // of squares, the root and the subtraction (a few ulps of the length).
            Node::Length(v, r) => {
                let len = (0..4).map(|a| m(v[a]) + r[a].get().abs()).sum::<f64>();
                (0..4).map(|a| e(v[a])).sum::<f64>() + 4.0 * ULP * (len + r[4].get().abs())
            }
            Node::Affine(v, r) => {
                let terms = (0..4).map(|a| r[a].get().abs() * m(v[a])).sum::<f64>();
                (0..4).map(|a| r[a].get().abs() * e(v[a])).sum::<f64>()
                    + 4.0 * ULP * (terms + r[4].get().abs())
            }
            // Through the faces that can be outside or the largest (the others are neither,
            // however large), and a few ulps of the length and the rounding.
            Node::BoxDist(v, r) => {
                let r = r.map(K::get);
                let q: [I; 4] = std::array::from_fn(|a| {
                    let u = iv.get(v[a]);
                    let u = I::new(u.lo + r[a], u.hi + r[a]);
                    // |u| over the region.
                    let least = match u.excludes_zero() {
                        true => u.lo.abs().min(u.hi.abs()),
                        false => 0.0,
                    };
                    I::new(least - r[4 + a], size(u) - r[4 + a])
                });
                let top = q.iter().map(|x| x.lo).fold(f64::NEG_INFINITY, f64::max);
                let len = q.iter().map(|x| x.hi.max(0.0).powi(2)).sum::<f64>().sqrt();
                (0..4)
                    .filter(|&a| q[a].hi > 0.0 || q[a].hi >= top)
                    .map(|a| e(v[a]) + ULP * (2.0 * (m(v[a]) + r[a].abs()) + r[4 + a].abs()))
                    .sum::<f64>()
                    + 4.0 * ULP * (len + r[8].abs())
                    + round
            }
            // 1-Lipschitz in both operands together; the blend rounds like its operands.
            Node::SMin(a, b, k) | Node::SMax(a, b, k) => {
                e(a).max(e(b)) + 4.0 * ULP * (m(a).max(m(b)) + m(k))
            }
            Node::D4(v) => {
                let most = (0..4).map(|a| e(v[a]) + 2.0 * ULP * m(v[a]));
                let most = most.fold(0.0, f64::max);
                outs[i] = [most, most, most, most, 0.0, 0.0, 0.0, 0.0];
                0.0
            }
            // The offset from the cell centre is continuous where the distance reads it
            // (a tiling's is symmetric about the cells' sides).
            Node::Rep(a, _) => {
                outs[i] = [e(a) + 2.0 * ULP * m(a), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
                0.0
            }
            Node::MinId(best, _, d, _) => {
                outs[i] = [e(best).max(e(d)), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
                0.0
            }
            Node::Proj(t, j) => outs[t.0 as usize][j as usize],
        };
    }
    err[root.0 as usize]
}
