//! The path tracer: unidirectional paths with BSDF and phase-function sampling, a wavefront
//! at a time. All paths of a batch march together through the VM; hits are then grouped by
//! object so normals (forward-mode gradients) and material maps also run as packets.
//!
//! # Next-event estimation
//! With `Settings::light_sampling` on, every non-delta scattering vertex (diffuse, rough shiny,
//! a scattering event in a medium) also samples a direction towards one spherical light
//! (`lights.rs`) and sends a shadow ray; the shadow rays of a whole wavefront march together
//! after shading. A shadow ray sees the light when the first surface it meets is that light
//! (on a whole-tape frame, or a frame of exact pieces, from outside the light's ball: when it
//! gets to the ball on the scene without the light, `march_shadows`); it is attenuated by
//! `exp(-sigma_t t)` in the path's current (homogeneous) medium. Any other first surface, a
//! glass or fog boundary included, occludes it: light through those is left to BSDF
//! sampling, which reaches it with weight 1 (see below).
//!
//! The two strategies are combined by multiple importance sampling with the **power heuristic**
//! (exponent 2) on solid-angle pdfs: the light sample is weighted by
//! `p_light^2 / (p_light^2 + p_bsdf^2)`, and a BSDF-sampled ray that hits a spherical light by
//! `p_bsdf^2 / (p_bsdf^2 + p_light^2)`, with `p_light` evaluated from the vertex the ray left.
//! The weights sum to 1 for every path that both strategies can produce. For paths only one of
//! them can produce the other's pdf is 0 and the weight 1: camera rays and rays leaving delta
//! lobes (mirror, glass, roughness 0) carry no BSDF pdf (`Path::mis_pdf = 0`), and so does a ray
//! that crossed a fog or air boundary since its last vertex (a shadow ray would have been
//! stopped there); a vertex inside a light has no light sample and `p_light = 0`. Light sampling
//! draws its random numbers from the path's own stream, so images stay independent of the
//! thread count; with it off no extra numbers are drawn and the estimator is plain BSDF sampling.

use super::bsdf::{Bsdf, BsdfSample, Dielectric, Ggx, Mirror};
use super::frame::{FrameObject, FrameScene, Shot};
use super::lights::{LightSample, Lights, Side};
use super::march::{Field, Hit, Marcher, Ray};
use super::material::{Medium, Surface};
use super::phase::{HenyeyGreenstein, PhaseFunction};
use super::sampler::{Sampler, SamplerKind};
use super::sampling::Frame;
use crate::film::PixelSums;
use crate::ir::exact::Pieces;
use crate::math::lanes::{F4, each, gather, lane};
use crate::vm::cells::{Cell, Cells, hit_epsilon};
use crate::vm::{Dual, LANES, Regs, run};
use glam::{DVec3, DVec4};

mod diffuse;

/// The settings of the light transport.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// The scene's: image size, bounces, marching limits and the seed of every sample's random
    /// stream (with the frame, pixel and sample index, so a render is the same on any number
    /// of threads).
    pub shot: Shot,
    /// Russian roulette from this many bounces on (`u32::MAX`: never).
    pub roulette_from: u32,
    /// Next-event estimation towards spherical lights, combined with BSDF sampling by MIS.
    pub light_sampling: bool,
    /// Where the random numbers come from.
    pub sampler: SamplerKind,
}

/// Counts for the summary.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Stats {
    /// Camera samples taken (pixels times samples per pixel).
    pub samples: u64,
    /// Distance evaluations while marching.
    pub evaluations: u64,
    /// Tape instructions those evaluations ran.
    #[serde(default)]
    pub instructions: u64,
    /// Ray segments that ran out of marching steps (their paths end there).
    pub out_of_steps: u64,
    /// Samples whose radiance came out NaN or infinite, dropped from the image.
    pub dropped: u64,
    /// Shadow rays traced for next-event estimation.
    pub shadow_rays: u64,
}

impl Stats {
    /// Add the marcher's work since its counts were `before` (evaluations, instructions).
    fn count_work(&mut self, marcher: &Marcher, before: (u64, u64)) {
        self.evaluations += marcher.evaluations - before.0;
        self.instructions += marcher.instructions - before.1;
    }
}

impl std::ops::AddAssign for Stats {
    fn add_assign(&mut self, o: Stats) {
        self.samples += o.samples;
        self.evaluations += o.evaluations;
        self.instructions += o.instructions;
        self.out_of_steps += o.out_of_steps;
        self.dropped += o.dropped;
        self.shadow_rays += o.shadow_rays;
    }
}

/// A rectangle of pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tile {
    /// Left column, in pixels from the left edge.
    pub x: u32,
    /// Top row, in pixels from the top edge.
    pub y: u32,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

/// Nested media a path is inside, innermost last.
const MAX_NESTING: usize = 4;
/// Null-surface crossings (fog and air boundaries) a path may make; they are not bounces.
const MAX_CROSSINGS: u32 = 256;
/// Paths in flight per batch: enough to fill the tapes' lanes cell by cell, few enough that
/// their state (some 500 bytes a path, 200 more in the marcher) stays in the core's caches.
/// Against 4,096, this took 6% off the room's render and 11% off the glass box's, and 4-16%
/// off every default render of the marcher corpus.
const BATCH: usize = 1024;

