//! The scene's tapes specialised to regions of space: a 16-way tree over a 4D cube around the
//! region rays visit, built lazily as rays reach its cells. Each cell carries the scene (and
//! interior) tapes pruned to the cell (`ir::prune`), in coordinates local to the cell's
//! centre, with interval lower bounds of their distances there and, where the distance is a
//! few planes, spheres, boxes and polytopes in the cell, its exact form (`ir::exact`), for
//! rays outside objects and for those inside. Inside a cell the pruned tapes compute what
//! the whole scene tape does wherever the distance is below the cell's `reach` (a fraction of
//! its edge) and a lower bound of at least `reach` elsewhere, so a ray step evaluates only the
//! objects near where it is.
//!
//! Precision: cells that hold a surface split until `f32` resolves the marching epsilon in
//! their local coordinates (`PRECISE_EDGE`), and their tapes are compiled from forms without
//! the cancellation of large constants (`ir::precise`), so a hypersphere of radius 1e5 or a
//! scene far from the origin is met to the epsilon, not to the rounding of its size.
//! Points outside the cube use the objects that may reach outside it only (the unbounded
//! ones, and bounded ones the cube leaves out: tilings, fields bounded by intervals), in
//! coordinates local to its centre, and a ray there drops the unbounded ones it provably never
//! meets.

use super::Tape;
use super::escape::entry;
use crate::ir::exact::{Meeting, Piece, Pieces, Rays, partition, pieces};
use crate::ir::interval::I;
use crate::ir::lower::nearest;
use crate::ir::precise::precise;
use crate::ir::prune::Pruned;
use crate::ir::{Graph, Id, Node, Un};
use crate::math::lanes::{F4, Lane, each};
use glam::DVec4;
use std::sync::OnceLock;
use std::sync::atomic::{AtomicU64, Ordering};

/// Deepest level to which cells split to shorten their tapes: 1/256 of the cube's edge.
const MAX_DEPTH: u32 = 8;
/// Deepest level to which cells holding a surface split to resolve the marching epsilon in
/// `f32` (`PRECISE_EDGE`), in scenes much larger than it.
const PRECISE_DEPTH: u32 = 24;
/// A cell resolves the epsilon when its edge is at most this many epsilons: `f32` then
/// rounds its local coordinates by about a sixteenth of it.
const PRECISE_EDGE: f64 = (1u64 << 20) as f64;
/// Cells split to resolve no epsilon below this (the final preset's): in a scene whose
/// surfaces fill space (a tiling), resolving 1e-9 would build a cell for almost every step.
/// Below it, the tolerance grows with the cell as `f32` needs.
const PRECISE_FLOOR: f64 = 1e-5;
/// Levels split whether or not the split shortened the tapes: the first splits of a cube
/// around a whole scene rarely separate its objects.
const FREE_DEPTH: u32 = 2;
/// A cell whose tapes have at most this many instructions is not split further: running
/// them costs less than building the children.
const SPLIT_LEN: usize = 48;
/// Exact cells of more pieces than this still split while that shortens their tapes: a ray
/// meets every piece of its cell.
pub const FEW_PIECES: usize = 24;
/// A cell whose tapes are longer than this is split even when its parent's were no longer:
/// the bounds pruning cuts objects by their distance, which takes smaller cells.
const LONG_LEN: usize = 64;
/// A cell's tapes are exact where the distance is below this fraction of its edge; beyond,
/// objects farther than that are cut to their lower bound (`ir::prune`). Small cells next
/// to a surface then hold only the objects nearest it, and most cells near a dense union
/// hold none and are crossed in one jump.
const REACH: f64 = 0.125;

