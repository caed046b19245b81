//! The proof that a ray has left the scene: it never enters the box of the bounded objects
//! again, and no unbounded object's distance reaches zero along the rest of it. Every marcher
//! ends a ray at the sky only on this proof, never by travelling far. And the proof that a
//! stretch of a ray meets no surface, which lets a ray crawling beside one leap ahead
//! (`Escape::clear`).

use crate::ir::eval;
use crate::ir::exact::{Cover, Form, Pieces, Reach, cover, pieces};
use crate::ir::interval::{Along, I, Intervals};
use crate::ir::{Bin, Graph, Id, K, Node, Var};
use crate::vm::cells::{FEW_PIECES, epsilon_at};
use glam::DVec4;

/// The box `lo..hi` holds every bounded object (by its ball, or a box `proven_box` found), and
/// `roots` are the distances of the unbounded ones (halfspaces, D4 packings, grids without
/// limits, custom fields without a proven box). `whole` holds the scene's distance and, where
/// objects can be entered, its interior distance (`distances`).
pub struct Escape {
    lo: DVec4,
    hi: DVec4,
    graph: Graph,
    roots: Vec<Id>,
    whole: Graph,
    /// The distance and nearest object in `whole`, outside objects and inside them.
    scene: (Id, Id),
    interior: Option<(Id, Id)>,
    /// The frame's animation time, where the graph still reads it.
    t: f64,
    /// Whether no ray outside objects, and no ray inside them, can ever prove that it has
    /// left the scene (`never_clears`): `escapes` then says no without trying.
    never: [bool; 2],
    /// Each unbounded object's cover (`ir::exact::cover`), where it has one; empty for the
    /// plain marcher, which takes no exact shortcut.
    covers: Vec<Option<Cover>>,
    /// Where every unbounded object is a min of forms (an exact cover), what `ahead` meets.
    exact: Option<Exact>,
    /// Where the whole scene is a few closed pieces, and so is the interior distance where
    /// objects can be entered: the pieces rays outside objects and inside them meet
    /// (`Escape::pieces`); none for the plain marcher, which takes no exact shortcut.
    pieces: Option<(Pieces, Option<Pieces>)>,
    /// How large the constants the scene's tapes add are (`magnitude`): their `f32` rounding
    /// grows with them as with the coordinates.
    magnitude: f64,
}

/// The exact unbounded objects (`Escape::ahead`): every form with its object's index in the
/// scene, and the box of the bounded objects (none where there are none).
struct Exact {
    forms: Vec<(Form, usize)>,
    objects: Option<(DVec4, DVec4)>,
}

/// What the exact unbounded objects say of a ray outside objects (`Escape::ahead`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Ahead {
    /// Nothing: some unbounded object is no min of closed forms (or the marcher takes no
    /// covers), or the ray starts inside a form.
    #[default]
    Unknown,
    /// The ray starts inside the bounded objects' box: they say more once it has left.
    Inside,
    /// The ray first meets an unbounded object at `first` (infinity: never), `object` (its
    /// index in the scene), and is inside the bounded objects' box from `into` to `out`
    /// (both 0 where it never is). Beyond the box (which is convex: a ray that has left it
    /// never comes back) the first meeting is where the ray ends.
    Meets {
        first: f64,
        object: usize,
        into: f64,
        out: f64,
    },
}

impl Escape {
    /// From the frame's graph: a box holding its bounded objects and the camera, and the box
    /// of the bounded objects alone (where it holds none, `lo` above `hi`); the others (each
    /// object's index in the scene and its distance); and the scene's distance and nearest
    /// object, outside objects and inside them (`None` where no object can be entered), at
    /// animation time `t`. With `covers`, the unbounded objects' covers too, which `escapes`
    /// meets before it bounds their graph, and which `ahead` meets where every one is exact.
    pub fn new(
        g: &Graph,
        (bounded, objects): ((DVec4, DVec4), (DVec4, DVec4)),
        unbounded: &[(usize, Id)],
        (scene, interior): ((Id, Id), Option<(Id, Id)>),
        (t, covers_wanted): (f64, bool),
    ) -> Escape {
        let covers: Vec<Option<Cover>> = match covers_wanted {
            true => unbounded.iter().map(|&(_, u)| cover(g, u)).collect(),
            false => vec![],
        };
        // Not with a tiled ball: meeting it from afar crosses its lattice cell by cell,
        // which the cells' march does for less (the D4 packing). With no unbounded object at
        // all, only the box is met: a ray that misses it ends at the sky unevaluated.
        let exact = (covers_wanted
            && covers.len() <= 64
            && (covers.iter()).all(|c| {
                c.as_ref()
                    .is_some_and(|c| c.exact && c.forms.iter().all(Form::closed))
            }))
        .then(|| {
            let forms = (covers.iter().flatten().zip(unbounded))
                .flat_map(|(c, u)| c.forms.iter().map(|f| (f.clone(), u.0)))
                .collect();
            // (An empty box, `lo` above `hi`, is met by no ray.)
            let objects = objects.0.cmple(objects.1).all().then_some(objects);
            Exact { forms, objects }
        });
        let pieces = covers_wanted
            .then(|| whole_pieces(g, scene, interior))
            .flatten();
        let unbounded: Vec<Id> = unbounded.iter().map(|u| u.1).collect();
        let unbounded = &unbounded[..];
        let (graph, map) = g.rebuild(unbounded, |g, n| g.intern(n));
        let unbounded: Vec<Id> = unbounded.iter().map(|r| map[r.0 as usize]).collect();
        let never = never_clears(&graph, &unbounded);
        let roots: Vec<Id> = [scene]
            .into_iter()
            .chain(interior)
            .flat_map(|(d, n)| [d, n])
            .collect();
        let (whole, at) = g.compact(&roots);
        let at = |(d, n): (Id, Id)| (at[d.0 as usize], at[n.0 as usize]);
        Escape {
            magnitude: magnitude(&whole),
            lo: bounded.0,
            hi: bounded.1,
            graph,
            roots: unbounded,
            whole,
            scene: at(scene),
            interior: interior.map(at),
            t,
            never,
            covers,
            exact,
            pieces,
        }
    }

