//! Spatial pruning: the graph specialised to a 4D box. Interval bounds over the box decide the
//! branches of `min`, `max`, smooth CSG where the blend is provably zero, `select`, `abs` and
//! the running min-with-id of the scene, so inside the box the pruned graph computes exactly
//! what the whole graph does, with only the branches that can matter there. The point
//! variables are moved to the box's own origin (`old = new + shift`) and the offset is folded
//! into the operations in `f64`, so an `f32` tape of the result keeps its precision however
//! far the box is from the world's origin.
//!
//! Beyond exact pruning, a box may drop what is farther from it than `reach` (the Lipschitz
//! pruning of Barbier et al., Eurographics 2025): a distance that every root reads only
//! through nondecreasing operations and that is at least `reach` everywhere in the box is
//! replaced by that bound. The result is then a lower bound of the distance, 1-Lipschitz, and
//! exact wherever it is below `reach`, which is all sphere tracing needs.

use super::interval::{I, Intervals, min_id_choice};
use super::opt::simplify;
use super::{Bin, Graph, Id, K, Node, Un, Var};
use rustc_hash::FxHashMap;

/// A graph specialised to a box, with the bounds of its roots there.
#[derive(Clone, Debug)]
pub struct Pruned {
    pub graph: Graph,
    pub roots: Vec<Id>,
    pub bounds: Vec<I>,
    /// Every node is one the roots need (as `prune` builds it): pruning this graph again
    /// need not find which are (a pass over it that was an eighth of building a dense
    /// union's cells).
    pub compact: bool,
}

/// What the bounds over the box decide for one node of the graph being pruned.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Plan {
    /// Not needed by the pruned roots.
    Dead,
    /// Kept, with every operand.
    Keep,
    /// The node equals its operand.
    Same(Id),
    /// Far from the box: its lower bound there stands for it.
    Bound(f64),
    /// A min-with-id that reduces to one pair: `d` (`true`) or `best`.
    Pair(bool),
}

/// `roots` of `g` for points `new + shift` with `new` in `region` (local coordinates),
/// exact where below `reach` (infinity: exact everywhere).
///
/// The bounds of `g` itself decide first, from the roots down, which nodes the result needs;
/// only those are built, so a box where most of a large union is cut costs little more than
/// one interval pass over `g`.
pub fn prune(g: &Graph, roots: &[Id], region: [I; 4], shift: [f64; 4], reach: f64) -> Pruned {
    prune_live(g, roots, g.live(roots), region, shift, reach)
}

impl Pruned {
    /// `prune` of this graph's roots.
    pub fn prune(&self, region: [I; 4], shift: [f64; 4], reach: f64) -> Pruned {
        let live = match self.compact {
            true => vec![true; self.graph.len()],
            false => self.graph.live(&self.roots),
        };
        prune_live(&self.graph, &self.roots, live, region, shift, reach)
    }
}

/// `prune`, with the nodes the roots need marked in `live`.
fn prune_live(
    g: &Graph,
    roots: &[Id],
    live: Vec<bool>,
    region: [I; 4],
    shift: [f64; 4],
    reach: f64,
) -> Pruned {
    let plan = plan(g, roots, &live, region, shift, reach);
    // Each kept node adds about one (a shifted variable, two).
    let kept = plan
        .iter()
        .filter(|p| !matches!(p, Plan::Dead | Plan::Pair(_)))
        .count();
    let mut out = Graph::with_capacity(kept + 2 * Var::POINT.len());
    // The point variables first: they get the smallest ids, so `x + c` keeps the constant
    // second, the form the optimiser folds into offsets.
    for v in Var::POINT {
        out.intern(Node::Var(v));
    }
    let vars = |v: Var| match v {
        Var::X | Var::Y | Var::Z | Var::W => region[v.index()],
        Var::NX | Var::NY | Var::NZ | Var::NW => I::new(-1.0, 1.0),
        Var::T => I::ALL,
    };
    let mut iv = Intervals::default();
    iv.extend(&out, &vars, None);
    let mut map = vec![Id(u32::MAX); g.len()];
    // Min-with-id tuples that reduce to one operand: what their two projections read.
    let mut decided: FxHashMap<u32, [Id; 2]> = FxHashMap::default();
    for i in 0..g.len() {
        let n = g.get(Id(i as u32));
        let new = match (plan[i], n) {
            (Plan::Dead, _) => continue,
            (Plan::Bound(lo), _) => out.intern(Node::Const(K::new(lo))),
            (Plan::Same(c), _) => map[c.0 as usize],
            (Plan::Pair(_), _) => continue,
            (_, Node::Var(v)) if Var::POINT.contains(&v) => {
                let x = out.intern(n);
                let s = shift[v.index()];
                if s == 0.0 {
                    x
                } else {
                    let c = out.intern(Node::Const(K::new(s)));
                    simplify(&mut out, Node::Bin(Bin::Add, x, c), None)
                }
            }
            (_, Node::Proj(t, j)) if decided.contains_key(&t.0) => decided[&t.0][j as usize],
            (_, Node::Proj(t, j)) if matches!(plan[t.0 as usize], Plan::Pair(_)) => {
                let Node::MinId(best, best_id, d, id) = g.get(t) else {
                    unreachable!("pairs are min-with-ids")
                };
                match (plan[t.0 as usize] == Plan::Pair(true), j) {
                    (true, 0) => map[d.0 as usize],
                    (true, _) => out.intern(Node::Const(id)),
                    (false, 0) => map[best.0 as usize],
                    (false, _) => map[best_id.0 as usize],
                }
            }
            _ => {
                let m = n.map(|c| map[c.0 as usize]);
                if let Node::MinId(best, best_id, d, id) = m
                    && let Some(take_d) = pair(iv.get(best), iv.get(d))
                {
                    let pair = if take_d {
                        [d, out.intern(Node::Const(id))]
                    } else {
                        [best, best_id]
                    };
                    decided.insert(i as u32, pair);
                    iv.extend(&out, &vars, None);
                    continue;
                }
                match choose(&iv, m) {
                    Ok(id) => id,
                    Err(Node::BoxDist(v, r)) => box_faces(&mut out, &iv, v, r),
                    Err(m) => simplify(&mut out, m, None),
                }
            }
        };
        iv.extend(&out, &vars, None);
        map[i] = new;
    }
    let kept: Vec<Id> = roots.iter().map(|r| map[r.0 as usize]).collect();
    let bounds = kept.iter().map(|r| iv.get(*r)).collect();
    let (graph, m) = out.compact(&kept);
    Pruned {
        graph,
        roots: kept.iter().map(|r| m[r.0 as usize]).collect(),
        bounds,
        compact: true,
    }
}

