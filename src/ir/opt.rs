//! Optimisation: the graph is rebuilt node by node through rules that fold constants, apply
//! algebraic identities, turn division by a constant into multiplication and merge chains of
//! affine maps; a second rebuild keeps only the nodes the roots still need (dead code).
//! Interning during the rebuild is the CSE.

use super::eval::fold;
use super::{Bin, Graph, Id, K, Node, SceneIr, Un, Var};

/// The optimised scene, with `t` left free (`None`) or fixed to a frame's value.
pub fn optimise(ir: &SceneIr, t: Option<f64>) -> SceneIr {
    let simplified = rebuild(ir, |g, n| simplify(g, n, t));
    rebuild(&simplified, |g, n| g.intern(n))
}

/// Copy the nodes the roots need into a new graph through `add`.
fn rebuild(ir: &SceneIr, add: impl FnMut(&mut Graph, Node) -> Id) -> SceneIr {
    let (g, map) = ir.graph.rebuild(&ir.roots(), add);
    ir.remap(g, &mut |id| map[id.0 as usize])
}

fn k(g: &mut Graph, x: f64) -> Id {
    g.intern(Node::Const(K::new(x)))
}

/// Add `n` (whose operands are already simplified) to `g` in its simplest form.
pub(crate) fn simplify(g: &mut Graph, n: Node, t: Option<f64>) -> Id {
    if let (Node::Var(Var::T), Some(t)) = (n, t) {
        return k(g, t);
    }
    if let Some(x) = fold(g, &n) {
        return k(g, x);
    }
    let c = |id: Id| g.constant(id);
    match n {
        Node::Bin(op, a, b) => {
            let (ca, cb) = (c(a), c(b));
            let same = a == b;
            match op {
                Bin::Add if ca == Some(0.0) => return b,
                Bin::Add | Bin::Sub if cb == Some(0.0) => return a,
                // `(x + a) + b = x + (a + b)`: pruning moves a point to each cell's origin in
                // turn, and the offsets must not pile up (in f32, nor in instructions).
                Bin::Add | Bin::Sub
                    if let (Some(kb), Node::Bin(Bin::Add, x, y)) = (cb, g.get(a))
                        && let Some(ky) = c(y) =>
                {
                    let s = if op == Bin::Add { ky + kb } else { ky - kb };
                    let s = k(g, s);
                    return simplify(g, Node::Bin(Bin::Add, x, s), t);
                }
                // A constant subtracted from a fused distance joins it.
                Bin::Sub
                    if cb.is_some() && matches!(g.get(a), Node::Length(..) | Node::BoxDist(..)) =>
                {
                    let s = cb.unwrap_or(0.0);
                    return g.intern(match g.get(a) {
                        Node::Length(v, mut r) => {
                            r[4] = K::new(r[4].get() + s);
                            Node::Length(v, r)
                        }
                        Node::BoxDist(v, mut r) => {
                            r[8] = K::new(r[8].get() + s);
                            Node::BoxDist(v, r)
                        }
                        _ => unreachable!("matched above"),
                    });
                }
                Bin::Sub if ca == Some(0.0) => return simplify(g, Node::Un(Un::Neg, b), t),
                Bin::Mul if ca == Some(1.0) => return b,
                Bin::Mul | Bin::Div if cb == Some(1.0) => return a,
                Bin::Div if cb.is_some_and(|x| x != 0.0 && x.is_finite()) => {
                    let r = k(g, 1.0 / cb.unwrap_or(1.0));
                    return g.intern(Node::Bin(Bin::Mul, a, r));
                }
                Bin::Min | Bin::Max if same => return a,
                Bin::Min if ca == Some(f64::INFINITY) => return b,
                Bin::Min if cb == Some(f64::INFINITY) => return a,
                // Constants (the bounds pruning cuts far distances to) rise to the top of a
                // chain of `min`s, where they fold into one immediate.
                Bin::Min if ca.is_none() && cb.is_none() => {
                    if let Some(id) = float_constants(g, a, b) {
                        return id;
                    }
                }
                Bin::Min if ca.is_some() && cb.is_none() => {
                    return simplify(g, Node::Bin(op, b, a), t);
                }
                Bin::Min if cb.is_some() => {
                    if let Node::Bin(Bin::Min, x, y) = g.get(a)
                        && let Some(ky) = c(y)
                    {
                        let k = k(g, ky.min(cb.unwrap_or(ky)));
                        return g.intern(Node::Bin(Bin::Min, x, k));
                    }
                }
                Bin::Max if ca == Some(f64::NEG_INFINITY) => return b,
                Bin::Max if cb == Some(f64::NEG_INFINITY) => return a,
                // Chains of sums and scalings of affine maps merge into one row, as the rows
                // of constant turns and moves do when they are lowered: with `t` folded in, a
                // turn by `a * t` is four products and two sums of the coordinates.
                // Only over the coordinates, which are finite: a row's kernel multiplies its
                // unused slots by 0, which makes an infinite atom NaN, and terms that cancel
                // drop out of it, with their NaN (`1 / max(p.x, 0)` in a custom field).
                Bin::Mul
                    if let Some((x, kx)) = ca.map(|k| (b, k)).or(cb.map(|k| (a, k)))
                        && kx != 0.0
                        && kx.is_finite()
                        && offset(g, x)
                        && of_coordinates(g, &[x]) =>
                {
                    return affine(g, [x; 4], [kx, 0.0, 0.0, 0.0, 0.0]);
                }
                Bin::Add | Bin::Sub
                    if ca.is_none()
                        && cb.is_none()
                        && (linear(g, a) || linear(g, b))
                        && of_coordinates(g, &[a, b]) =>
                {
                    let sign = if op == Bin::Add { 1.0 } else { -1.0 };
                    return affine(g, [a, b, a, a], [1.0, sign, 0.0, 0.0, 0.0]);
                }
                _ => {}
            }
        }
        Node::Un(Un::Neg, a) => {
            if let Node::Un(Un::Neg, x) = g.get(a) {
                return x;
            }
        }
        Node::Select(cond, a, b) => {
            if a == b {
                return a;
            }
            if let Some(x) = c(cond) {
                return if x != 0.0 { a } else { b };
            }
        }
        Node::SMin(a, b, kk) | Node::SMax(a, b, kk) if c(kk).is_some_and(|x| x <= 0.0) => {
            let op = if matches!(n, Node::SMin(..)) {
                Bin::Min
            } else {
                Bin::Max
            };
            return simplify(g, Node::Bin(op, a, b), t);
        }
        Node::Affine(v, row) => return affine(g, v, row.map(K::get)),
        Node::Length(v, r) => {
            let (v, off) = absorb_offsets(g, v, std::array::from_fn(|i| r[i].get()));
            let mut r = r;
            r[..4].copy_from_slice(&off.map(K::new));
            return g.intern(Node::Length(v, r));
        }
        Node::BoxDist(v, r) => {
            let (v, off) = absorb_offsets(g, v, std::array::from_fn(|i| r[i].get()));
            let mut r = r;
            r[..4].copy_from_slice(&off.map(K::new));
            return g.intern(Node::BoxDist(v, r));
        }
        _ => {}
    }
    g.intern(n)
}