#[derive(Clone, Copy, Debug)]
/// The media a path is inside, innermost last (at most a few deep): which medium it travels
/// through, and what it enters or leaves at a boundary.
pub struct Stack {
    entries: [(u32, Medium); MAX_NESTING],
    len: usize,
}

impl Stack {
    const EMPTY: Stack = Stack {
        entries: [(0, Medium::VACUUM); MAX_NESTING],
        len: 0,
    };

    /// Whether the path is in no object's medium.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    fn medium(&self, outside: Medium) -> Medium {
        if self.len == 0 {
            outside
        } else {
            self.entries[self.len - 1].1
        }
    }

    /// Enter `object`; past the nesting limit the path keeps its current medium.
    fn push(&mut self, object: u32, m: Medium) {
        if self.len < MAX_NESTING {
            self.entries[self.len] = (object, m);
            self.len += 1;
        }
    }

    /// Whether the path is inside `object`; `None` when the stack is full without it, as it
    /// then cannot tell (the path may have entered it past the nesting limit).
    fn contains(&self, object: u32) -> Option<bool> {
        let found = self.entries[..self.len].iter().any(|e| e.0 == object);
        (found || self.len < MAX_NESTING).then_some(found)
    }

    /// Leave `object`, wherever it is on the stack.
    fn remove(&mut self, object: u32) {
        if let Some(i) = self.entries[..self.len].iter().rposition(|e| e.0 == object) {
            self.entries.copy_within(i + 1..self.len, i);
            self.len -= 1;
        }
    }
}

#[derive(Clone, Debug)]
struct Path {
    /// Index of the pixel within the tile.
    pixel: u32,
    sampler: Sampler,
    beta: DVec3,
    /// Product of `(eta_light_side / eta_camera_side)^3` over transmissions: `beta * eta_scale`
    /// is the throughput without radiance scaling, which is what Russian roulette should see.
    eta_scale: f64,
    radiance: DVec3,
    o: DVec4,
    d: DVec4,
    bounces: u32,
    crossings: u32,
    stack: Stack,
    /// The current segment ends at a sampled free-flight distance.
    flight: bool,
    /// Still on the camera ray (no surface recorded in the first-hit buffers yet).
    primary: bool,
    /// The solid-angle pdf with which the current segment's direction was drawn at its vertex,
    /// when a light sample was also taken there (for the MIS weight of a light this segment
    /// hits); 0 when the segment's light hits take weight 1.
    mis_pdf: f64,
    /// The vertex that light sample was drawn from: the surface point itself (the segment
    /// starts a little off it), or the scattering point in a medium.
    mis_from: DVec4,
}

impl Path {
    fn u3(&mut self) -> DVec3 {
        self.sampler.get3()
    }
}

/// One surface hit waiting for its normal and material.
#[derive(Clone, Copy)]
struct Pending<'c> {
    path: u32,
    p: DVec4,
    t: f64,
    object: u32,
    /// The cell of the hit, whose pruned tape of the object gives its normal (none for the
    /// plain marcher: the whole object tape does).
    cell: Option<&'c Cell>,
}

/// A light sample waiting for its shadow ray: what it adds to path `path` if the ray's first
/// hit is light `light` of the frame's `Lights` (whose ball the ray enters `enter` along it),
/// before attenuation by `exp(-sigma_t t)`.
#[derive(Debug, PartialEq)]
struct Shadow {
    path: u32,
    light: u32,
    enter: f64,
    sigma_t: f64,
    contribution: DVec3,
}

/// The shadow rays of one wavefront.
#[derive(Default)]
struct Shadows {
    pending: Vec<Shadow>,
    rays: Vec<Ray>,
    /// The rays of one tape (`march_shadows`): what they march (0: the frame's field, `k +
    /// 1`: light `k`'s unlit tape or its cull's pieces), and their index in `pending`; then
    /// the batch of them and their hits.
    queue: Vec<(u32, u32)>,
    batch: Vec<Ray>,
    hits: Vec<Hit>,
}

/// Per-thread scratch space, reused across tiles.
#[derive(Default)]
pub struct Scratch {
    marcher: Marcher,
    shadows: Shadows,
    paths: Vec<Path>,
    rays: Vec<Ray>,
    hits: Vec<Hit>,
    outputs: Vec<f32>,
    surfaces: Vec<Surface>,
    normals: Vec<DVec4>,
    grad: Option<Regs<Dual, LANES>>,
    regs: Option<Regs<f32, LANES>>,
}

/// Take samples `samples` of every pixel of `tile` in frame `frame` whose entry in `active`
/// (row-major within the tile) is true, adding them to `sums`.
#[allow(clippy::too_many_arguments)]
pub fn render_tile(
    fs: &FrameScene,
    s: &Settings,
    frame: u32,
    tile: Tile,
    samples: std::ops::Range<u32>,
    active: &[bool],
    initial: Stack,
    scratch: &mut Scratch,
    stats: &mut Stats,
    sums: &mut [PixelSums],
) {
    let pixels = (tile.width * tile.height) as usize;
    let busy = active.iter().filter(|a| **a).count();
    let per_batch = (BATCH / busy.max(1)).max(1) as u32;
    let mut first = samples.start;
    while first < samples.end {
        let last = (first + per_batch).min(samples.end);
        scratch.paths.clear();
        for k in (0..pixels as u32).filter(|&k| active[k as usize]) {
            let (px, py) = (tile.x + k % tile.width, tile.y + k / tile.width);
            let global = py as u64 * s.shot.width as u64 + px as u64;
            for sample in first..last {
                let mut sampler = Sampler::new(s.sampler, s.shot.seed, frame, global, sample);
                let (jx, jy) = (sampler.get(), sampler.get());
                let d = (fs.camera).direction(
                    px as f64 + jx,
                    py as f64 + jy,
                    s.shot.width,
                    s.shot.height,
                );
                scratch.paths.push(Path {
                    pixel: k,
                    sampler,
                    beta: DVec3::ONE,
                    eta_scale: 1.0,
                    radiance: DVec3::ZERO,
                    o: fs.camera.position,
                    d,
                    bounces: 0,
                    crossings: 0,
                    stack: initial,
                    flight: false,
                    primary: true,
                    mis_pdf: 0.0,
                    mis_from: DVec4::ZERO,
                });
            }
        }
        trace(fs, s, scratch, sums, stats);
        first = last;
    }
}