/// Laid out for the marcher: what locating a point reads (corner, edge, children) and the
/// scene's lower bound come first, in the cell's first cache line (each step into a new
/// cell misses on it); the interior's bound, the exact pieces and the origin follow in the
/// second.
#[repr(C, align(64))]
pub struct Cell {
    /// The corner with the smallest coordinates, and the edge length.
    pub lo: DVec4,
    pub size: f64,
    /// The 16 children, each built when a ray first reaches it; none when the cell is not
    /// split.
    children: Box<[OnceLock<Box<Cell>>]>,
    /// Lower bounds over the cell of the scene's distance and the interior's (minus infinity
    /// where unknown).
    pub lower: [f64; 2],
    /// The scene distance as the smallest of a few planes, spheres, boxes and polytopes in
    /// local coordinates, where it is one over the whole cell (halfspaces, walls seen from
    /// inside a box, a hypersphere alone): rays meet it exactly.
    pub exact: Option<Pieces>,
    /// The interior's unsigned distance as such pieces, for rays inside objects (the faces
    /// of a glass box and the floor under it, each of whose `|f|` is met on the ray's side).
    pub inner: Option<Pieces>,
    /// Where the tapes' local coordinates are zero.
    pub origin: DVec4,
    /// Outputs: signed distance to the nearest visible object and its index (as `vm::Program`).
    pub scene: Tape,
    /// Outputs: unsigned distance to the nearest surface and its object, for rays inside.
    pub interior: Option<Tape>,
    /// Each object's distance, for the normals of hits in the cell (compiled at the first).
    objects: OnceLock<Vec<Tape>>,
    /// The tapes are exact where the distance is below this; above it they give a lower
    /// bound of it, itself at least this (`REACH`).
    pub reach: f64,
    /// How far `f32` may round the interior tape's distance in the cell (`ir::precise::
    /// rounding`; 0 without one, infinite where unknown).
    rounding: f64,
    /// The same bound for the scene tape: 0 where rays outside objects never read it near a
    /// surface (no surface in the cell, or exact pieces). Partial cells bound the whole scene
    /// tape, not their `rest`, which is no looser.
    scene_rounding: f64,
    /// Where the distance is not, but some objects' are: rays outside objects meet those
    /// exactly and step on the others alone (`partial`, built when a ray first needs it:
    /// rays march only in cells without children).
    partial: OnceLock<Option<Partial>>,
    /// The pruned graph, for the object tapes and the children.
    graph: Pruned,
    needs: Needs,
    depth: u32,
    /// Instructions in the tapes.
    len: usize,
}

/// A cell's distance as a few planes and spheres met exactly (`pieces`, which hold only in
/// the cell) and the tape of the other objects (`rest`: distance and nearest object). A ray
/// grazing a floor next to a box steps on the box's distance, not on its height over the
/// floor.
pub struct Partial {
    pub pieces: Pieces,
    pub rest: Tape,
}

/// What building a cell costs beside the nodes of its pruned graph, in such nodes: about 5
/// us a cell against 0.5 us a node, fitted with the probe's weight of a node
/// (`render::probe`'s `BUILT`, which says how).
pub const CELL_NODES: usize = 10;

/// The tree of one frame's cells, and what lies outside its cube.
pub struct Cells {
    /// The work of building the cells so far, in nodes of their graphs (`CELL_NODES` more
    /// for each cell): what the lazy tree costs, for the probe's model, tests and
    /// measurements.
    built: AtomicU64,
    root: Cell,
    /// Points outside the cube: the scene without the objects that lie inside it. A step from
    /// such a point may go no further than to the cube.
    outside: Outside,
}

/// The cells outside the cube: one of every object outside it, and one of each subset of the
/// unbounded ones (with all the `wide` ones), built when a ray first proves it meets no other
/// (`Escape::escapes`): a ray grazing a floor past a custom field meets the floor exactly once
/// the field is out of its way.
struct Outside {
    all: Cell,
    graph: Graph,
    unbounded: Vec<(usize, Id)>,
    /// Bounded objects outside the cube (`Cells::new`), in every one of these cells.
    wide: Vec<(usize, Id)>,
    objects: Vec<Id>,
    needs: Needs,
    origin: DVec4,
    /// Indexed by the set's bits (bit `i`: `unbounded[i]`); empty for more than `SUBSETS`
    /// unbounded objects.
    subsets: Box<[OnceLock<Cell>]>,
}

/// An object outside the cube: its index and its distance.
pub type Placed = (usize, Id);

/// The most unbounded objects whose subsets get cells of their own.
const SUBSETS: usize = 6;