/// `min(a, b)` with the constant of `a = min(x, k)` or `b = min(y, k)` lifted out of it:
/// `min(min(x, y), k)`; `None` when neither has one.
fn float_constants(g: &mut Graph, a: Id, b: Id) -> Option<Id> {
    let split = |g: &Graph, x: Id| match g.get(x) {
        Node::Bin(Bin::Min, y, k) => g.constant(k).map(|k| (y, k)),
        _ => None,
    };
    let (sa, sb) = (split(g, a), split(g, b));
    if sa.is_none() && sb.is_none() {
        return None;
    }
    let (x, ka) = sa.unwrap_or((a, f64::INFINITY));
    let (y, kb) = sb.unwrap_or((b, f64::INFINITY));
    let rest = simplify(g, Node::Bin(Bin::Min, x, y), None);
    let k = k(g, ka.min(kb));
    Some(simplify(g, Node::Bin(Bin::Min, rest, k), None))
}

/// Inputs of the form `x + c` feed `x` with the offset `c` added to the operation's own.
fn absorb_offsets(g: &Graph, v: [Id; 4], off: [f64; 4]) -> ([Id; 4], [f64; 4]) {
    let mut v = v;
    let mut off = off;
    for i in 0..4 {
        let (x, c) = match g.get(v[i]) {
            Node::Bin(Bin::Add, x, c) => (x, g.constant(c)),
            Node::Bin(Bin::Sub, x, c) => (x, g.constant(c).map(|c| -c)),
            _ => continue,
        };
        if let Some(c) = c {
            v[i] = x;
            off[i] += c;
        }
    }
    (v, off)
}

/// Whether `id` is an affine map of one or more nodes that a row reading it takes in
/// (`expand` splits it into them).
fn linear(g: &Graph, id: Id) -> bool {
    let c = |x: Id| g.constant(x).is_some();
    match g.get(id) {
        Node::Affine(..) | Node::Un(Un::Neg, _) => true,
        Node::Bin(Bin::Add | Bin::Sub, _, b) => c(b),
        Node::Bin(Bin::Mul, a, b) => c(a) || c(b),
        _ => false,
    }
}