    /// Where the whole scene is a few closed pieces (`FEW_PIECES` at most: as many as a cell
    /// meets without splitting), the pieces a ray outside objects (`interior` false) or
    /// inside them meets: once, from where it starts, it knows where it ends (`march`). Set
    /// for both or neither, so a frame with them needs no cells and no probe; where no
    /// object can be entered, a ray inside objects meets the scene's, as it would march the
    /// scene tape.
    pub fn pieces(&self, interior: bool) -> Option<&Pieces> {
        let (scene, inside) = self.pieces.as_ref()?;
        Some(inside.as_ref().filter(|_| interior).unwrap_or(scene))
    }

    /// Whether every ray of the frame meets the scene's pieces (`pieces`).
    pub fn meets_every_ray(&self) -> bool {
        self.pieces.is_some()
    }

    /// Where the ray from `p` along `d`, outside objects, meets the unbounded objects and the
    /// bounded objects' box, where every unbounded object is a min of forms (`Cover::exact`),
    /// none a tiled ball, and the ray starts outside every form and outside the box: a
    /// marcher on the whole tape then knows where the ray ends once it is past the box, or
    /// before it reaches it, without stepping there. Inside the box (where most rays that
    /// left a bounded object start, and end on another) nothing is met yet.
    pub fn ahead(&self, p: DVec4, d: DVec4, proofs: &mut Proofs) -> Ahead {
        let Some(Exact { forms, objects }) = self.exact.as_ref() else {
            return Ahead::Unknown;
        };
        if objects.is_some_and(|(lo, hi)| inside(p, lo, hi)) {
            return Ahead::Inside;
        }
        let (pa, da) = (p.to_array(), d.to_array());
        let (mut first, mut object) = (f64::INFINITY, 0);
        for (f, o) in forms {
            // No lattice: nothing to cross.
            let m = f.meet(pa, da, (f64::INFINITY, 0));
            proofs.bounded += 1;
            match m.first {
                _ if m.value <= 0.0 => return Ahead::Unknown,
                Some(t) if t < first => (first, object) = (t, *o),
                _ => {}
            }
        }
        let (into, out) = (objects.and_then(|(lo, hi)| span(p, d, lo, hi))).unwrap_or((0.0, 0.0));
        Ahead::Meets {
            first,
            object,
            into,
            out,
        }
    }

    /// The distance below which the whole scene tape's `f32` cannot tell a point at `p` from
    /// a surface (`epsilon_at`), grown with the tape's own constants too: an object moved from
    /// 1e4 to near the origin computes `p - c` of 1e4 there, and rounds by 5e-4, five
    /// epsilons. Where it exceeds the epsilon, hits settle in `f64` (`approach`).
    pub fn epsilon_at(&self, p: DVec4, epsilon: f64) -> f64 {
        epsilon_at(p, epsilon).max(epsilon_at(DVec4::splat(self.magnitude), epsilon))
    }

    /// The scene's (for a ray inside objects, the interior, unsigned) distance at `p` in
    /// `f64`, and the nearest object's index (-1 for none): a plain walk of the graph
    /// (`eval::walk`). Bounds over a stretch of length zero gave the same at several times
    /// the cost: they were a fifth of a `glass_box` profile.
    pub fn distance(&self, p: DVec4, interior: bool, proofs: &mut Proofs) -> (f64, f64) {
        let (root, near) = self.roots(interior);
        // Distances do not read the normal.
        let vars = eval::vars(p.to_array(), [0.0; 4], self.t);
        eval::walk(&self.whole, None, &vars, &mut proofs.point);
        proofs.walked += self.whole.len() as u64;
        let at = |id: Id| proofs.point[id.0 as usize][0];
        (at(root), at(near))
    }