impl Outside {
    fn new(
        graph: &Graph,
        (unbounded, wide): (&[Placed], &[Placed]),
        objects: Vec<Id>,
        needs: Needs,
        origin: DVec4,
    ) -> Outside {
        let n = unbounded.len();
        let subsets = if n <= SUBSETS { 1 << n } else { 0 };
        let every: Vec<(usize, Id)> = unbounded.iter().chain(wide).copied().collect();
        Outside {
            all: outside(graph, &every, &objects, needs, origin),
            graph: graph.clone(),
            unbounded: unbounded.to_vec(),
            wide: wide.to_vec(),
            objects,
            needs,
            origin,
            subsets: (0..subsets).map(|_| OnceLock::new()).collect(),
        }
    }

    /// The cell of the unbounded objects in `keep` (bit `i`: `unbounded[i]`).
    fn keeping(&self, keep: u64) -> &Cell {
        // The last slot, every object, is `all` itself.
        match self.subsets.get(keep as usize) {
            Some(cell) if keep as usize + 1 < self.subsets.len() => cell.get_or_init(|| {
                let kept: Vec<(usize, Id)> = (self.unbounded.iter().enumerate())
                    .filter(|(i, _)| keep >> i & 1 == 1)
                    .map(|(_, &u)| u)
                    .chain(self.wide.iter().copied())
                    .collect();
                outside(&self.graph, &kept, &self.objects, self.needs, self.origin)
            }),
            _ => &self.all,
        }
    }
}

/// The cell of everything outside the cube where the objects are `unbounded`, local to
/// `origin`.
fn outside(
    g: &Graph,
    unbounded: &[(usize, Id)],
    objects: &[Id],
    needs: Needs,
    origin: DVec4,
) -> Cell {
    let mut og = g.clone();
    let scene = nearest(&mut og, unbounded);
    let abs: Vec<(usize, Id)> = (unbounded.iter())
        .map(|&(i, d)| (i, og.intern(Node::Un(Un::Abs, d))))
        .collect();
    let roots = Roots {
        scene,
        interior: needs.interior.then(|| nearest(&mut og, &abs)),
        objects: objects.to_vec(),
    };
    let beyond = Pruned {
        graph: og,
        roots: roots.flat(),
        bounds: vec![],
        compact: false,
    };
    let everywhere = Place {
        lo: DVec4::splat(f64::NEG_INFINITY),
        size: f64::INFINITY,
        origin,
    };
    Cell::new(&beyond, DVec4::ZERO, everywhere, 0, 0, needs)
}

/// The distance below which a point counts as on a surface, at `p` in a tape's local
/// coordinates: `f32` cannot resolve distances below a few ulps of the coordinates, so far
/// from the tape's origin the epsilon grows with them.
pub fn epsilon_at(p: DVec4, epsilon: f64) -> f64 {
    epsilon.max(p.abs().max_element() * (1.0 / (1u64 << 21) as f64))
}

/// How far a path leaving a hit at `p` must step off it, in epsilons' terms: the epsilon of
/// the cell where the hit's distance was evaluated (`Cell::epsilon`), not of its distance
/// from the origin; on the whole tape (no cell) the epsilon itself, since hits the tape's
/// `f32` cannot resolve settle in `f64` (`render::march::approach`, and `careful` inside
/// objects), and so do the next segment's first steps. Stepping off by the whole tape's
/// rounding instead lifted a floor's paths 0.27 off it at 1e5 from the origin, and its light
/// read 1.35 times too bright. The integrator, the probe's bounces and the differential
/// harness all leave hits by it.
pub fn hit_epsilon(cell: Option<&Cell>, p: DVec4, epsilon: f64, interior: bool) -> f64 {
    cell.map_or(epsilon, |cell| cell.epsilon(p, epsilon, interior))
}

/// The cells from the root down to one cell (`Cells::locate`).
#[derive(Clone, Copy)]
pub struct Path<'a> {
    cells: [&'a Cell; PRECISE_DEPTH as usize + 1],
    len: usize,
}

/// The roots a cell specialises: the scene's distance and nearest object, the interior's
/// (when some object can be entered), and each object's distance (for normals).
#[derive(Clone, Debug)]
pub struct Roots {
    pub scene: (Id, Id),
    pub interior: Option<(Id, Id)>,
    pub objects: Vec<Id>,
}