impl Stack {
    /// The media around the camera: every enterable object whose inside contains it.
    pub fn at_camera(fs: &FrameScene, eps: f64) -> Stack {
        let mut stack = Stack::EMPTY;
        if !fs.features.interiors {
            return stack;
        }
        let p = fs.camera.position;
        for (i, o) in fs.objects.iter().enumerate() {
            if !o.layout.has_interior() || !fs.contains(i, p, eps) {
                continue;
            }
            match o.surface_at(p, DVec4::W, fs.t) {
                Surface::Glass { inside, .. } | Surface::Boundary { inside } => {
                    stack.push(i as u32, inside)
                }
                _ => {}
            }
        }
        stack
    }
}

/// Advance every path in `scratch.paths` until all have ended, adding each to its pixel.
fn trace(
    fs: &FrameScene,
    s: &Settings,
    scratch: &mut Scratch,
    sums: &mut [PixelSums],
    stats: &mut Stats,
) {
    let Scratch {
        marcher,
        shadows,
        paths,
        rays,
        hits,
        outputs,
        surfaces,
        normals,
        grad,
        regs,
    } = scratch;
    let grad = grad.get_or_insert_with(|| Regs { r: vec![] });
    let regs = regs.get_or_insert_with(|| Regs { r: vec![] });
    let interior = fs.interior.as_ref().filter(|_| fs.features.interiors);
    let nee = Nee {
        lights: (s.light_sampling && !fs.lights.is_empty()).then_some(&fs.lights),
        interior: interior.is_some(),
    };
    // Hits hold references into this frame's cells, so they live here, not in `scratch`.
    let (mut pending, mut spare): (Vec<Pending>, Vec<Pending>) = (Vec::new(), Vec::new());
    let diffuse = &mut Vec::new();
    // Hits are found in their cells from the last hit's cell (`Cells::locate`).
    let mut near = fs.cells.as_ref().map(Cells::path);
    while !paths.is_empty() {
        rays.clear();
        for path in paths.iter_mut() {
            let m = path.stack.medium(fs.medium);
            let mut tmax = f64::INFINITY;
            path.flight = false;
            path.sampler.start_segment(path.bounces);
            if !m.is_vacuum() {
                let u = path.sampler.get();
                let d = -(1.0 - u).ln() / m.sigma_t;
                if d < tmax {
                    (tmax, path.flight) = (d, true);
                }
            }
            rays.push(Ray {
                o: path.o,
                d: path.d,
                tmax,
                interior: path.stack.len > 0 && interior.is_some(),
            });
        }
        let before = (marcher.evaluations, marcher.instructions);
        marcher.march(fs.field(), rays, s.shot.limits, hits);
        stats.count_work(marcher, before);

        // Resolve everything but surface hits; collect those.
        pending.clear();
        diffuse.clear();
        shadows.pending.clear();
        shadows.rays.clear();
        let mut alive = vec![true; paths.len()];
        for (i, path) in paths.iter_mut().enumerate() {
            match hits[i] {
                Hit::OutOfSteps => {
                    stats.out_of_steps += 1;
                    alive[i] = false;
                }
                Hit::Beyond if path.flight => {
                    alive[i] =
                        scatter_in_medium(path, i as u32, rays[i].tmax, fs, s, &nee, shadows);
                }
                Hit::Beyond => {
                    path.radiance += path.beta * fs.sky;
                    alive[i] = false;
                }
                Hit::Surface { t, object } => {
                    let p = path.o + path.d * t;
                    pending.push(Pending {
                        path: i as u32,
                        p,
                        t,
                        object: object as u32,
                        cell: (fs.cells.as_ref().zip(near.as_mut()))
                            .map(|(c, near)| c.locate(near, p)),
                    })
                }
            }
        }

        // Normals and materials, a packet of one object's hits at a time; where every ray
        // meets the scene's exact pieces, normals from those.
        let field = fs.field();
        let pieces = field.pieces(false);
        // By cell too, for the normals; in the same order in every run, since shading adds to
        // the pixels' sums in this order.
        match fs.cells {
            Some(_) => pending.sort_by_key(|h| (h.object, h.cell.map(Cell::id))),
            None => by_object(&mut pending, &mut spare, fs.objects.len()),
        }
        for group in pending.chunk_by(|a, b| a.object == b.object) {
            let object = &fs.objects[group[0].object as usize];
            for chunk in group.chunks(LANES) {
                normals_of(chunk, object, pieces, grad, normals);
                surfaces.clear();
                match object.uniform {
                    Some(surface) => surfaces.resize(chunk.len(), surface),
                    None => {
                        regs.fit(&object.material);
                        regs.set_time(fs.t as f32);
                        for (lane, (h, n)) in chunk.iter().zip(normals.iter()).enumerate() {
                            let (p, n) = (h.p.as_vec4().to_array(), n.as_vec4().to_array());
                            regs.set_point(lane, p, n);
                        }
                        run(&object.material, regs);
                        surfaces.extend((0..chunk.len()).map(|lane| {
                            outputs.clear();
                            let out = object.material.outputs.iter().map(|&o| regs.get(o)[lane]);
                            outputs.extend(out);
                            object.layout.surface(outputs)
                        }));
                    }
                }
                for ((h, &n), &surface) in chunk.iter().zip(normals.iter()).zip(surfaces.iter()) {
                    let path = &mut paths[h.path as usize];
                    let pixel = &mut sums[path.pixel as usize];
                    let queues = (&mut *shadows, &mut *diffuse);
                    alive[h.path as usize] = shade(path, h, n, surface, fs, s, &nee, queues, pixel);
                }
            }
        }
        diffuse::scatter(diffuse, (paths, &mut alive), fs, s, &nee, shadows);

        // Shadow rays of the light samples taken above, all at once.
        if !shadows.pending.is_empty() {
            march_shadows(fs, s, marcher, shadows, paths, stats);
        }

        // Retire finished paths into their pixels.
        let mut k = 0;
        paths.retain(|path| {
            let keep = alive[k];
            k += 1;
            if !keep {
                let l = path.radiance;
                stats.samples += 1;
                if l.is_finite() {
                    sums[path.pixel as usize].add_radiance(l);
                } else {
                    stats.dropped += 1;
                    sums[path.pixel as usize].add_radiance(DVec3::ZERO);
                }
            }
            keep
        });
    }
}