/// Whether `id` is a row or an offset, which a constant factor scales into one row.
fn offset(g: &Graph, id: Id) -> bool {
    match g.get(id) {
        Node::Affine(..) => true,
        Node::Bin(Bin::Add | Bin::Sub, _, b) => g.constant(b).is_some(),
        _ => false,
    }
}

/// Whether the nodes `ids` are affine in the point's coordinates alone: `expand`'s atoms are
/// coordinates or rows of them, all finite.
fn of_coordinates(g: &Graph, ids: &[Id]) -> bool {
    let coordinate = |id: Id| matches!(g.get(id), Node::Var(v) if v.index() < 4);
    let finite = |id: Id| match g.get(id) {
        Node::Affine(v, _) => v.iter().all(|&x| coordinate(x)),
        _ => coordinate(id),
    };
    (ids.iter()).all(|&id| expand(g, id).0.iter().all(|&(atom, _)| finite(atom)))
}

/// A node as a linear combination of "atoms" (nodes that are not affine in their operands)
/// plus a constant.
fn expand(g: &Graph, id: Id) -> (Vec<(Id, f64)>, f64) {
    let c = |x: Id| g.constant(x);
    match g.get(id) {
        Node::Affine(src, r) => {
            let terms = (0..4)
                .filter(|j| r[*j].get() != 0.0)
                .map(|j| (src[j], r[j].get()))
                .collect();
            (terms, r[4].get())
        }
        Node::Bin(Bin::Add, a, b) if c(b).is_some() => (vec![(a, 1.0)], c(b).unwrap_or(0.0)),
        Node::Bin(Bin::Sub, a, b) if c(b).is_some() => (vec![(a, 1.0)], -c(b).unwrap_or(0.0)),
        Node::Bin(Bin::Mul, a, b) if c(b).is_some() => (vec![(a, c(b).unwrap_or(1.0))], 0.0),
        Node::Bin(Bin::Mul, a, b) if c(a).is_some() => (vec![(b, c(a).unwrap_or(1.0))], 0.0),
        Node::Un(Un::Neg, a) => (vec![(a, -1.0)], 0.0),
        Node::Const(k) => (vec![], k.get()),
        _ => (vec![(id, 1.0)], 0.0),
    }
}

/// An affine row, merged with the affine maps it reads when the result still has at most four
/// inputs, and reduced when it is a constant, a plain input or an offset.
fn affine(g: &mut Graph, v: [Id; 4], row: [f64; 5]) -> Id {
    // Collect sum_i row_i * expand(v_i) over distinct atoms, in id order for a canonical form.
    let mut terms: Vec<(Id, f64)> = vec![];
    let mut offset = row[4];
    let add = |terms: &mut Vec<(Id, f64)>, a: Id, c: f64| match terms.iter_mut().find(|t| t.0 == a)
    {
        Some(t) => t.1 += c,
        None => terms.push((a, c)),
    };
    for i in (0..4).filter(|i| row[*i] != 0.0) {
        let (ts, k) = expand(g, v[i]);
        offset += row[i] * k;
        for (a, c) in ts {
            add(&mut terms, a, row[i] * c);
        }
    }
    terms.retain(|t| t.1 != 0.0);
    terms.sort_by_key(|t| t.0);
    if terms.len() > 4 {
        // Too many inputs to merge: keep the row over its direct operands.
        terms.clear();
        offset = row[4];
        for i in (0..4).filter(|i| row[*i] != 0.0) {
            add(&mut terms, v[i], row[i]);
        }
        terms.sort_by_key(|t| t.0);
    }
    match terms[..] {
        [] => k(g, offset),
        [(a, c)] if c == 1.0 && offset == 0.0 => a,
        [(a, 1.0)] => {
            let b = k(g, offset);
            g.intern(Node::Bin(Bin::Add, a, b))
        }
        [(a, c)] if offset == 0.0 => {
            let m = k(g, c);
            g.intern(Node::Bin(Bin::Mul, a, m))
        }
        _ => {
            // Unused slots repeat the first input with coefficient 0.
            let first = terms[0].0;
            let mut src = [first; 4];
            let mut r = [0.0, 0.0, 0.0, 0.0, offset];
            for (j, (a, c)) in terms.iter().enumerate() {
                src[j] = *a;
                r[j] = *c;
            }
            g.intern(Node::Affine(src, r.map(K::new)))
        }
    }
}
