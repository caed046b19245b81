//! The reference evaluator: a plain tree walk of the IR in `f64`, the meaning every optimised
//! tape is tested against, and the constant folder built on the same kernels.

use super::{Graph, Id, Node, Var};
use crate::math::kernel::*;

/// The values a node produces from its operands' values (`get`), in `f64`.
pub fn node<T: Real>(n: &Node, get: impl Fn(Id) -> T, out: &mut [T; 8]) {
    let v4 = |v: [Id; 4]| v.map(&get);
    let k = |k: super::K| T::of(k.get());
    out[0] = match *n {
        Node::Var(_) => unreachable!("inputs are bound by the caller"),
        Node::Const(c) => k(c),
        Node::Un(op, a) => un(op, get(a)),
        Node::Bin(op, a, b) => bin(op, get(a), get(b)),
        Node::Select(c, a, b) => select(get(c), get(a), get(b)),
        Node::Length(v, r) => norm(v4(v), r.map(k)),
        Node::Affine(v, r) => affine(v4(v), r.map(k)),
        Node::BoxDist(v, r) => box_dist(v4(v), r.map(k)),
        Node::SMin(a, b, c) => smin(get(a), get(b), get(c)),
        Node::SMax(a, b, c) => -smin(-get(a), -get(b), get(c)),
        Node::D4(v) => {
            *out = d4(v4(v));
            return;
        }
        Node::Rep(x, l) => {
            let r = rep(get(x), k(l));
            out[..2].copy_from_slice(&r);
            return;
        }
        Node::MinId(a, b, c, id) => {
            let r = min_id(get(a), get(b), get(c), k(id));
            out[..2].copy_from_slice(&r);
            return;
        }
        Node::Proj(..) => unreachable!("projections are read by the caller"),
    };
}

/// The reference evaluator: every node of the graph that the roots need, in `f64`, one point
/// at a time. It is deliberately plain; the VM must agree with it.
pub struct Reference<'g> {
    graph: &'g Graph,
    live: Vec<bool>,
    vals: Vec<[f64; 8]>,
}

impl<'g> Reference<'g> {
    pub fn new(graph: &'g Graph, roots: &[Id]) -> Reference<'g> {
        Reference {
            graph,
            live: graph.live(roots),
            vals: vec![[0.0; 8]; graph.len()],
        }
    }

    /// Evaluate with the inputs `vars` (indexed by `Var::index`), then read nodes with `value`.
    pub fn run(&mut self, vars: &[f64; 9]) {
        walk(self.graph, Some(&self.live), vars, &mut self.vals);
    }

    pub fn value(&self, id: Id) -> f64 {
        self.vals[id.0 as usize][0]
    }
}

/// Every node of `g` that `live` marks (all when `None`) at the inputs `vars`, in id order, into
/// `vals` (a node's outputs at its id; resized to the graph).
pub fn walk(g: &Graph, live: Option<&[bool]>, vars: &[f64; 9], vals: &mut Vec<[f64; 8]>) {
    vals.resize(g.len(), [0.0; 8]);
    for i in 0..g.len() {
        if live.is_some_and(|l| !l[i]) {
            continue;
        }
        let n = g.get(Id(i as u32));
        let mut out = [0.0; 8];
        match n {
            Node::Var(v) => out[0] = vars[v.index()],
            Node::Proj(a, j) => out[0] = vals[a.0 as usize][j as usize],
            n => node(&n, |c| vals[c.0 as usize][0], &mut out),
        }
        vals[i] = out;
    }
}

/// Evaluate a node whose operands are all constants, or `None` if it is not foldable.
/// A projection folds when the tuple it reads does.
pub fn fold(g: &Graph, n: &Node) -> Option<f64> {
    let (t, j) = match *n {
        Node::Var(_) | Node::Const(_) => return None,
        Node::Proj(a, j) => (g.get(a), j as usize),
        n if n.arity() > 1 => return None,
        n => (n, 0),
    };
    if !t.children().iter().all(|c| g.constant(*c).is_some()) {
        return None;
    }
    let mut out = [0.0; 8];
    node(&t, |c| g.constant(c).unwrap_or(f64::NAN), &mut out);
    Some(out[j])
}

/// Bind inputs by name for callers that have a point, a normal and a frame variable.
pub fn vars(p: [f64; 4], n: [f64; 4], t: f64) -> [f64; 9] {
    let mut v = [0.0; 9];
    for i in 0..4 {
        v[Var::POINT[i].index()] = p[i];
        v[Var::NORMAL[i].index()] = n[i];
    }
    v[Var::T.index()] = t;
    v
}