/// `hits` (none of them in a cell) in order of object, each object's in the order they came,
/// as a stable sort leaves them, by counting: the sort was 1.5% of the room's render.
fn by_object<'c>(hits: &mut Vec<Pending<'c>>, spare: &mut Vec<Pending<'c>>, objects: usize) {
    let Some(&first) = hits.first() else {
        return;
    };
    let mut next = vec![0; objects];
    for h in hits.iter() {
        next[h.object as usize] += 1;
    }
    let mut start = 0;
    for n in &mut next {
        (*n, start) = (start, start + *n);
    }
    spare.clear();
    spare.resize(hits.len(), first);
    for h in hits.iter() {
        let at = &mut next[h.object as usize];
        spare[*at] = *h;
        *at += 1;
    }
    std::mem::swap(hits, spare);
}

/// Unit outward normals at the hits, by forward-mode gradients of each hit's object's distance
/// as pruned to the hit's cell (in its local coordinates, so far from the origin they keep
/// their precision; one packet per cell), or, in a frame met as a few exact pieces
/// (`pieces`), in `f64` from the object's piece that is least at the hit (the one its
/// distance is, as a min of them); where the gradient vanishes or is not finite, the normal
/// faces back along the ray.
fn normals_of(
    hits: &[Pending],
    object: &FrameObject,
    pieces: Option<&Pieces>,
    grad: &mut Regs<Dual, LANES>,
    out: &mut Vec<DVec4>,
) {
    let mut g = Vec::with_capacity(hits.len());
    // (The hits are all on one object; one the scene's pieces leave out, air, has its tape.)
    let pieces = pieces.filter(|p| (hits.first()).is_some_and(|h| p.of(h.object as usize)));
    if let Some(pieces) = pieces {
        let object = f64::from(hits[0].object);
        let mut of = pieces.iter().filter(|piece| piece.object == object);
        match (of.next(), of.next()) {
            // An object of one piece (most are): four hits at a time, in the lanes of a vector.
            (Some(piece), None) => {
                for four in hits.chunks(4) {
                    let p = gather(each(|l| four[l.min(four.len() - 1)].p.to_array()));
                    let n = crate::simd::wide!(piece.form.gradient::<F4>(p));
                    let n = |l| n.map_or(DVec4::ZERO, |n| DVec4::from_array(lane(n, l)));
                    g.extend((0..four.len()).map(n));
                }
            }
            _ => g.extend(hits.iter().map(|h| piece_gradient(pieces, h.object, h.p))),
        }
    } else {
        let same = |a: Option<&Cell>, b: Option<&Cell>| match (a, b) {
            (Some(a), Some(b)) => std::ptr::eq(a, b),
            (a, b) => a.is_none() && b.is_none(),
        };
        for run in hits.chunk_by(|a, b| same(a.cell, b.cell)) {
            let (tape, origin) = match run[0].cell {
                Some(cell) => (&cell.objects()[run[0].object as usize], cell.origin),
                None => (&object.distance, DVec4::ZERO),
            };
            let points: Vec<[f32; 4]> = (run.iter())
                .map(|h| (h.p - origin).as_vec4().to_array())
                .collect();
            let duals = crate::vm::gradient(tape, grad, &points, 0.0);
            g.extend(
                duals
                    .iter()
                    .map(|d| DVec4::from_array(d.g.map(|x| x as f64))),
            );
        }
    }
    out.clear();
    out.extend(g.iter().map(|&n| {
        let len = n.length();
        if len.is_finite() && len > 1e-12 {
            n / len
        } else {
            DVec4::ZERO
        }
    }));
}