    /// How far along the stretch of `len` from `p` along `d` the ray provably meets no
    /// surface (`len` for all of it, 0 for none): the scene's distance (for a ray inside
    /// objects, the interior one, unsigned) stays above zero there (`Intervals::along`). Exact
    /// for planes and spheres, so a ray crawling beside one (grazing it, or closing in at a
    /// shallow angle) can leap ahead to just short of where it meets it. Where the stretch
    /// crosses a tiling's cells, the bounds over all of it are loose (the offset from the
    /// cell's centre jumps at each side): it is split at the sides (at most `PIECES` pieces)
    /// and bounded piece by piece, each exact in its cell, as far as they hold: a ray in a
    /// lattice's channel, far from every piece, leaps across many cells at once.
    pub fn clear(&self, p: DVec4, d: DVec4, len: f64, interior: bool, proofs: &mut Proofs) -> f64 {
        let proven = |from, len, proofs: &mut Proofs| {
            self.along(from, d, len, interior, proofs).0.positive()
        };
        if proven(p, len, proofs) {
            return len;
        }
        let mut cuts = std::mem::take(&mut proofs.cuts);
        let mut clear = 0.0;
        if proofs.along.crossings(&self.whole, len, PIECES, &mut cuts) {
            for &end in &cuts {
                let from = p + d * clear;
                if !proven(from, end - clear, proofs) {
                    break;
                }
                clear = end;
            }
        }
        proofs.cuts = cuts;
        clear
    }

    /// The distance and nearest object in `whole`: the interior's for a ray inside objects,
    /// where some object can be entered, the scene's otherwise.
    fn roots(&self, interior: bool) -> (Id, Id) {
        match (interior, self.interior) {
            (true, Some(i)) => i,
            _ => self.scene,
        }
    }

    /// Bounds of the scene's (or interior) distance and nearest object over the stretch of
    /// `len` from `p` along `d`.
    fn along(&self, p: DVec4, d: DVec4, len: f64, interior: bool, proofs: &mut Proofs) -> (I, I) {
        let (root, near) = self.roots(interior);
        let (p, d) = (p.to_array(), d.to_array());
        let iv = Intervals::along(&mut proofs.along, &self.whole, p, d, len);
        proofs.bounded += self.whole.len() as u64;
        (iv.get(root), iv.get(near))
    }

    /// Whether the ray from `p` along `d` provably meets no surface: it never enters the box
    /// of the bounded objects again, and no unbounded object's distance changes sign anywhere
    /// along the rest of the ray (bounded along the ray itself, `Intervals::along`). For a ray
    /// outside objects (not `interior`) the distances must be positive there: one negative
    /// all along means the ray has crossed that surface (by a rounding, at a cell's side),
    /// and it meets it where it is. `keep` holds the unbounded objects the ray may still
    /// meet (bit `i`: the `i`th); once the ray is past the box, those proven out of its way
    /// leave it. `proofs` holds the bounds' buffers and counts the nodes bounded.
    pub fn escapes(
        &self,
        p: DVec4,
        d: DVec4,
        interior: bool,
        keep: &mut u64,
        proofs: &mut Proofs,
    ) -> bool {
        if self.never[interior as usize] {
            return false;
        }
        // A ray bound for the box cannot escape yet, and is left the intervals until it has
        // passed it: they cost a pass over the unbounded objects' graph, 14% of a tiling's
        // render when every attempt paid it.
        if entry(p, d, self.lo, self.hi).is_some() {
            return false;
        }
        if let Some(decided) = self.met_covers(p, d, interior, keep, proofs) {
            return decided;
        }
        // Objects past the mask's 64 bits count only when all are out of the way.
        let mut rest = true;
        if !self.roots.is_empty() {
            let (p, d) = (p.to_array(), d.to_array());
            let iv = Intervals::along(&mut proofs.along, &self.graph, p, d, f64::INFINITY);
            proofs.bounded += self.graph.len() as u64;
            for (i, r) in self.roots.iter().enumerate() {
                let x = iv.get(*r);
                let clear = if interior { x.nonzero() } else { x.positive() };
                match i {
                    0..64 if clear => *keep &= !(1 << i),
                    0..64 => {}
                    _ => rest &= clear,
                }
            }
        }
        *keep == 0 && rest
    }

    /// What meeting the unbounded objects' covers exactly decides, where it decides: yes where
    /// the ray meets none of the forms of any cover (each from outside it, with no first
    /// meeting, and not given up), then none of the objects; no where a ray outside objects
    /// reaches a form of an exact cover (`Cover::exact`), whose object it then reaches
    /// too. Either way an interval pass over their graph is not needed. Objects whose covers it
    /// clears leave `keep`.
    fn met_covers(
        &self,
        p: DVec4,
        d: DVec4,
        interior: bool,
        keep: &mut u64,
        proofs: &mut Proofs,
    ) -> Option<bool> {
        if self.covers.is_empty() || self.roots.len() > 64 {
            return None;
        }
        let (p, d) = (p.to_array(), d.to_array());
        for (i, cover) in self.covers.iter().enumerate() {
            let Some(cover) = cover.as_ref().filter(|_| *keep & 1 << i != 0) else {
                continue;
            };
            let mut misses = true;
            for f in &cover.forms {
                let (reach, cells) = f.reach(p, d);
                // Counted as nodes bounded: a form, or a lattice cell crossed, costs about one.
                proofs.bounded += 1 + cells as u64;
                match reach {
                    // Inside objects a proof needs the distance away from zero, which a form
                    // reached does not rule out (another may hold the ray inside for ever).
                    Reach::Reached if cover.exact && !interior => return Some(false),
                    Reach::Missed => {}
                    _ => misses = false,
                }
            }
            if misses {
                *keep &= !(1 << i);
            }
        }
        (*keep == 0).then_some(true)
    }