/// Which operand of a min-with-id the bounds choose (`Some(true)`: `d`). Against an infinite
/// `best` (no object yet) the pair only differs where `d` is infinite too, which no ray can
/// hit, or NaN: take `d` where it cannot be NaN.
fn pair(best: I, d: I) -> Option<bool> {
    min_id_choice(best, d).or((best == I::point(f64::INFINITY) && !d.nan).then_some(true))
}

/// The plan of every node of `g` for the box: bounds over it (in `g`'s own coordinates,
/// `new + shift`) decide the choices and the cuts, from the roots down, so that nodes only
/// a dropped branch reads are never built.
fn plan(
    g: &Graph,
    roots: &[Id],
    live: &[bool],
    region: [I; 4],
    shift: [f64; 4],
    reach: f64,
) -> Vec<Plan> {
    let vars = |v: Var| match v {
        Var::X | Var::Y | Var::Z | Var::W => {
            let (r, s) = (region[v.index()], shift[v.index()]);
            I::new(r.lo + s, r.hi + s)
        }
        Var::NX | Var::NY | Var::NZ | Var::NW => I::new(-1.0, 1.0),
        Var::T => I::ALL,
    };
    let iv = Intervals::of(g, &vars, Some(live));
    let cuttable = cuttable(g, live);
    let mut plan = vec![Plan::Dead; g.len()];
    for r in roots {
        plan[r.0 as usize] = Plan::Keep;
    }
    let need = |plan: &mut [Plan], c: Id| {
        if plan[c.0 as usize] == Plan::Dead {
            plan[c.0 as usize] = Plan::Keep;
        }
    };
    for i in (0..g.len()).rev() {
        if plan[i] == Plan::Dead {
            continue;
        }
        let n = g.get(Id(i as u32));
        let far = iv.get(Id(i as u32));
        // (A node that may be NaN is not a distance the cut's bound stands for.)
        plan[i] = if cuttable[i] && far.lo >= reach && !far.nan {
            Plan::Bound(far.lo)
        } else if let Node::MinId(best, best_id, d, _) = n
            && let Some(take_d) = pair(iv.get(best), iv.get(d))
        {
            if take_d {
                need(&mut plan, d);
            } else {
                need(&mut plan, best);
                need(&mut plan, best_id);
            }
            Plan::Pair(take_d)
        } else if let Ok(c) = choose(&iv, n) {
            need(&mut plan, c);
            Plan::Same(c)
        } else {
            for c in n.children() {
                need(&mut plan, c);
            }
            Plan::Keep
        };
    }
    plan
}

/// Which live nodes are distances that every root reads only through nondecreasing
/// operations: `min`, `max`, the running min-with-id (both its distances, and its object
/// through the nearest-object projection, which only needs to be right where the distance is
/// below the cut) and `abs` (whose operand is positive wherever a cut changes it). Object
/// ids are never cut.
fn cuttable(g: &Graph, live: &[bool]) -> Vec<bool> {
    // Whether nothing but nondecreasing reads reach the node; parents come after children.
    let mut open = live.to_vec();
    for i in (0..g.len()).rev().filter(|i| live[*i]) {
        let n = g.get(Id(i as u32));
        let passes = open[i]
            && match n {
                Node::Bin(Bin::Min | Bin::Max, ..) | Node::Un(Un::Abs, _) | Node::MinId(..) => true,
                Node::Proj(t, _) => matches!(g.get(t), Node::MinId(..)),
                _ => false,
            };
        if !passes {
            for c in n.children() {
                open[c.0 as usize] = false;
            }
        }
    }
    for (i, o) in open.iter_mut().enumerate() {
        *o &= !matches!(
            g.get(Id(i as u32)),
            Node::Const(_) | Node::Proj(_, 1) | Node::MinId(..)
        );
    }
    open
}