/// The gradient at `p` of object `object`'s distance, the least of its `pieces` there (an
/// object of several: `normals_of` takes those of one piece four at a time).
fn piece_gradient(pieces: &Pieces, object: u32, p: DVec4) -> DVec4 {
    let p = p.to_array();
    let mut of = pieces
        .iter()
        .filter(|piece| piece.object == f64::from(object));
    let Some(mut at) = of.next() else {
        return DVec4::ZERO;
    };
    let mut least = at.form.value(p);
    for piece in of {
        let v = piece.form.value(p);
        if v < least || (least.is_nan() && !v.is_nan()) {
            (at, least) = (piece, v);
        }
    }
    at.form.gradient(p).map_or(DVec4::ZERO, DVec4::from_array)
}

/// Offset from a surface point along `side` (a unit normal), past the marching epsilon at the
/// point (`eps`, see `Cell::epsilon`), so the next segment does not hit the same surface at once.
fn leave(p: DVec4, side: DVec4, eps: f64) -> DVec4 {
    p + side * (4.0 * eps)
}

/// Russian roulette and the bounce count after a scattering event (`delta`: by a delta lobe);
/// false ends the path. As in pbrt, a path survives with probability equal to its throughput
/// (without radiance scaling) when that is below 1, so weights never grow past 1 and add no
/// heavy tail. Only after a non-delta event, though: a delta chain (mirrors, glass) is
/// deterministic, so every path through it carries the same weight, and roulette there would
/// turn that smooth estimate into survivors and zeros; the bounce limit still ends it.
fn survive(path: &mut Path, s: &Settings, delta: bool) -> bool {
    path.bounces += 1;
    let q = (path.beta * path.eta_scale).max_element();
    if !delta && path.bounces >= s.roulette_from && q < 1.0 {
        if q <= 0.0 || path.sampler.get() >= q {
            return false;
        }
        path.beta /= q;
    }
    path.beta.max_element() > 0.0
}

/// What next-event estimation needs to know about the frame.
struct Nee<'a> {
    /// The lights to sample; `None` when light sampling is off or there are none.
    lights: Option<&'a Lights>,
    /// Rays inside objects march on the interior tape.
    interior: bool,
}

impl<'a> Nee<'a> {
    /// Take one light sample at `x`, the vertex path `index` is at (after its scattering
    /// albedo is in `beta`), and queue its shadow ray, which leaves from `origin` (`x` lifted
    /// off its surface, as the path's own next segment is). `lobe(wo)` gives the scattering
    /// function times `|cos|` (the phase function in a medium) towards the world direction
    /// `wo`, and the pdf with which the path would draw `wo` itself. Returns whether a light
    /// sample was taken, i.e. whether this vertex's BSDF rays must be MIS-weighted (the caller
    /// then sets `mis_pdf`; `mis_from` is set here).
    #[allow(clippy::too_many_arguments)]
    fn sample(
        &self,
        path: &mut Path,
        index: u32,
        x: DVec4,
        origin: DVec4,
        medium: Medium,
        lobe: impl Fn(DVec4) -> (DVec3, f64),
        shadows: &mut Shadows,
    ) -> bool {
        let Some((lights, select, u)) = self.draw(path, x) else {
            return false;
        };
        let ls = lights.sample(x, select, u);
        self.queue(lights, path, index, ls, origin, medium, lobe, shadows);
        true
    }

    /// The numbers of a light sample at the vertex `x` of `path`, from its own stream (which
    /// light, and where on it), where there are lights to sample.
    fn draw(&self, path: &mut Path, x: DVec4) -> Option<(&'a Lights, f64, DVec3)> {
        let lights = self.lights?;
        let (select, u) = (path.sampler.get(), path.u3());
        path.mis_from = x;
        Some((lights, select, u))
    }

    /// The rest of `sample` once the light sample `ls` is drawn (none: nothing to send):
    /// queue its shadow ray where it can add anything.
    #[allow(clippy::too_many_arguments)]
    fn queue(
        &self,
        lights: &Lights,
        path: &Path,
        index: u32,
        ls: Option<LightSample>,
        origin: DVec4,
        medium: Medium,
        lobe: impl Fn(DVec4) -> (DVec3, f64),
        shadows: &mut Shadows,
    ) {
        let Some(ls) = ls else {
            return;
        };
        // The shadow ray meets a surface first where it must leave an object the light lies
        // wholly outside, or enter one it lies wholly inside: it is occluded, unmarched.
        let stack = &path.stack;
        let inside = &stack.entries[..stack.len];
        if inside
            .iter()
            .any(|e| lights.side(ls.light, e.0) == Side::Outside)
            || (lights.enclosing(ls.light).iter()).any(|&o| stack.contains(o) == Some(false))
        {
            return;
        }
        let (f, pdf_bsdf) = lobe(ls.wo);
        // Nothing towards the light (below the surface, or a NaN from a degenerate lobe).
        if f.max_element().is_nan() || f.max_element() <= 0.0 {
            return;
        }
        // Power heuristic: L f / p_light * p_light^2 / (p_light^2 + p_bsdf^2), written so
        // that a tiny cone's huge pdf cannot overflow.
        let ratio = pdf_bsdf / ls.pdf;
        let light = &lights.lights()[ls.light];
        let contribution = path.beta * f * light.radiance / (ls.pdf * (1.0 + ratio * ratio));
        if !contribution.is_finite() || contribution.max_element() <= 0.0 {
            return;
        }
        // The ray from `origin`, a little off `x`, may just miss the ball: it sees nothing.
        let Some(enter) = light.enter(origin, ls.wo) else {
            return;
        };
        shadows.pending.push(Shadow {
            path: index,
            light: ls.light as u32,
            enter,
            sigma_t: medium.sigma_t.max(0.0),
            contribution,
        });
        shadows.rays.push(Ray {
            o: origin,
            d: ls.wo,
            // Past the centre by the radius: a ray from `origin` that meets the ball at all
            // meets it before that, though `origin` is a little nearer than `x`.
            tmax: ls.distance + light.radius,
            interior: path.stack.len > 0 && self.interior,
        });
    }