impl Roots {
    /// Scene, interior (the scene's again when there is none, so offsets stay put), objects.
    fn flat(&self) -> Vec<Id> {
        let (d, n) = self.scene;
        let (e, m) = self.interior.unwrap_or(self.scene);
        [d, n, e, m]
            .into_iter()
            .chain(self.objects.iter().copied())
            .collect()
    }
}

/// What every cell's tapes must provide: the interior tape (when some object can be
/// entered), and distances that resolve the marching epsilon.
#[derive(Clone, Copy, Debug)]
struct Needs {
    interior: bool,
    epsilon: f64,
}

/// Where a cell is: its corner with the smallest coordinates, its edge, and the point its
/// tapes' local coordinates are zero at.
#[derive(Clone, Copy, Debug)]
struct Place {
    lo: DVec4,
    size: f64,
    origin: DVec4,
}

impl Place {
    /// The cell in its own local coordinates (everything, outside the cube).
    fn region(&self) -> [I; 4] {
        std::array::from_fn(|a| {
            if self.size.is_finite() {
                let lo = self.lo[a] - self.origin[a];
                I::new(lo, lo + self.size)
            } else {
                I::ALL
            }
        })
    }

    /// The graph to compile the cell's tapes from, when `pr` (pruned to the cell) has nodes
    /// that `f32` would round by more than the cell resolves (`ir::precise`), and the roots
    /// to compile.
    fn precise(&self, pr: &Pruned, epsilon: f64) -> (Option<Graph>, Vec<Id>) {
        if !self.size.is_finite() {
            return (None, pr.roots.clone());
        }
        let quantum = epsilon_at(DVec4::splat(self.size / 2.0), epsilon);
        match precise(&pr.graph, &pr.roots, self.region(), quantum) {
            Some((g, roots)) => (Some(g), roots),
            None => (None, pr.roots.clone()),
        }
    }
}

impl Cells {
    /// Cells over the cube of edge `size` at corner `lo`, from the frame's optimised graph.
    /// `scene` is the scene's distance and nearest object, `interior` the interior's, and
    /// `objects` each object's distance. `unbounded` lists (object index, distance) for the
    /// objects that may reach outside the cube, as `Escape::escapes` proves rays clear of them
    /// (its `keep` bits), and `wide` others outside it that no escape proof clears (bounded
    /// objects in the proof's box, kept out of the cube); every other object lies inside it. Near
    /// surfaces, cells resolve `epsilon` (the marching epsilon) however large the cube.
    pub fn new(
        g: &Graph,
        tapes: Roots,
        (lo, size): (DVec4, f64),
        (unbounded, wide): (&[Placed], &[Placed]),
        epsilon: f64,
    ) -> Cells {
        let interior = tapes.interior.is_some();
        let needs = Needs { interior, epsilon };
        let whole = Pruned {
            graph: g.clone(),
            roots: tapes.flat(),
            bounds: vec![],
            compact: false,
        };
        let centre = lo + DVec4::splat(size / 2.0);
        let cube = Place {
            lo,
            size,
            origin: centre,
        };
        let root = Cell::new(&whole, DVec4::ZERO, cube, 0, usize::MAX, needs);
        let outside = Outside::new(g, (unbounded, wide), tapes.objects, needs, centre);
        Cells {
            built: AtomicU64::new(0),
            root,
            outside,
        }
    }

    /// The deepest cell holding `p`.
    pub fn find(&self, p: DVec4) -> &Cell {
        self.locate(&mut self.path(), p)
    }