    /// Every unbounded object, as `escapes` takes them.
    pub fn unbounded(&self) -> u64 {
        match self.roots.len() {
            n @ 0..64 => (1 << n) - 1,
            _ => u64::MAX,
        }
    }
}

/// The pieces of the scene's distance and, where objects can be entered, of the interior
/// distance (`Escape::pieces`), where each is a few closed ones: none of a tiled ball, whose
/// crossing of its lattice may stop short.
fn whole_pieces(
    g: &Graph,
    scene: (Id, Id),
    interior: Option<(Id, Id)>,
) -> Option<(Pieces, Option<Pieces>)> {
    let few = |(d, n): (Id, Id)| {
        pieces(g, d, n)
            .filter(|p| p.len() <= FEW_PIECES && p.iter().all(|p| p.form.closed()))
            .map(Pieces::from)
    };
    let outside = few(scene)?;
    let inside = match interior {
        Some(i) => Some(few(i)?),
        None => None,
    };
    Some((outside, inside))
}

/// Whether some unbounded object (the roots of `g`) is one no escape proof can clear, for
/// rays outside objects and for rays inside them: its distance reads the position only
/// through D4 tilings, whose offsets range over their whole cell along every ray that goes
/// on for ever, so its bounds along any such ray are its bounds over all of space, and those
/// reach zero (for rays inside objects, contain it). A packing of spheres is one: every try
/// failed, and skipping them made `d4_packing`'s render about 9% faster. (A rectangular tiling is not: along a
/// ray square to an axis, that axis's offset stays put, and a ray in a channel may clear.)
fn never_clears(g: &Graph, roots: &[Id]) -> [bool; 2] {
    // Which nodes read the position only through D4 nodes' outputs (or not at all).
    let mut tiled = Vec::with_capacity(g.len());
    for i in 0..g.len() {
        let n = g.get(Id(i as u32));
        tiled.push(match n {
            Node::Var(v) => v.index() >= 4,
            Node::D4(_) => true,
            _ => n.children().iter().all(|c| tiled[c.0 as usize]),
        });
    }
    let iv = Intervals::of(g, &|_: Var| I::ALL, None);
    let never = |clears: fn(I) -> bool| {
        roots
            .iter()
            .any(|r| tiled[r.0 as usize] && !clears(iv.get(*r)))
    };
    [never(I::positive), never(I::nonzero)]
}

/// A marcher's scratch space for escape proofs, and their cost so far.
#[derive(Default)]
pub struct Proofs {
    along: Along,
    /// Where a stretch crosses tilings' cells (`Escape::clear`).
    cuts: Vec<f64>,
    /// Every node's value at a point (`Escape::distance`).
    point: Vec<[f64; 8]>,
    /// Graph nodes bounded to prove that rays escape, for the statistics.
    pub bounded: u64,
    /// Graph nodes walked in `f64` for distances at points (`Escape::distance`).
    pub walked: u64,
}

/// The most pieces a stretch is split into at tilings' cells (`Escape::clear`): each costs a
/// pass over the scene's graph.
const PIECES: usize = 32;

/// A box holding every point where `id`'s distance (in `g`, at animation time `t`) is at most
/// zero, where interval bounds prove one: along each axis, on each side, the least reach `x`
/// (a power of two from `2^-20` to `2^60`, then halved towards the last that failed, `HALVINGS`
/// times) such that the distance's bounds over the half of space beyond it (`x_i >= x`, or
/// `x_i <= -x`, the other coordinates anything) are positive. A custom field that is a few
/// spheres (the distance to the nearest point of a clamped grid) is bounded this way, which
/// the analysis of shapes cannot see (`Shape::bounds`); a halfspace, a D4 packing or a grid
/// without limits never is. `None` when some side has no such reach.
///
/// Bounds past a function's domain are the whole line (`I::known`), so `min(log(y), |p| - 1)`,
/// whose slab `0 < y <= 1` is solid for every `x`, gets no box.
pub fn proven_box(g: &Graph, id: Id, t: f64) -> Option<(DVec4, DVec4)> {
    // The object's own nodes only: a pass over the whole scene's graph for each object would
    // grow with the square of the objects.
    let (cone, at) = g.compact(&[id]);
    let root = at[id.0 as usize];
    let positive_beyond = |axis: usize, side: f64, x: f64| {
        let beyond = match side > 0.0 {
            true => I::new(x, f64::INFINITY),
            false => I::new(f64::NEG_INFINITY, -x),
        };
        let vars = |v: Var| match v {
            Var::T => I::point(t),
            _ if v.index() == axis => beyond,
            _ => I::ALL,
        };
        let iv = Intervals::of(&cone, &vars, None);
        iv.get(root).positive()
    };
    let (mut lo, mut hi) = (DVec4::ZERO, DVec4::ZERO);
    for axis in 0..4 {
        for side in [-1.0, 1.0] {
            // The farthest reach first: an unbounded object fails it, and costs one pass.
            if !positive_beyond(axis, side, 2f64.powi(MAX_POWER)) {
                return None;
            }
            let k = (-20..=MAX_POWER).find(|&k| positive_beyond(axis, side, 2f64.powi(k)))?;
            // Any reach proven is a proof, so the bisection need not be monotone.
            let (mut fail, mut reach) = (2f64.powi(k - 1), 2f64.powi(k));
            for _ in 0..HALVINGS {
                let mid = (fail + reach) / 2.0;
                match positive_beyond(axis, side, mid) {
                    true => reach = mid,
                    false => fail = mid,
                }
            }
            match side > 0.0 {
                true => hi[axis] = reach,
                false => lo[axis] = -reach,
            }
        }
    }
    Some((lo, hi))
}