    /// The MIS weight of emission `path` reaches on a BSDF-sampled segment at `object`.
    fn weight(&self, path: &Path, object: u32) -> Option<f64> {
        let lights = self.lights?;
        if path.mis_pdf <= 0.0 {
            return None;
        }
        let light = lights.of_object(object)?;
        let ratio = lights.pdf(light, path.mis_from, path.d) / path.mis_pdf;
        Some(1.0 / (1.0 + ratio * ratio))
    }
}

/// March the wavefront's shadow rays and add what their lights give the paths. Where the
/// frame marches its whole tape, a ray from outside objects marches its light's unlit tape
/// (`FrameScene::unlit`) only as far as the light's ball, and sees the light if nothing is
/// in the way: the steps that close in on the light's own surface, shorter and shorter where
/// the ray meets it at a slant, were half of a lit room's steps. Where every ray meets the
/// scene's exact pieces, a ray from where its light's cull holds (`ShadowCull`) meets fewer of
/// them, and not the light's own ball: it too goes as far as the ball, whose entry is known in
/// closed form. Elsewhere, and from inside the ball on any frame, it marches the frame's field
/// as far as past the light, and sees it if the light is the first surface it meets.
fn march_shadows(
    fs: &FrameScene,
    s: &Settings,
    marcher: &mut Marcher,
    shadows: &mut Shadows,
    paths: &mut [Path],
    stats: &mut Stats,
) {
    let Shadows {
        pending,
        rays,
        queue,
        batch,
        hits,
    } = shadows;
    let eps = s.shot.limits.epsilon;
    let cull = |light: usize| fs.shadow_culls.get(light);
    queue.clear();
    queue.extend(
        (pending.iter().zip(rays.iter()).enumerate()).map(|(i, (sh, r))| {
            let light = sh.light as usize;
            // From inside the ball (`enter` 0) the whole meeting decides what the ray sees.
            let own = !r.interior
                && sh.enter > 0.0
                && (light < fs.unlit.len() || cull(light).is_some_and(|c| c.holds(r.o, eps)));
            (if own { sh.light + 1 } else { 0 }, i as u32)
        }),
    );
    queue.sort_unstable();
    stats.shadow_rays += rays.len() as u64;
    for group in queue.chunk_by(|a, b| a.0 == b.0) {
        let light = group[0].0.checked_sub(1).map(|k| k as usize);
        let unlit = light.and_then(|k| fs.unlit.get(k));
        let field = unlit.map_or(fs.field(), |tape| Field {
            scene: tape,
            ..fs.field()
        });
        batch.clear();
        batch.extend(group.iter().map(|&(_, i)| {
            let (sh, r) = (&pending[i as usize], rays[i as usize]);
            let tmax = if light.is_some() { sh.enter } else { r.tmax };
            Ray { tmax, ..r }
        }));
        let before = (marcher.evaluations, marcher.instructions);
        match light.and_then(cull).filter(|_| unlit.is_none()) {
            Some(cull) => marcher.meet(|_| &cull.pieces, batch, s.shot.limits, hits),
            None => marcher.march(field, batch, s.shot.limits, hits),
        }
        stats.count_work(marcher, before);
        for (&(_, i), &hit) in group.iter().zip(hits.iter()) {
            let sh = &pending[i as usize];
            let object = fs.lights.lights()[sh.light as usize].object as usize;
            let Some(t) = sees(hit, object, light.map(|_| sh.enter)) else {
                continue;
            };
            let transmittance = if sh.sigma_t > 0.0 {
                (-sh.sigma_t * t).exp()
            } else {
                1.0
            };
            paths[sh.path as usize].radiance += sh.contribution * transmittance;
        }
    }
}

/// Where a shadow ray that ended in `hit` sees the light, object `light`: where it meets it
/// first, or, marched on the light's unlit tape or met on its cull's pieces up to where it
/// enters its ball (`enter`), there if nothing was in the way (an `f64` settling near the ball
/// may still name the light).
fn sees(hit: Hit, light: usize, enter: Option<f64>) -> Option<f64> {
    match (hit, enter) {
        (Hit::Surface { t, object }, _) if object == light => Some(t),
        (Hit::Beyond, Some(enter)) => Some(enter),
        _ => None,
    }
}