    /// A path that leads nowhere yet, for `locate`.
    pub fn path(&self) -> Path<'_> {
        Path {
            cells: [&self.root; PRECISE_DEPTH as usize + 1],
            len: 0,
        }
    }

    /// The deepest cell holding `p`, climbing from the end of `path` (the cells down to where
    /// the ray last was) only as far as it must, and leaving the new path there.
    pub fn locate<'a>(&'a self, path: &mut Path<'a>, p: DVec4) -> &'a Cell {
        while path.len > 0 && !path.cells[path.len - 1].contains(p) {
            path.len -= 1;
        }
        if path.len == 0 {
            if !self.root.contains(p) {
                return &self.outside.all;
            }
            (path.cells[0], path.len) = (&self.root, 1);
        }
        let mut c = path.cells[path.len - 1];
        while let Some(kid) = c.child(p, &self.built) {
            (path.cells[path.len], path.len) = (kid, path.len + 1);
            c = kid;
        }
        c
    }

    /// The work of building the cells so far (not the root), in nodes (`CELL_NODES`).
    pub fn built(&self) -> u64 {
        self.built.load(Ordering::Relaxed)
    }

    /// Whether `cell` is (one of) the region outside the cube.
    pub fn is_outside(&self, cell: &Cell) -> bool {
        !cell.size.is_finite()
    }

    /// The region outside the cube with only the unbounded objects in `keep` (bit `i`: the
    /// `i`th, as `Escape::escapes` proves them out of a ray's way).
    pub fn outside(&self, keep: u64) -> &Cell {
        self.outside.keeping(keep)
    }

    /// How far `p` is from the cube (0 inside): outside it, the distance the outside cell
    /// gives holds only this far, since it leaves out the objects inside the cube.
    pub fn gap(&self, p: DVec4) -> f64 {
        let hi = self.root.lo + DVec4::splat(self.root.size);
        (self.root.lo - p).max(p - hi).max(DVec4::ZERO).length()
    }

    /// Where the ray from `o` along `d`, starting outside the cube, enters it (infinity when
    /// it starts inside or never gets there: once out, it stays out).
    pub fn enter(&self, o: DVec4, d: DVec4) -> f64 {
        let hi = self.root.lo + DVec4::splat(self.root.size);
        match entry(o, d, self.root.lo, hi) {
            // A ray from the cube's high faces, which belong to the cells beyond, enters at 0.
            Some(_) if self.root.contains(o) => f64::INFINITY,
            Some(t) => t,
            None => f64::INFINITY,
        }
    }
}

/// The cell's distance split into pieces met exactly and a tape of the rest, where it has
/// both.
fn partial(pr: &Pruned, place: Place, needs: Needs) -> Option<Partial> {
    let (pieces, rest) = partition(&pr.graph, pr.roots[0], pr.roots[1])?;
    let mut graph = pr.graph.clone();
    let (d, n) = nearest(&mut graph, &rest);
    let rest = Pruned {
        graph,
        roots: vec![d, n],
        bounds: vec![],
        compact: false,
    };
    let (precise, roots) = place.precise(&rest, needs.epsilon);
    let tape = Tape::compile("rest", precise.as_ref().unwrap_or(&rest.graph), &roots);
    Some(Partial {
        pieces: pieces.into(),
        rest: tape,
    })
}

impl Cell {
    /// The cell at corner `lo` with edge `size`, pruned from `parent` (whose local origin is
    /// `parent_origin`), local to `origin`.
    fn new(
        parent: &Pruned,
        parent_origin: DVec4,
        place: Place,
        depth: u32,
        parent_len: usize,
        needs: Needs,
    ) -> Cell {
        let Place { lo, size, origin } = place;
        let region = place.region();
        let shift = (origin - parent_origin).to_array();
        let reach = if size.is_finite() {
            REACH * size
        } else {
            f64::INFINITY
        };
        let pr = parent.prune(region, shift, reach);
        let (precise, roots) = place.precise(&pr, needs.epsilon);
        let tapes = precise.as_ref().unwrap_or(&pr.graph);
        let scene = Tape::compile("scene", tapes, &roots[..2]);
        let interior = (needs.interior).then(|| Tape::compile("interior", tapes, &roots[2..4]));
        let rounding = if needs.interior {
            crate::ir::precise::rounding(tapes, roots[2], region)
        } else {
            0.0
        };
        // (A distance that may be NaN in the cell is not known to be above anything.)
        let lower = [0, 2].map(|r| match pr.bounds[r].nan {
            true => f64::NEG_INFINITY,
            false => pr.bounds[r].lo,
        });
        let exact = pieces(&pr.graph, pr.roots[0], pr.roots[1]).map(Pieces::from);
        let inner = (needs.interior)
            .then(|| pieces(&pr.graph, pr.roots[2], pr.roots[3]))
            .flatten()
            .map(Pieces::from);
        let scene_rounding = if lower[0] > 0.0 || exact.is_some() {
            0.0
        } else {
            crate::ir::precise::rounding(tapes, roots[0], region)
        };
        let len = scene.code.len() + interior.as_ref().map_or(0, |t| t.code.len());
        // A cell with no surface in it is crossed in one jump and never split. Others split
        // while that still shortens the tapes (where two surfaces meet, no subdivision
        // separates them), and at the first levels in any case: the first splits of a cube
        // around a whole scene rarely separate its objects, but they do carve out empty space.
        // Cells with a surface also split while they are too large for `f32` to resolve the
        // epsilon in them.
        let empty = lower[0].min(lower[1]) > 0.0;
        let shorter = depth < MAX_DEPTH
            && len > SPLIT_LEN
            && (len < parent_len || depth < FREE_DEPTH || len > LONG_LEN);
        // Exact cells need no splitting, unless rays inside objects march their f32 interior
        // tape there.
        let finer = depth < PRECISE_DEPTH && size > PRECISE_EDGE * needs.epsilon.max(PRECISE_FLOOR);
        let many = exact.as_ref().is_none_or(|e| e.len() > FEW_PIECES);
        let split = !empty
            && ((shorter && many)
                || (finer && (exact.is_none() || needs.interior && inner.is_none())));
        Cell {
            lo,
            size,
            origin,
            scene,
            interior,
            objects: OnceLock::new(),
            reach,
            rounding,
            scene_rounding,
            lower,
            exact,
            inner,
            partial: OnceLock::new(),
            graph: pr,
            needs,
            depth,
            len,
            children: (0..if split { 16 } else { 0 })
                .map(|_| OnceLock::new())
                .collect(),
        }
    }