/// The largest reach `proven_box` tries, `2^60`.
const MAX_POWER: i32 = 60;

/// The halvings that tighten each side's reach in `proven_box`: to within 1/16 of it.
const HALVINGS: u32 = 4;

/// Where the ray from `p` along `d` first meets the box `lo..hi`, if it does (slab test,
/// `t >= 0`; 0 when `p` is inside).
pub fn entry(p: DVec4, d: DVec4, lo: DVec4, hi: DVec4) -> Option<f64> {
    // Without divisions where most rays of a closed scene start: inside.
    if inside(p, lo, hi) {
        return Some(0.0);
    }
    span(p, d, lo, hi).map(|s| s.0)
}

/// Whether `p` is in the box `lo..hi`.
fn inside(p: DVec4, lo: DVec4, hi: DVec4) -> bool {
    p.cmpge(lo).all() && p.cmple(hi).all()
}

/// Where the ray from `p` along `d` is inside the box `lo..hi` (`t >= 0`), if it ever is.
fn span(p: DVec4, d: DVec4, lo: DVec4, hi: DVec4) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for a in 0..4 {
        if d[a] == 0.0 {
            if p[a] < lo[a] || p[a] > hi[a] {
                return None;
            }
            continue;
        }
        // One division an axis: the products are within an ulp of the quotients.
        let inv = 1.0 / d[a];
        let (u, v) = ((lo[a] - p[a]) * inv, (hi[a] - p[a]) * inv);
        t0 = t0.max(u.min(v));
        t1 = t1.min(u.max(v));
    }
    (t0 <= t1).then_some((t0, t1))
}