/// A real scattering event in the current medium, `t` along the segment.
fn scatter_in_medium(
    path: &mut Path,
    index: u32,
    t: f64,
    fs: &FrameScene,
    s: &Settings,
    nee: &Nee,
    shadows: &mut Shadows,
) -> bool {
    if path.bounces >= s.shot.bounces {
        return false;
    }
    let m = path.stack.medium(fs.medium);
    path.o += path.d * t;
    path.beta *= m.albedo;
    let u = path.u3();
    let phase = HenyeyGreenstein::new(m.g);
    let wi = -path.d;
    let lobe = |wo| {
        let p = phase.eval(wi, wo);
        (DVec3::splat(p), phase.pdf(wi, wo))
    };
    let sampled = nee.sample(path, index, path.o, path.o, m, lobe, shadows);
    let sample = phase.sample(wi, u);
    path.d = sample.wo;
    path.mis_pdf = if sampled { sample.pdf } else { 0.0 };
    path.primary = false;
    survive(path, s, false)
}

/// Shade one surface hit; false ends the path. A diffuse vertex is left in `diffuse` for
/// `diffuse::scatter`, which decides whether its path goes on.
#[allow(clippy::too_many_arguments)]
fn shade(
    path: &mut Path,
    h: &Pending,
    n: DVec4,
    surface: Surface,
    fs: &FrameScene,
    s: &Settings,
    nee: &Nee,
    (shadows, diffuse): (&mut Shadows, &mut Vec<diffuse::Vertex>),
    pixel: &mut PixelSums,
) -> bool {
    // The hit's precision (on the interior tape, for a ray inside an object).
    let interior = path.stack.len > 0 && fs.interior.is_some() && fs.features.interiors;
    let eps = hit_epsilon(h.cell, h.p, s.shot.limits.epsilon, interior);
    let n = if n == DVec4::ZERO { -path.d } else { n };
    let entering = path.d.dot(n) < 0.0;
    if matches!(surface, Surface::Boundary { .. } | Surface::Glass { .. }) {
        // The stack, not the normal, says which side of an enterable object the path is on. A
        // segment that starts within epsilon of a surface (a scattering point, or an offset
        // near an edge, where the gradient is another face's) hits it at once; if the ray is
        // moving away from it, that is no crossing, and taking it for one would enter the
        // object twice or leave it while inside. Step off the surface on the path's own side.
        let inside = path.stack.contains(h.object).unwrap_or(!entering);
        if inside == entering {
            path.o = leave(h.p, if inside { -n } else { n }, eps);
            // The shadow ray of the vertex this segment left met the same non-crossing and
            // stopped there, so light found through it is BSDF sampling's alone.
            path.mis_pdf = 0.0;
            path.crossings += 1;
            return path.crossings <= MAX_CROSSINGS;
        }
    }
    if let Surface::Boundary { inside } = surface {
        if entering {
            path.stack.push(h.object, inside);
        } else {
            path.stack.remove(h.object);
        }
        path.o = leave(h.p, if entering { -n } else { n }, eps);
        // A shadow ray would have stopped at this boundary: light reached through it is BSDF
        // sampling's alone.
        path.mis_pdf = 0.0;
        path.crossings += 1;
        return path.crossings <= MAX_CROSSINGS;
    }
    if path.primary {
        path.primary = false;
        pixel.albedo += surface.albedo();
        pixel.normal += n;
        pixel.position += h.p;
        pixel.depth += h.t;
    }
    match nee.weight(path, h.object) {
        Some(w) => path.radiance += path.beta * surface.emission() * w,
        None => path.radiance += path.beta * surface.emission(),
    }
    if path.bounces >= s.shot.bounces {
        return false;
    }
    let u = path.u3();
    let wi_world = -path.d;
    let delta = match surface {
        Surface::Light { .. } | Surface::Boundary { .. } => return false,
        Surface::Glass { ior, tint, inside } => {
            let frame = Frame::new(n);
            let wi = frame.to_local(wi_world);
            let Some(b) = (Dielectric { ior }).sample(wi, u) else {
                return false;
            };
            path.beta *= b.weight;
            let side = if b.wo.w >= 0.0 { n } else { -n };
            if b.wo.w * wi.w < 0.0 {
                path.beta *= tint;
                path.eta_scale /= b.weight.x;
                if wi.w > 0.0 {
                    path.stack.push(h.object, inside);
                } else {
                    path.stack.remove(h.object);
                }
            }
            path.d = frame.to_world(b.wo).normalize();
            path.o = leave(h.p, side, eps);
            path.mis_pdf = 0.0;
            Some(true)
        }
        Surface::Diffuse { albedo, .. } => {
            let (path, p) = (h.path, h.p);
            diffuse.push(diffuse::Vertex {
                path,
                p,
                n,
                eps,
                u,
                albedo,
            });
            return true;
        }
        Surface::Mirror { tint } => reflect(path, h.p, n, &Mirror { tint }, u, eps, None),
        Surface::Shiny { roughness, color } => {
            let ggx = Ggx::from_roughness(roughness, color);
            let light = (!ggx.is_mirror()).then_some((fs, nee, h.path, &mut *shadows));
            reflect(path, h.p, n, &ggx, u, eps, light)
        }
    };
    delta.is_some_and(|delta| survive(path, s, delta))
}

/// Light sampling at a surface vertex: the frame, the estimator and the path's index.
type LightSampling<'a, 'b> = Option<(&'a FrameScene, &'a Nee<'b>, u32, &'a mut Shadows)>;