    /// The pieces that rays outside objects (`interior` false) or inside them meet exactly in
    /// the cell, where its distance for them is one.
    pub fn pieces(&self, interior: bool) -> Option<&Pieces> {
        if interior { &self.inner } else { &self.exact }.as_ref()
    }

    /// The cell's pieces and the tape of the rest, where it is partial (not exact).
    pub fn partial(&self) -> Option<&Partial> {
        (self.partial)
            .get_or_init(|| {
                let partial = || partial(&self.graph, self.place(), self.needs);
                self.exact.is_none().then(partial).flatten()
            })
            .as_ref()
    }

    fn place(&self) -> Place {
        Place {
            lo: self.lo,
            size: self.size,
            origin: self.origin,
        }
    }

    /// Each object's distance in the cell, local to its origin.
    pub fn objects(&self) -> &[Tape] {
        self.objects.get_or_init(|| {
            let (precise, roots) = self.place().precise(&self.graph, self.needs.epsilon);
            let tapes = precise.as_ref().unwrap_or(&self.graph.graph);
            (roots[4..].iter())
                .map(|r| Tape::compile("object", tapes, &[*r]))
                .collect()
        })
    }

    /// The distance below which a point `p` of the cell counts as on a surface, for a ray
    /// inside an object (`interior`, which marches the `f32` interior tape) or not: the
    /// marching `epsilon`, or more where the cell's `f32` tapes cannot resolve it at `p`.
    /// Exact pieces, which rays outside objects meet, are evaluated in `f64`, which resolves
    /// it.
    ///
    /// Rays inside objects also resolve no less than twice the bound of the interior tape's
    /// rounding in the cell (a step overshoots a surface by that at most): their unsigned
    /// distance shows no sign change where a step crosses a surface, so one that never
    /// rounds below the epsilon (a rounded box's edge of radius 1e3, a length of 1e3 less the
    /// radius) let rays through it. Rays outside objects see the crossing as a negative
    /// distance.
    pub fn epsilon(&self, p: DVec4, epsilon: f64, interior: bool) -> f64 {
        if self.pieces(interior).is_some() {
            epsilon
        } else if interior && self.rounding.is_finite() {
            epsilon_at(p - self.origin, epsilon).max(self.rounding)
        } else {
            epsilon_at(p - self.origin, epsilon)
        }
    }

    /// How far the scene tape's distance may be from the true one where rays outside
    /// objects read it in the cell (a bound of its `f32` rounding; 0 where they never do: no
    /// surface in the cell, or exact pieces). A step may end inside a surface by that much.
    pub fn scene_slack(&self) -> f64 {
        self.scene_rounding
    }