/// How large the constants that `g` adds to the coordinates or to its values are (moves,
/// offsets and half-extents in fused nodes, an affine row's offset, a constant added or
/// subtracted), times the constant factors above them: near the origin its values are about
/// that large, and round with it. `(|p / 1e4| - 1) * 1e4` (a unit sphere scaled by 1e4) rounds
/// by 1e4 times `|p / 1e4| - 1`'s rounding. Its largest at any node, so no factor below 1
/// hides a constant. Not the operands of a `min` or `max` (a cap of 1e30 adds nothing), nor
/// values a custom field computes (`1 / (|x| + 1e-30)` is 1e30 at the origin, but a `min` may
/// cap it); not infinities.
fn magnitude(g: &Graph) -> f64 {
    let finite = |x: f64| if x.is_finite() { x.abs() } else { 0.0 };
    let most = |ks: &[K]| ks.iter().map(|k| finite(k.get())).fold(0.0, f64::max);
    // A finite constant factor scales its operand's magnitude; an infinite one leaves it.
    let scaled = |k: f64, m: f64| if k.is_finite() { k.abs() * m } else { m };
    let mut m = vec![0.0f64; g.len()];
    for i in 0..g.len() {
        let node = g.get(Id(i as u32));
        let of = |x: Id| m[x.0 as usize];
        let operands = node.children().into_iter().map(of).fold(0.0, f64::max);
        let added = |x: Id| g.constant(x).map_or(0.0, finite);
        m[i] = match node {
            Node::Length(_, r) => operands.max(most(&r)),
            Node::BoxDist(_, r) => operands.max(most(&r)),
            Node::Affine(v, r) => (v.iter().zip(&r[..4]))
                .filter(|(_, c)| c.get() != 0.0)
                .map(|(&x, c)| scaled(c.get(), of(x)))
                .fold(finite(r[4].get()), f64::max),
            Node::Bin(Bin::Add | Bin::Sub, a, b) => operands.max(added(a)).max(added(b)),
            Node::Bin(Bin::Mul, a, b) => match (g.constant(a), g.constant(b)) {
                (Some(k), _) => scaled(k, of(b)),
                (_, Some(k)) => scaled(k, of(a)),
                _ => operands,
            },
            Node::Bin(Bin::Div, a, b) => match g.constant(b) {
                Some(k) if k != 0.0 => scaled(1.0 / k, of(a)),
                _ => operands,
            },
            _ => operands,
        };
    }
    m.into_iter().fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    /// Every object's distance as an unbounded root, as `escapes` takes them.
    fn escape_of(source: &str) -> Escape {
        escape_with(source, false)
    }

    /// `escape_of`, with the objects' covers where `covers`.
    fn escape_with(source: &str, covers: bool) -> Escape {
        let c = crate::Compilation::from_source("t.4ds", source);
        let scene = c.scene.expect("the test scene compiles");
        let ir = crate::compile::Compiled::new(&scene).program(Some(0.5)).ir;
        let objects: Vec<(usize, Id)> = ir.objects.iter().map(|o| o.distance).enumerate().collect();
        let roots = ((ir.distance, ir.nearest), ir.interior);
        let none = (DVec4::INFINITY, DVec4::NEG_INFINITY);
        Escape::new(
            &ir.graph,
            ((DVec4::ZERO, DVec4::ZERO), none),
            &objects,
            roots,
            (0.5, covers),
        )
    }

    /// Where an unbounded object has a cover (a floor with a ball cut out of it, by its
    /// plane; a smooth union of a floor and a ball, by both lowered by the blend), a ray that
    /// meets none of the forms escapes on their meetings alone: no interval pass over the
    /// graph (one node counted per form met). Rays it does not clear are left to the bounds,
    /// which decide as they did without covers, on rays up, down, and across the ball.
    #[test]
    fn covers_prove_escapes_without_bounds() {
        let shapes = [
            "subtract(halfspace([0, 1, 0, 0], offset: 0), hypersphere(0.5))",
            "union(halfspace([0, 1, 0, 0], offset: 0), hypersphere(0.5) \
             |> translate([0, 2, 0, 0]), smooth: 0.3)",
        ];
        for shape in shapes {
            let source = scene(&[shape]);
            let (with, without) = (escape_with(&source, true), escape_of(&source));
            let o = DVec4::new(3.0, 4.0, -2.0, 1.0);
            let up = DVec4::new(0.1, 1.0, 0.2, 0.0).normalize();
            let mut proofs = Proofs::default();
            assert!(with.escapes(o, up, false, &mut with.unbounded(), &mut proofs));
            assert!(
                proofs.bounded <= 2,
                "{shape}: {} nodes bounded",
                proofs.bounded
            );
            assert!(without.escapes(o, up, false, &mut without.unbounded(), &mut proofs));
            assert!(proofs.bounded > 2, "{shape}: the bounds were not needed");
            for d in [-DVec4::Y, DVec4::new(0.0, -0.3, 1.0, 0.0).normalize()] {
                let mut proofs = Proofs::default();
                let (a, b) = (
                    with.escapes(o, d, false, &mut with.unbounded(), &mut proofs),
                    without.escapes(o, d, false, &mut without.unbounded(), &mut proofs),
                );
                assert!(
                    !a && !b,
                    "{shape}: a ray bound for the floor escapes ({a}, {b})"
                );
            }
        }
    }

    /// A floor (an exact unbounded object) below a ball (bounded, in the box `(-1, 1, -1, -1)
    /// ..(1, 3, 1, 1)`): `ahead` meets the floor exactly and spans the box, for rays that miss
    /// the box and rays through it, and waits for a ray inside the box to leave it; it says
    /// nothing for a ray starting inside the floor, for the plain marcher (no covers), or
    /// where an unbounded object is no min of forms (the floor with a hole).
    #[test]
    fn rays_meet_exact_unbounded_objects_ahead() {
        let ball = "hypersphere(1) |> translate([0, 2, 0, 0])";
        let of = |floor: &str, covers: bool| {
            let c = crate::Compilation::from_source("t.4ds", &scene(&[floor, ball]));
            let scene = c.scene.expect("the test scene compiles");
            let ir = crate::compile::Compiled::new(&scene).program(Some(0.5)).ir;
            let boxed = (
                DVec4::new(-1.0, 1.0, -1.0, -1.0),
                DVec4::new(1.0, 3.0, 1.0, 1.0),
            );
            let camera = DVec4::new(0.0, 0.0, -6.0, 0.0);
            Escape::new(
                &ir.graph,
                ((boxed.0.min(camera), boxed.1.max(camera)), boxed),
                &[(0, ir.objects[0].distance)],
                ((ir.distance, ir.nearest), ir.interior),
                (0.5, covers),
            )
        };
        let floor = "halfspace([0, 1, 0, 0], offset: 0)";
        let e = of(floor, true);
        let mut proofs = Proofs::default();
        let down = -DVec4::Y;
        let meets = |first, into, out| Ahead::Meets {
            first,
            object: 0,
            into,
            out,
        };
        let beside = e.ahead(DVec4::new(3.0, 4.0, -2.0, 1.0), down, &mut proofs);
        assert_eq!(beside, meets(4.0, 0.0, 0.0));
        let slant = DVec4::new(1.0, -2.0, 0.0, 0.0).normalize();
        // Into the box where x reaches -1, out where y reaches 1; the floor at y = 0.
        let through = e.ahead(DVec4::new(-1.5, 4.0, 0.0, 0.0), slant, &mut proofs);
        let close = |x: f64, want: f64| (x - want * 5f64.sqrt()).abs() < 1e-12;
        assert!(
            matches!(through, Ahead::Meets { first, into, out, .. }
                if close(into, 0.5) && close(out, 1.5) && close(first, 2.0)),
            "{through:?}"
        );
        let inside = DVec4::new(0.0, 1.5, 0.0, 0.5);
        assert_eq!(e.ahead(inside, down, &mut proofs), Ahead::Inside);
        let under = DVec4::new(3.0, -1.0, 0.0, 0.0);
        assert_eq!(e.ahead(under, DVec4::Y, &mut proofs), Ahead::Unknown);
        let above = DVec4::new(3.0, 4.0, 0.0, 0.0);
        assert_eq!(
            of(floor, false).ahead(above, down, &mut proofs),
            Ahead::Unknown
        );
        let holed = "subtract(halfspace([0, 1, 0, 0], offset: 0), hypersphere(0.5))";
        assert_eq!(
            of(holed, true).ahead(above, down, &mut proofs),
            Ahead::Unknown
        );
    }

    /// With no unbounded object, only the bounded objects' box is met: a ray that misses it
    /// meets nothing (`first` infinite, the box spanned nowhere), a ray towards it spans it,
    /// one inside it waits to leave; the plain marcher takes no such shortcut.
    #[test]
    fn rays_meet_only_the_box_where_every_object_is_bounded() {
        let c = crate::Compilation::from_source("t.4ds", &scene(&["hypersphere(1)"]));
        let scene = c.scene.expect("the test scene compiles");
        let ir = crate::compile::Compiled::new(&scene).program(Some(0.0)).ir;
        let boxed = (DVec4::splat(-1.0), DVec4::splat(1.0));
        let camera = DVec4::new(0.0, 0.0, -6.0, 0.0);
        let of = |covers| {
            Escape::new(
                &ir.graph,
                ((boxed.0.min(camera), boxed.1.max(camera)), boxed),
                &[],
                ((ir.distance, ir.nearest), ir.interior),
                (0.0, covers),
            )
        };
        let (e, mut proofs) = (of(true), Proofs::default());
        let away = e.ahead(camera, -DVec4::Z, &mut proofs);
        assert!(matches!(away, Ahead::Meets { first, out: 0.0, .. } if first.is_infinite()));
        let towards = e.ahead(camera, DVec4::Z, &mut proofs);
        assert!(
            matches!(towards, Ahead::Meets { first, into: 5.0, out: 7.0, .. }
                if first.is_infinite()),
            "{towards:?}"
        );
        assert_eq!(e.ahead(DVec4::ZERO, DVec4::Z, &mut proofs), Ahead::Inside);
        assert_eq!(
            of(false).ahead(camera, -DVec4::Z, &mut proofs),
            Ahead::Unknown
        );
    }

    fn scene(shapes: &[&str]) -> String {
        let objects: String = (shapes.iter().enumerate())
            .map(|(i, s)| format!("object o{i} {{ shape = {s}\n material = diffuse(0.5) }}\n"))
            .collect();
        format!("camera {{ from = [0, 0, -6, 0]\n to = [0, 0, 0, 0] }}\n{objects}")
    }

    /// Bounds past a function's domain prove nothing: a ray falling through the slab
    /// `0 < y <= 1` of `min(log(y), |p| - 1)` from far beside the ball is not proven clear (a
    /// NaN bound of the logarithm would drop out of the `min`, leaving the ball's positive
    /// one), nor is a stretch across the slab, while a ray rising away from both is.
    #[test]
    fn bounds_that_turn_nan_prove_nothing() {
        let e = escape_of(&scene(&["sdf |p| min(log(p.y), length(p) - 1)"]));
        let mut proofs = Proofs::default();
        let (far, down, up) = (DVec4::new(10.0, 5.0, 0.0, 0.0), -DVec4::Y, DVec4::Y);
        assert!(!e.escapes(far, down, false, &mut e.unbounded(), &mut proofs));
        assert_eq!(e.clear(far, down, 10.0, false, &mut proofs), 0.0);
        assert!(e.escapes(far, up, false, &mut e.unbounded(), &mut proofs));
        // A line along the ray with a NaN end is read by its parent too: the arcsine past 1
        // (where the kernel's `max` keeps `x - 10`, solid) must not let the `max` pick it and
        // the `min` then pick the other operand's line.
        let (o, d) = (
            DVec4::new(0.0, 0.5, -3.0, 0.0),
            DVec4::new(0.0, 0.3, 1.0, 0.0),
        );
        let d = d.normalize();
        let arcsine = "max(p.x - 10, asin(p.y) / 1rad + 5)";
        let e = escape_of(&scene(&[&format!("sdf |p| min({arcsine}, length(p) - 1)")]));
        assert!(e.clear(o, d, 5.0, false, &mut proofs) < 1.7);
        let e = escape_of(&scene(&[&format!("sdf |p| min({arcsine}, p.x + 1)")]));
        assert!(!e.escapes(o, d, false, &mut e.unbounded(), &mut proofs));
        // A square root below zero is NaN too: this field is solid for y < 0.
        let e = escape_of(&scene(&["sdf |p| max(length(p) - 2, sqrt(p.y) + 0.1)"]));
        let (o, d) = (
            DVec4::new(0.0, -0.5, -5.0, 0.0),
            DVec4::new(0.0, -0.1, 1.0, 0.0),
        );
        let d = d.normalize();
        assert!(!e.escapes(o, d, false, &mut e.unbounded(), &mut proofs));
        assert!(e.clear(o, d, 10.0, false, &mut proofs) < 4.0);
        // A NaN that an outer `max` drops: past `x = 0` the inner `max` is NaN (its first
        // operand is), and the outer one keeps `-1 - z^2` there, solid. The inner `max`'s
        // bounds must not read as at least `y - 0.5` where its first operand may be NaN.
        let e = escape_of(&scene(&[
            "sdf |p| max(-1 - p.z * p.z, max(sqrt(p.x), p.y - 0.5))",
        ]));
        let (o, d) = (
            DVec4::new(1.0, 1.0, 0.0, 0.0),
            DVec4::new(-1.0, 0.2, 0.0, 0.0),
        );
        let d = d.normalize();
        assert!(!e.escapes(o, d, false, &mut e.unbounded(), &mut proofs));
        assert!(e.clear(o, d, 10.0, false, &mut proofs) < 1.1);
    }

    /// Fields with products, quotients, powers and logarithms that are numbers wherever a ray
    /// goes keep their escape proofs: the bounds do not mark them as maybe NaN for an infinite
    /// bound times 0 (a limit along the ray), a division whose numerator is never 0, a square
    /// or the logarithm of a positive number (a reviewer's cases, which lost their proofs when
    /// every one was marked).
    #[test]
    fn fields_that_are_numbers_keep_their_proofs() {
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let mut proofs = Proofs::default();
        for (field, o, d) in [
            ("max(max(p.y, 0) * p.x, length(p) - 1)", [3.0, 0.5], [s, -s]),
            ("max((p.x + 5) / p.y, length(p) - 1)", [3.0, 3.0], [s, s]),
            (
                "max(pow(abs(p.x), 2) - 1, length(p) - 1)",
                [3.0, 0.5],
                [s, s],
            ),
            ("max(log(abs(p.x) + 1), length(p) - 1)", [3.0, 0.5], [s, s]),
        ] {
            let e = escape_of(&scene(&[&format!("sdf |p| {field}")]));
            let (o, d) = (
                DVec4::new(o[0], o[1], 0.0, 0.0),
                DVec4::new(d[0], d[1], 0.0, 0.0),
            );
            assert!(
                e.escapes(o, d, false, &mut e.unbounded(), &mut proofs),
                "{field}"
            );
            assert_eq!(e.clear(o, d, 10.0, false, &mut proofs), 10.0, "{field}");
        }
    }

    /// The proofs skipped (`never_clears`) are only ones that would have failed: on random
    /// rays, outside and inside objects, the proof tried anyway never succeeds where it is
    /// skipped, in tilings, their unions and intersections with planes and generated scenes.
    /// It is skipped in a D4 packing, alone or beside a floor, and tried in a rectangular
    /// tiling and a D4 packing cut by a plane, where rays in channels or past the plane clear.
    #[test]
    fn escape_proofs_are_skipped_only_where_none_succeeds() {
        let packing = "hypersphere(radius: 0.6) |> tile(d4(scale: 1))";
        let floor = "halfspace(normal: [0, 1, 0, 0], offset: 1)";
        let cases = [
            (scene(&[packing]), Some(true)),
            (scene(&[packing, floor]), Some(true)),
            (
                include_str!("../../examples/d4_packing.4ds").to_string(),
                Some(true),
            ),
            (
                scene(&[&format!("intersect({packing}, {floor})")]),
                Some(false),
            ),
            (
                scene(&["hypersphere(radius: 0.3) |> tile(grid(2))"]),
                Some(false),
            ),
            (scene(&[floor]), Some(false)),
        ];
        let generated = (1..=60).map(|seed| (crate::generate::generate(seed).source, None));
        let mut rng = Pcg64Mcg::seed_from_u64(11);
        let mut proofs = Proofs::default();
        let (mut skipped, mut cleared) = (0, 0);
        for (source, expect) in cases.into_iter().chain(generated) {
            let mut escape = escape_of(&source);
            let never = escape.never;
            if let Some(e) = expect {
                assert_eq!(never[0], e, "{source}");
            }
            escape.never = [false; 2];
            for _ in 0..200 {
                let p = DVec4::from_array(std::array::from_fn(|_| rng.random_range(-5.0..5.0)));
                let d = DVec4::from_array(std::array::from_fn(|_| rng.random_range(-1.0..1.0)));
                let d = d.normalize();
                for interior in [false, true] {
                    let mut keep = escape.unbounded();
                    let clears = escape.escapes(p, d, interior, &mut keep, &mut proofs);
                    assert!(!(clears && never[interior as usize]), "{p} {d} {source}");
                    skipped += never[interior as usize] as u32;
                    cleared += clears as u32;
                }
            }
        }
        assert!(skipped >= 1200 && cleared > 1000, "{skipped} {cleared}");
    }
}