/// Scatter off a one-sided reflector, its frame turned towards the side the path came from;
/// with `light`, take a light sample there first (the lobe must not be a delta). Returns
/// whether the sampled lobe is a delta, or `None` for a zero-weight sample (the path ends).
fn reflect<B: Bsdf>(
    path: &mut Path,
    p: DVec4,
    n: DVec4,
    bsdf: &B,
    u: DVec3,
    eps: f64,
    light: LightSampling,
) -> Option<bool> {
    let (n, o) = facing(path, p, n, eps);
    let frame = Frame::new(n);
    let wi = frame.to_local(-path.d);
    let mut sampled = false;
    if let Some((fs, nee, index, shadows)) = light {
        let m = path.stack.medium(fs.medium);
        let lobe = |wo_world| cosine_lobe(bsdf, wi, frame.to_local(wo_world));
        sampled = nee.sample(path, index, p, o, m, lobe, shadows);
    }
    let b = bsdf.sample(wi, u)?;
    let d = frame.to_world(b.wo).normalize();
    Some(scattered(path, b, d, o, sampled))
}

/// The scattering function times `|cos|` from `wi` towards `wo` (both local), and the pdf with
/// which `bsdf` draws `wo`: what a light sample towards `wo` needs of the surface.
fn cosine_lobe<B: Bsdf>(bsdf: &B, wi: DVec4, wo: DVec4) -> (DVec3, f64) {
    (bsdf.eval(wi, wo) * wo.w.abs(), bsdf.pdf(wi, wo))
}

/// The normal `n` at `p` turned towards the side the path comes from, and the point the path
/// leaves from on that side.
fn facing(path: &Path, p: DVec4, n: DVec4, eps: f64) -> (DVec4, DVec4) {
    let n = if path.d.dot(n) < 0.0 { n } else { -n };
    (n, leave(p, n, eps))
}

/// The path goes on from `o` along the BSDF's sample `b`, whose direction in the world is `d`;
/// `sampled`: a light sample was taken at the vertex. Returns whether the lobe is a delta.
fn scattered(path: &mut Path, b: BsdfSample, d: DVec4, o: DVec4, sampled: bool) -> bool {
    path.beta *= b.weight;
    (path.d, path.o) = (d, o);
    path.mis_pdf = if sampled && !b.delta { b.pdf } else { 0.0 };
    b.delta
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compile::Frames;
    use crate::render::frame::Build;
    use crate::render::march::MarcherKind;
    use rand::{Rng, SeedableRng};

    /// Counting hits into order of object leaves them as a stable sort by object does, so
    /// that shading adds to the pixels in the same order as before.
    #[test]
    fn hits_by_object_are_a_stable_sort() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(9);
        for (n, objects) in [(0, 3), (1, 1), (1000, 5), (300, 40)] {
            let hits: Vec<Pending> = (0..n)
                .map(|i| Pending {
                    path: i,
                    p: DVec4::ZERO,
                    t: 0.0,
                    object: rng.random_range(0..objects),
                    cell: None,
                })
                .collect();
            let mut want = hits.clone();
            want.sort_by_key(|h| h.object);
            let (mut got, mut spare) = (hits, vec![]);
            by_object(&mut got, &mut spare, objects as usize);
            let order = |v: &[Pending]| v.iter().map(|h| (h.object, h.path)).collect::<Vec<_>>();
            assert_eq!(order(&got), order(&want));
        }
    }

    /// An object of several pieces takes its normal from the piece that is least at the hit:
    /// on the surface of a union of three balls (one object, three pieces), the outward
    /// normal of the ball it is on, on every side of the seams. It fails with the first piece
    /// always taken, and with each piece held against the first one's value only.
    #[test]
    fn normals_come_from_the_least_piece() {
        let balls = [
            (DVec4::new(-0.8, 0.0, 0.0, 0.0), 1.0),
            (DVec4::new(0.8, 0.3, 0.0, 0.0), 0.7),
            (DVec4::new(0.2, -0.6, 0.3, 0.0), 0.6),
        ];
        let source = "render { size = 8 x 8  spp = 1 }
            camera { from = [0, 0, -6, 0]  to = [0, 0, 0, 0] }
            object o {
                shape = union(hypersphere(1) |> translate([-0.8, 0, 0, 0]),
                              hypersphere(0.7) |> translate([0.8, 0.3, 0, 0]),
                              hypersphere(0.6) |> translate([0.2, -0.6, 0.3, 0]))
                material = diffuse(rgb(0.5))
            }";
        let scene = crate::Compilation::from_source("t.4ds", source).scene;
        let scene = scene.expect("the test scene compiles");
        let fs = Frames::new(&scene).at(0.0, Build::marcher(MarcherKind::Auto));
        let pieces = fs.escape.pieces(false).expect("balls are exact pieces");
        assert_eq!(pieces.len(), 3);
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(3);
        let mut checked = [0; 3];
        for _ in 0..3000 {
            let u = DVec4::from_array(std::array::from_fn(|_| rng.random_range(-1.0..1.0)));
            let u = u.normalize();
            for (i, &(c, r)) in balls.iter().enumerate() {
                let p = c + u * r;
                let inside = |(o, s): &(DVec4, f64)| (p - *o).length() < s + 1e-6;
                if (balls.iter().enumerate()).any(|(j, b)| j != i && inside(b)) {
                    continue;
                }
                let n = piece_gradient(pieces, 0, p);
                assert!((n - u).length() < 1e-9, "ball {i} at {p}: {n} against {u}");
                checked[i] += 1;
            }
        }
        assert!(checked.iter().all(|&k| k > 500), "{checked:?}");
    }
}