    /// How far the interior tape's distance may be from the true one in the cell (a bound of
    /// its `f32` rounding; infinite where unknown, as outside the cube).
    pub fn slack(&self) -> f64 {
        self.rounding
    }

    /// Which cell this is, the same in every run (its depth and corner), for ordering work
    /// by cell without depending on where it lives in memory.
    pub fn id(&self) -> (u32, [u64; 4]) {
        (self.depth, self.lo.to_array().map(f64::to_bits))
    }

    pub fn contains(&self, p: DVec4) -> bool {
        (0..4).all(|a| self.lo[a] <= p[a] && p[a] < self.lo[a] + self.size)
    }

    /// How far the ray from `p` (inside the cell) along `d` travels before it leaves.
    pub fn exit(&self, p: DVec4, d: DVec4) -> f64 {
        (0..4)
            .map(|a| match d[a] {
                x if x > 0.0 => (self.lo[a] + self.size - p[a]) / x,
                x if x < 0.0 => (self.lo[a] - p[a]) / x,
                _ => f64::INFINITY,
            })
            .fold(f64::INFINITY, f64::min)
            .max(0.0)
    }

    /// The child holding `p` (a point of this cell), built on first use; `None` if the cell
    /// is not split.
    fn child(&self, p: DVec4, built: &AtomicU64) -> Option<&Cell> {
        let half = self.size / 2.0;
        let mid = self.lo + DVec4::splat(half);
        let k: usize = (0..4).map(|a| ((p[a] >= mid[a]) as usize) << a).sum();
        let kid = self.children.get(k)?;
        Some(kid.get_or_init(|| {
            let lo =
                self.lo + DVec4::from_array(std::array::from_fn(|a| ((k >> a) & 1) as f64 * half));
            let place = Place {
                lo,
                size: half,
                origin: lo + DVec4::splat(half / 2.0),
            };
            let kid = Cell::new(
                &self.graph,
                self.origin,
                place,
                self.depth + 1,
                self.len,
                self.needs,
            );
            built.fetch_add(
                (kid.graph.graph.len() + CELL_NODES) as u64,
                Ordering::Relaxed,
            );
            Box::new(kid)
        }))
    }
}

/// What a ray meets of a cell's pieces (`meet`), each as (distance or `t`, object): read
/// through `near` and `first`. The numbers of a pair lie apart: the out-of-line meetings write
/// them one at a time, and a pair copied as one 16-byte load could not be forwarded from those
/// two stores (it waited for them to retire: a fifth of the marcher's loop in a scene of
/// partial cells).
#[derive(Clone, Copy, Debug)]
pub struct Met {
    /// The nearest piece's distance at the ray's point, and the first piece's `t` (infinity
    /// when it meets none before `clear`).
    near_d: f64,
    first_t: f64,
    /// How far the ray is known to meet no piece: at least the `limit` asked for, unless a
    /// tiled ball's crossing of its lattice gave up before (`Form::meet`).
    pub clear: f64,
    /// The nearest piece's object, and the first piece's.
    near_object: f64,
    first_object: f64,
    /// Lattice cells the tiled balls' crossings went through.
    pub cells: usize,
}

/// What the ray from `p` (local to the pieces' cell) along `d` meets of `pieces`, looking at
/// least `limit` far, or across at most `cells` cells of a tiled ball's lattice. Cells with
/// moved balls (`Pieces::has_moved`) meet them eight at a time, in a function of their own:
/// that pass beside the other forms' loop, even untaken, made meeting boxes 9 to 12% slower.
#[inline(always)]
pub fn meet(pieces: &Pieces, p: DVec4, d: DVec4, reach: (f64, usize)) -> Met {
    match pieces.has_moved() {
        true => meet_moved(pieces, p, d, reach),
        false => meet_forms(pieces, p, d, reach),
    }
}