/// The operand `n` reduces to over the bounds (`Ok`), or the node to add in its place.
fn choose(iv: &Intervals, n: Node) -> Result<Id, Node> {
    let v = |x: Id| iv.get(x);
    let below = |a: Id, b: Id| v(a).hi <= v(b).lo;
    // `a - b >= k` everywhere: the polynomial blend of width `k` is zero. Where an operand may
    // be NaN, the blend is NaN (a `min` or `max` of a NaN and a number is either, by an order
    // the graph does not keep: `I::dropping`).
    let apart = |a: Id, b: Id, k: Id| {
        let numbers = !v(a).nan && !v(b).nan && !v(k).nan;
        let k = v(k).hi;
        k >= 0.0 && v(a).lo - v(b).hi >= k && numbers
    };
    match n {
        Node::Bin(Bin::Min, a, b) if below(a, b) => Ok(a),
        Node::Bin(Bin::Min, a, b) if below(b, a) => Ok(b),
        Node::Bin(Bin::Max, a, b) if below(b, a) => Ok(a),
        Node::Bin(Bin::Max, a, b) if below(a, b) => Ok(b),
        Node::SMin(a, b, k) if apart(a, b, k) => Ok(b),
        Node::SMin(a, b, k) if apart(b, a, k) => Ok(a),
        Node::SMax(a, b, k) if apart(a, b, k) => Ok(a),
        Node::SMax(a, b, k) if apart(b, a, k) => Ok(b),
        Node::Select(c, a, _) if v(c).excludes_zero() => Ok(a),
        Node::Select(c, _, b) if v(c) == I::point(0.0) => Ok(b),
        Node::Un(Un::Abs, a) if v(a).lo >= 0.0 => Ok(a),
        Node::Un(Un::Abs, a) if v(a).hi <= 0.0 => Err(Node::Un(Un::Neg, a)),
        _ => Err(n),
    }
}

/// A hyperbox distance where the bounds decide which faces can be nearest and on which side
/// of the centre the point is, and at most one face can have the point outside it: the
/// largest of the candidate faces' affine distances (outside, that one face's). Otherwise the
/// node as it is.
fn box_faces(g: &mut Graph, iv: &Intervals, v: [Id; 4], r: [K; 9]) -> Id {
    let r = r.map(K::get);
    let whole = |g: &mut Graph| simplify(g, Node::BoxDist(v, r.map(K::new)), None);
    // A NaN face makes the distance NaN, where the faces' `max` might drop it.
    if v.iter().any(|&x| iv.get(x).nan) {
        return whole(g);
    }
    let u: [I; 4] = std::array::from_fn(|a| {
        let x = iv.get(v[a]);
        I::new(x.lo + r[a], x.hi + r[a])
    });
    // q_a = |u_a| - half_a, with the side of the centre decided, or nothing known.
    let q: [Option<(f64, I)>; 4] = std::array::from_fn(|a| {
        let h = r[4 + a];
        if u[a].lo >= 0.0 {
            Some((1.0, I::new(u[a].lo - h, u[a].hi - h)))
        } else if u[a].hi <= 0.0 {
            Some((-1.0, I::new(-u[a].hi - h, -u[a].lo - h)))
        } else {
            None
        }
    });
    let hi = |a: usize| q[a].map_or(f64::INFINITY, |x| x.1.hi);
    let lo = |a: usize| q[a].map_or(f64::NEG_INFINITY, |x| x.1.lo);
    // Where at most one axis can put the point outside, the distance is the largest of the
    // faces' on both sides of the surface: outside, the one positive face's.
    if (0..4).filter(|&a| hi(a) > 0.0).count() > 1 {
        return whole(g);
    }
    let top = (0..4).map(lo).fold(f64::NEG_INFINITY, f64::max);
    let candidates: Vec<usize> = (0..4).filter(|&a| hi(a) >= top).collect();
    if candidates.iter().any(|&a| q[a].is_none()) {
        return whole(g);
    }
    let mut faces = candidates.iter().map(|&a| {
        let s = q[a].map_or(1.0, |x| x.0);
        let row = [s, 0.0, 0.0, 0.0, s * r[a] - r[4 + a] - r[8]].map(K::new);
        (v[a], row)
    });
    let (x, row) = faces.next().expect("some face is largest");
    let mut d = simplify(g, Node::Affine([x; 4], row), None);
    for (x, row) in faces {
        let f = simplify(g, Node::Affine([x; 4], row), None);
        d = g.intern(Node::Bin(Bin::Max, d, f));
    }
    d
}