/// `meet` for up to four rays (`Rays`), lane by lane the same: planes, balls and boxes meet
/// them in the lanes of one vector (`Form::meet_lanes`).
pub fn meet_lanes(pieces: &Pieces, rays: &Rays) -> [Met; 4] {
    let mut met = [Met::NONE; 4];
    if pieces.has_moved() {
        for (l, met) in met.iter_mut().enumerate().take(rays.live()) {
            let (p, d, reach) = rays.ray(l);
            *met = meet_moved(pieces, DVec4::from_array(p), DVec4::from_array(d), reach);
        }
        return met;
    }
    crate::simd::wide!({
        // `Met::take` and `Met::cut` in the lanes of vectors.
        let inf = F4::splat(f64::INFINITY);
        let (mut near, mut first, mut clear) = ((inf, F4::splat(0.0)), (inf, F4::splat(0.0)), inf);
        let mut cells = [0; 4];
        for piece in pieces.iter() {
            let m = piece.form.meet_lanes(rays);
            let object = F4::splat(piece.object);
            near = nearer(near, (F4(m.value), object));
            (clear, cells) = (clear.min(F4(m.clear)), each(|l| cells[l] + m.cells[l]));
            first = nearer(first, (F4(m.first), object));
        }
        let first = cut_beyond(first, clear);
        each(|l| Met {
            near_d: near.0.at(l),
            first_t: first.0.at(l),
            clear: clear.at(l),
            near_object: near.1.at(l),
            first_object: first.1.at(l),
            cells: cells[l],
        })
    })
}

#[inline(never)]
fn meet_moved(pieces: &Pieces, p: DVec4, d: DVec4, reach: (f64, usize)) -> Met {
    let mut met = Met::NONE;
    for (piece, m) in pieces.meetings(p.to_array(), d.to_array(), reach) {
        met.take(piece, m);
    }
    met.cut()
}

impl Met {
    /// Nothing met yet.
    const NONE: Met = Met {
        near_d: f64::INFINITY,
        first_t: f64::INFINITY,
        clear: f64::INFINITY,
        near_object: 0.0,
        first_object: 0.0,
        cells: 0,
    };

    /// The nearest piece at the ray's point: its distance and object.
    #[inline(always)]
    pub fn near(&self) -> (f64, f64) {
        (self.near_d, self.near_object)
    }

    /// The first piece the ray meets: its `t` (infinity when it meets none before `clear`)
    /// and object.
    #[inline(always)]
    pub fn first(&self) -> (f64, f64) {
        (self.first_t, self.first_object)
    }

    /// A piece's meeting with the ray, after those before it (ties go to the first).
    #[inline(always)]
    fn take(&mut self, piece: &Piece, m: Meeting) {
        let first = m.first.unwrap_or(f64::NAN);
        (self.near_d, self.near_object) =
            nearer((self.near_d, self.near_object), (m.value, piece.object));
        (self.clear, self.cells) = (self.clear.min(m.clear), self.cells + m.cells);
        (self.first_t, self.first_object) =
            nearer((self.first_t, self.first_object), (first, piece.object));
    }

    /// `cut_beyond` of the first piece.
    #[inline(always)]
    fn cut(mut self) -> Met {
        (self.first_t, self.first_object) =
            cut_beyond((self.first_t, self.first_object), self.clear);
        self
    }
}

/// A (distance or `t`, object) pair kept against a later piece's (`value`, `object`): the
/// later where it is below (ties go to the first; NaN is below nothing). One ray's or four's.
#[inline(always)]
fn nearer<L: Lane>((d, o): (L, L), (value, object): (L, L)) -> (L, L) {
    let below = value.lt(d);
    (L::select(below, value, d), L::select(below, object, o))
}

/// The first piece's (`t`, object), none (infinity) where it lies beyond `clear`: beyond where
/// one piece's crossing gave up, it may be met before the first of the others.
#[inline(always)]
fn cut_beyond<L: Lane>((t, o): (L, L), clear: L) -> (L, L) {
    let beyond = t.gt(clear);
    let none = (L::splat(f64::INFINITY), L::splat(0.0));
    (L::select(beyond, none.0, t), L::select(beyond, none.1, o))
}

#[inline(never)]
fn meet_forms(pieces: &[Piece], p: DVec4, d: DVec4, reach: (f64, usize)) -> Met {
    crate::simd::wide!({
        let (p, d) = (p.to_array(), d.to_array());
        let mut met = Met::NONE;
        for piece in pieces {
            met.take(piece, piece.form.meet(p, d, reach));
        }
        met.cut()
    })
}
