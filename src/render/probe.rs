//! Whether a frame's cells pay for themselves. The cells' marcher saves evaluations (pruned
//! tapes, exact planes and spheres, jumps over empty cells, relaxed steps) but pays on every
//! step for finding the ray's cell and grouping rays by cell; where the whole tape is short and
//! nothing prunes it (a tiling alone) that costs more than it saves. Before a frame renders,
//! a fixed probe of rays (camera rays through a grid of pixels, then two mirror bounces from
//! their hits) is marched through the cells and on the whole tape (both with relaxed steps), and
//! the frame keeps its cells only where their modelled cost is lower. The whole tape goes
//! first: where its march costs less than the cells would spend setting up the same rays, the
//! cells are not marched at all. Where the whole tape wins, it is marched with plain steps
//! too, and the frame takes them where they cost less. The model counts, not clocks (`Work::cost`), so the choice is the
//! same in every run, on every machine and whatever the thread count.

use super::camera::FrameCamera;
use super::frame::FrameObject;
use super::march::{Field, Hit, Limits, Marcher, Ray};
use crate::vm::cells::hit_epsilon;
use crate::vm::{Dual, LANES, Regs};
use glam::DVec4;

/// Most columns of the probe's grid of camera rays (its rows follow the image's aspect); an
/// eighth of the image's, down to `MIN_COLUMNS`, on small images, so that the probe costs
/// little beside them.
const COLUMNS: u32 = 24;
const MIN_COLUMNS: u32 = 16;
/// Mirror bounces followed from each camera ray's hit.
const BOUNCES: usize = 2;
/// The shares the whole-tape march of the probe is taken in.
const SHARES: usize = 8;
/// The probe's step limit (the render's, if lower): with a limit of a million, a crawling
/// ray in the probe would take a million steps of the whole tape before the frame starts.
const STEPS: u32 = 1000;

/// What marching the probe cost one marcher, in counts.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Work {
    /// Rays marched.
    pub rays: u64,
    /// Graph nodes bounded to prove that rays escape (`Escape::escapes`).
    pub bounded: u64,
    /// Graph nodes walked in `f64` where `f32` cannot decide a hit (`Escape::distance`).
    pub walked: u64,
    /// Steps (sphere steps, jumps across cells, steps back) per lane.
    pub steps: u64,
    /// Tape instructions run per lane.
    pub instructions: u64,
    /// Rays that took at least a quarter of the step limit, or ran out: crawling rays
    /// (grazing a surface) that a bigger image, with more such rays, loses to the limit.
    pub strained: u64,
    /// The work of building the cells the rays reached first, in graph nodes
    /// (`Cells::built`; 0 on the whole tape): in the probe's result, what the render would
    /// build per probe's worth of its rays (`Building::per_probe`).
    pub built: f64,
}

impl Work {
    /// Whether more than 1 in 256 of its rays crawled (`strained`): rays a render would lose
    /// to the step limit.
    fn crawls(&self) -> bool {
        self.strained > self.rays / 256
    }

    /// Marching time in nanoseconds, modelled from the counts with one marcher's weights.
    fn cost(&self, w: &Weights) -> f64 {
        w.ray * self.rays as f64
            + w.step * self.steps as f64
            + w.instruction * self.instructions as f64
            + w.bounded * self.bounded as f64
            + w.walked * self.walked as f64
            + w.built * self.built
    }
}

/// What each count costs a marcher, in nanoseconds on the 2-core development machine: a ray's
/// set-up, a step's bookkeeping (for the cells, finding the cell and grouping rays by cell), a
/// tape instruction per lane (the cells' groups are small, so their runs are narrow and dearer
/// per lane), a node bounded for an escape proof, a node walked in `f64` (`WALKED`). Fitted (non-negative least squares, relative
/// error) to both marchers timed alone on the probe rays of 50 scenes: the examples, sphere
/// unions, a custom field, a tiling, a turned slab and 40 generated scenes
/// (`docs/performance.md`, "Cells only where they pay"). Evaluations, fitted too, took no
/// weight of their own. Only the ratio of the two costs matters, so the machine's speed drops out.
/// A graph node walked in `f64` costs either marcher the same: 7 to 15 ns, timed over 200,000
/// walks of each of six generated scenes' graphs (13 to 105 nodes), 12 on most.
const WALKED: f64 = 12.0;

struct Weights {
    ray: f64,
    step: f64,
    instruction: f64,
    bounded: f64,
    walked: f64,
    built: f64,
}

/// A node of a new cell's graph (`Cells::built`, which counts `vm::cells::CELL_NODES` more
/// for each cell), with its share of the rest of building the cell (bounds, exact pieces,
/// tapes): fitted (least squares, relative error) to the time spent building cells in 16
/// renders, three of a union of 1,024 spheres and one of 256 (20 to 110 ns a node of
/// the cell and its parent's graph together, 1,500 to 4,500 cells) and 12 generated scenes
/// (2 to 57,000 cells, 250 to 600 ns), within 0.4 to 1.6 times of each. The parent's nodes,
/// which pruning reads, took no weight; counting them at 500 ns made building the sphere
/// union's cells look eight times dearer than it is, and a 1-spp render of it took the
/// whole tape, three times slower.
const BUILT: f64 = 500.0;

const CELLS: Weights = Weights {
    ray: 107.0,
    step: 39.0,
    instruction: 0.77,
    bounded: 19.0,
    walked: WALKED,
    built: BUILT,
};

const WHOLE: Weights = Weights {
    ray: 53.0,
    step: 14.0,
    instruction: 0.16,
    bounded: 21.0,
    walked: WALKED,
    built: 0.0,
};

/// The probe's outcome: what each marcher's march of it cost (as far as it went: the
/// whole-tape march stops once it costs more than the cells').
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Probe {
    /// What marching through the cells cost; `None` where they were not marched (the whole
    /// tape's march alone showing that they cannot pay) or given up (`Probe::through`).
    pub cells: Option<Work>,
    /// What marching the whole tape cost, as far as it went.
    pub whole: Work,
    /// What marching the whole tape with plain steps cost, where the whole tape won.
    pub plain: Option<Work>,
    /// What marching through the cells had cost when they were given up (`Probe::through`).
    pub abandoned: Option<Work>,
}

/// Where the probe looks: the frame's camera and objects, the image's size and samples per
/// pixel, the marching limits, and whether the camera is inside an object that can be entered
/// (its rays then march on the interior tape, as the render's do).
#[derive(Clone, Copy)]
pub struct Sight<'a> {
    pub camera: &'a FrameCamera,
    pub objects: &'a [FrameObject],
    pub size: (u32, u32),
    pub spp: u32,
    pub limits: Limits,
    pub inside: bool,
}

impl Sight<'_> {
    /// The probe's camera rays: a grid of pixels, an eighth of the image's columns (at least
    /// `MIN_COLUMNS`, at most `COLUMNS`), in an order that spreads every run of them over the
    /// image (a golden-ratio stride through the grid): the first few, by which a stage may
    /// give up, are not the top rows' sky, and each doubling of them doubles their density.
    fn rays(&self) -> Vec<Ray> {
        let (width, height) = self.size;
        let columns = (width / 8).clamp(MIN_COLUMNS, COLUMNS);
        let rows = (columns * height / width.max(1)).clamp(1, COLUMNS);
        let n = (columns * rows) as usize;
        let coprime = |k: &usize| (2..=*k).all(|f| !k.is_multiple_of(f) || !n.is_multiple_of(f));
        let stride = (n * 618 / 1000..).find(coprime).expect("n + 1 is coprime");
        (0..n)
            .map(|k| (k * stride % n) as u32)
            .map(|i| Ray {
                o: self.camera.position,
                d: self.camera.direction(
                    (i % columns) as f64 + 0.5,
                    (i / columns) as f64 + 0.5,
                    columns,
                    rows,
                ),
                tmax: f64::INFINITY,
                interior: self.inside,
            })
            .collect()
    }

    /// The render's limits, with the probe's step limit: rays the whole-tape march would lose
    /// crawl at most this long in the probe.
    fn limits(&self) -> Limits {
        Limits {
            max_steps: self.limits.max_steps.min(STEPS),
            ..self.limits
        }
    }
}

impl Probe {
    /// The probe's first stage, on the whole tape of `whole` (a frame's field without cells):
    /// the probe, where that alone shows that cells cannot pay (so they need not be built);
    /// else what the whole tape's march cost as far as it went, and the cells must be marched
    /// too (`Probe::through`).
    pub fn whole(whole: Field, sight: Sight) -> Result<Probe, Work> {
        let mut marcher = Marcher::default();
        let (work, all) = whole_alone(&mut marcher, whole, sight)?;
        Ok(Probe::on_whole(
            &mut marcher,
            whole,
            (work, &all),
            sight.limits(),
        ))
    }

    /// The probe where the cells are not marched: the whole tape's march (`work`, of the rays
    /// `all`), and plain steps where they may cost less.
    fn on_whole(
        marcher: &mut Marcher,
        whole: Field,
        (work, all): (Work, &[Ray]),
        limits: Limits,
    ) -> Probe {
        let mut probe = Probe {
            cells: None,
            whole: work,
            plain: None,
            abandoned: None,
        };
        probe.plain_steps(marcher, whole, all, limits);
        probe
    }

    /// The probe's second stage, where the first could not decide (its march of the whole tape
    /// cost `first` as far as it went): through the cells of `cells` (a frame's field with
    /// cells), then on the whole tape as far as that can win. After each quarter of rays from
    /// the second on, cells whose building alone would cost the render more than `WORSE`
    /// times the whole tape's march (at the first stage's cost per ray) are given up, and so
    /// are cells whose building in the probe has cost more than `BUDGET` of the frame's
    /// camera rays on the whole tape, checked after every `CHUNK` rays; the whole tape is
    /// then marched alone. Not where the first stage's rays crawled: the cells may be what
    /// keeps those rays within the step limit (`Choice::CellsForSteps`), whatever they cost.
    pub fn through(cells: Field, sight: Sight, first: Work) -> Probe {
        let whole = Field {
            cells: None,
            ..cells
        };
        let mut marcher = Marcher::default();
        let limits = sight.limits();
        // The camera rays a quarter at a time (each run of them spread over the image): what
        // the second quarter builds beside what the first did says how much the render's
        // denser rays share cells.
        let camera = sight.rays();
        let after = std::cell::RefCell::new(vec![]);
        let samples = sight.size.0 as f64 * sight.size.1 as f64 * sight.spp as f64;
        // The nodes built so far came from this many of the camera rays (and their bounces).
        let building = |camera_rays: u64| {
            let after = after.borrow();
            let quarter = |k: usize| after[k] - if k == 0 { 0.0 } else { after[k - 1] };
            let unshared =
                after.len() >= 4 && quarter(1) > 0.0 && quarter(3) >= UNSHARED * quarter(1);
            Building {
                first: after[0],
                second: match unshared {
                    true => after[0],
                    false => after.get(1).map_or(0.0, |b| b - after[0]),
                },
                rays: camera_rays as f64,
                samples,
            }
        };
        let per_ray = first.cost(&WHOLE) / first.rays.max(1) as f64;
        let crawled = first.crawls();
        let give_up = |work: &Work, part_done: bool| {
            if part_done {
                after.borrow_mut().push(work.built);
            }
            if crawled {
                return false;
            }
            // Checked on every piece: a ray of a far scene may build thousands of nodes.
            if work.built * CELLS.built > BUDGET * per_ray * samples {
                return true;
            }
            // The share `s` is known once the second quarter is marched.
            part_done && after.borrow().len() >= 2 && {
                let marched = work.rays.min(camera.len() as u64);
                let built = building(marched).per_probe(work.built) * CELLS.built;
                built > WORSE * per_ray * work.rays as f64
            }
        };
        let pace = Pace {
            part: camera.len().div_ceil(4),
            piece: CHUNK,
            grow: false,
        };
        let marched = generations(&mut marcher, cells, camera.clone(), sight, (pace, give_up));
        let (mut cells, all) = match marched {
            Ok(marched) => marched,
            Err(abandoned) => {
                let (work, all) = generations(&mut marcher, whole, camera, sight, NEVER)
                    .expect("a march that never gives up");
                let probe = Probe::on_whole(&mut marcher, whole, (work, &all), limits);
                return Probe {
                    abandoned: Some(abandoned),
                    ..probe
                };
            }
        };
        cells.built = building(camera.len() as u64).per_probe(cells.built);
        let mut probe = Probe {
            cells: Some(cells),
            whole: Work::default(),
            plain: None,
            abandoned: None,
        };
        probe.whole_after_cells(&mut marcher, whole, &all, limits);
        probe.plain_steps(&mut marcher, whole, &all, limits);
        probe
    }

    /// Relaxed steps lose where they overshoot more than they gain (a slab's planes met head
    /// on): where the whole tape wins, plain steps are measured too, as far as they can win.
    fn plain_steps(&mut self, marcher: &mut Marcher, whole: Field, all: &[Ray], limits: Limits) {
        if self.choice() == Choice::Whole {
            let plain = Field {
                relax: false,
                ..whole
            };
            let mut work = Work::default();
            in_shares(
                marcher,
                plain,
                all,
                limits,
                &mut work,
                self.whole.cost(&WHOLE),
            );
            self.plain = Some(work);
        }
    }

    /// The rays `all` the cells marched, on the whole tape, as far as that can win (the cells
    /// pay whatever the rest would cost, and a whole-tape march of a dense union is most of
    /// what the probe would spend).
    fn whole_after_cells(
        &mut self,
        marcher: &mut Marcher,
        whole: Field,
        all: &[Ray],
        limits: Limits,
    ) {
        let cells_cost = self.cells.map_or(0.0, |c| c.cost(&CELLS));
        in_shares(marcher, whole, all, limits, &mut self.whole, cells_cost);
    }

    /// Whether the frame should march through its cells: they cost less than marching the whole
    /// tape, or marching it would lose rays to the step limit that they do not.
    pub fn cells_pay(&self) -> bool {
        !matches!(self.choice(), Choice::Whole | Choice::PlainSteps)
    }

    /// The marcher the frame should use, and why.
    pub fn choice(&self) -> Choice {
        let Some(cells) = self.cells else {
            return self.steps();
        };
        if self.whole.strained > 2 * cells.strained + cells.rays / 256 {
            // Many more crawling rays than the cells have: the whole tape would lose a visible band of
            // them (a horizon over a floor). A few in a lattice's channels crawl either way.
            Choice::CellsForSteps
        } else if cells.cost(&CELLS) <= self.whole.cost(&WHOLE) {
            Choice::CellsForSpeed
        } else {
            self.steps()
        }
    }

    /// On the whole tape: relaxed steps, unless plain ones cost no more and crawl no more.
    /// Where the probe's rays meet nothing (small objects between its columns) the two cost
    /// the same, and the frame marches as plain does: a relaxed step's bookkeeping cost
    /// generated scenes of that kind 1 to 8% over plain.
    fn steps(&self) -> Choice {
        match self.plain {
            Some(p)
                if p.cost(&WHOLE) <= self.whole.cost(&WHOLE)
                    && p.strained <= self.whole.strained =>
            {
                Choice::PlainSteps
            }
            _ => Choice::Whole,
        }
    }
}

/// How much of the cells the probe built the render would build again, per probe's worth of
/// its rays: a probe of few rays builds cells a render of many shares (a dense union's), or
/// builds them for nearly every ray (where cells split to resolve the epsilon at every step of
/// a scene far larger than it), and building them was then all of the render (a generated
/// scene at scale 1e4: 47 s through the cells, 0.2 s on the whole tape).
struct Building {
    /// Nodes the first quarter of the camera rays built, then the second.
    first: f64,
    second: f64,
    /// The camera rays whose march (with their bounces) built what is extrapolated, and the
    /// frame's samples.
    rays: f64,
    samples: f64,
}

impl Building {
    /// The nodes the render would build per probe's worth of its rays, from the `total` the
    /// probe built: each doubling of the rays' density builds `1 + s` times as much as the
    /// last, `s` the share the second quarter of the camera rays built beside the first (1
    /// where no ray shares a cell, 0 where the first built every cell), up to the render's
    /// `samples / rays` times the probe's density.
    fn per_probe(&self, total: f64) -> f64 {
        let share = match self.first > 0.0 {
            true => (self.second / self.first).clamp(0.0, 1.0),
            false if self.second > 0.0 => 1.0,
            false => 0.0,
        };
        let denser = (self.samples / self.rays.max(1.0)).max(1.0);
        total * (1.0 + share).powf(denser.log2()) / denser
    }
}

/// Where the fourth quarter of the probe's camera rays built at least this share of what the
/// second did, denser rays share no more cells than sparser ones did: the render is taken to
/// build as much for every probe's worth of its rays as the probe did (no ray sharing a
/// cell). Small objects inside a shell of radius 1e6 (its whole tape resolving the epsilon
/// only in `f64`, its cells splitting around each ray) built 25,098, then 13,615, 13,124
/// and 12,991 nodes a quarter; extrapolated from the first two quarters, the model put
/// building at a sixth of the 75.7 million nodes the render built, kept the cells, and the
/// frame took 53 s where plain took 3.4 s (80 x 60, 4 spp). A union of 1,024 spheres built
/// 37,647, then 5,314, 3,829 and 2,977: its rays share more as they grow denser.
const UNSHARED: f64 = 0.9;

/// What the probe chose for a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Choice {
    /// Cells, because the whole tape takes many more probe rays near the step limit.
    CellsForSteps,
    /// Cells, because they cost less.
    CellsForSpeed,
    /// Relaxed marching on the whole tape, because it costs less.
    Whole,
    /// Plain steps on the whole tape, because they cost less than relaxed ones there.
    PlainSteps,
    /// No probe: every ray meets the scene's few exact pieces once (`Escape::pieces`).
    Exact,
}

impl Choice {
    /// How the bench names it.
    pub fn name(self) -> &'static str {
        match self {
            Choice::CellsForSteps => "cells (steps)",
            Choice::CellsForSpeed => "cells (speed)",
            Choice::Whole => "whole (speed)",
            Choice::PlainSteps => "whole, plain steps (speed)",
            Choice::Exact => "exact pieces",
        }
    }
}

/// The probe on the whole tape alone, from the camera rays, where it shows that the cells
/// cannot pay: their march costs at least their set-up of each ray (`CELLS.ray`), and the
/// whole tape's costs less in all (without many crawling rays, which would choose the cells
/// for steps). Building and marching the cells was up to 6% of a small frame's render
/// (0.6 ms of 9 for a generated scene at 96 x 72, 4 spp) where the whole tape then won. (The
/// cells' bounces follow their own hits, so their ray count may differ a little: the bound
/// is the model's, not exact.)
/// Marched `CHUNK` rays at a time, it gives up as soon as it costs more, with what it cost
/// so far.
fn whole_alone(
    marcher: &mut Marcher,
    whole: Field,
    sight: Sight,
) -> Result<(Work, Vec<Ray>), Work> {
    let give_up = |work: &Work, _| work.cost(&WHOLE) > work.rays as f64 * CELLS.ray;
    let pace = Pace {
        part: usize::MAX,
        piece: CHUNK,
        grow: true,
    };
    let (work, all) = generations(marcher, whole, sight.rays(), sight, (pace, give_up))?;
    match work.crawls() {
        false => Ok((work, all)),
        true => Err(work),
    }
}

/// March `all` on the whole tape of `field` an eighth of them at a time (each eighth spread
/// over the image), adding to `work`, and no more once that costs more than `beyond`: a
/// march that costs more than its rival's has lost whatever the rest would cost (costs only
/// grow), so the choice is the same as after marching all of them.
fn in_shares(
    marcher: &mut Marcher,
    field: Field,
    all: &[Ray],
    limits: Limits,
    work: &mut Work,
    beyond: f64,
) {
    let mut hits = vec![];
    for k in 0..SHARES {
        let share: Vec<Ray> = all.iter().skip(k).step_by(SHARES).copied().collect();
        march(marcher, field, &share, limits, &mut hits, work);
        if work.cost(&WHOLE) > beyond {
            break;
        }
    }
}

/// Cells whose building alone would cost the render this many times the whole tape's march
/// are not marched to the end of the probe (`Probe::through`): they cannot pay.
const WORSE: f64 = 2.0;

/// How much the probe may spend building cells, as a share of the march of the frame's camera
/// rays on the whole tape (modelled at the first stage's cost per probe ray, which counts its
/// bounces where it marched them): beyond it, the cells have already cost more than the whole
/// tape would, and a small frame of a scene whose cells keep splitting (a generated scene at
/// scale 1e4 whose plain render takes 0.04 s) is not held up by a probe that builds them for
/// longer than the render takes.
const BUDGET: f64 = 1.0;

/// How a march of the probe takes a generation's rays: in parts of `part` rays, each marched
/// `piece` rays at a time, its cost checked after each piece; where it may `grow`, each piece
/// of a part twice as many as the last (the tape runs `LANES` points at a time: pieces of 16
/// rays ran it a quarter full, and took twice as long as the same rays at once).
#[derive(Clone, Copy)]
struct Pace {
    part: usize,
    piece: usize,
    grow: bool,
}

/// A march of the probe that takes its rays all at once and never gives up.
const NEVER: (Pace, fn(&Work, bool) -> bool) = (
    Pace {
        part: usize::MAX,
        piece: usize::MAX,
        grow: false,
    },
    |_, _| false,
);

/// The probe's rays on `field`: the camera rays `rays`, then `BOUNCES` generations of mirror
/// bounces from their hits, marched at `pace`; what that cost and every ray marched, or what
/// it cost so far as soon as `give_up` says so of it (told after each piece whether it ended
/// a part).
fn generations(
    marcher: &mut Marcher,
    field: Field,
    mut rays: Vec<Ray>,
    sight: Sight,
    (pace, give_up): (Pace, impl Fn(&Work, bool) -> bool),
) -> Result<(Work, Vec<Ray>), Work> {
    let (mut work, mut hits, mut found, mut all) = (Work::default(), vec![], vec![], vec![]);
    let (limits, mut grad) = (sight.limits(), Regs { r: vec![] });
    for generation in 0..=BOUNCES {
        found.clear();
        for part in rays.chunks(pace.part) {
            let (mut from, mut size) = (0, pace.piece);
            while from < part.len() {
                let to = part.len().min(from.saturating_add(size));
                march(
                    marcher,
                    field,
                    &part[from..to],
                    limits,
                    &mut hits,
                    &mut work,
                );
                if give_up(&work, to == part.len()) {
                    return Err(work);
                }
                found.extend_from_slice(&hits);
                from = to;
                size = if pace.grow {
                    size.saturating_mul(2)
                } else {
                    size
                };
            }
        }
        all.extend_from_slice(&rays);
        if generation < BOUNCES {
            rays = bounce(&rays, &found, (sight.objects, field), &mut grad, limits);
        }
    }
    Ok((work, all))
}

/// Rays a march of the probe takes at a time before it checks its cost.
const CHUNK: usize = 16;

/// March `rays` through `field`, adding what it cost to `work`.
fn march(
    marcher: &mut Marcher,
    field: Field,
    rays: &[Ray],
    limits: Limits,
    hits: &mut Vec<Hit>,
    work: &mut Work,
) {
    let built = || field.cells.map_or(0, |c| c.built());
    let before = (
        marcher.instructions,
        marcher.proofs.bounded,
        marcher.proofs.walked,
        built(),
    );
    marcher.march(field, rays, limits, hits);
    work.built += (built() - before.3) as f64;
    work.rays += rays.len() as u64;
    work.instructions += marcher.instructions - before.0;
    work.bounded += marcher.proofs.bounded - before.1;
    work.walked += marcher.proofs.walked - before.2;
    let strain = (limits.max_steps / 4).max(1);
    for s in marcher.last_steps() {
        work.steps += s as u64;
        work.strained += (s >= strain) as u64;
    }
}

/// The mirror bounces of the rays that hit a surface, from just off it on the ray's side, as
/// far off as the render's paths leave a hit marched through `field` (`hit_epsilon`). The normals are
/// evaluated `LANES` hits of one object at a time (one at a time, they were most of a small
/// frame's probe).
fn bounce(
    rays: &[Ray],
    hits: &[Hit],
    (objects, field): (&[FrameObject], Field),
    grad: &mut Regs<Dual, LANES>,
    limits: Limits,
) -> Vec<Ray> {
    let met: Vec<(usize, &Ray, DVec4)> = (rays.iter().zip(hits))
        .filter_map(|(r, h)| match *h {
            Hit::Surface { t, object } => Some((object, r, r.o + r.d * t)),
            _ => None,
        })
        .collect();
    let mut order: Vec<usize> = (0..met.len()).collect();
    order.sort_by_key(|&i| met[i].0);
    let mut normals = vec![DVec4::ZERO; met.len()];
    for group in order.chunk_by(|&a, &b| met[a].0 == met[b].0) {
        for lanes in group.chunks(LANES) {
            let points: Vec<[f32; 4]> = lanes
                .iter()
                .map(|&i| met[i].2.as_vec4().to_array())
                .collect();
            let g = crate::vm::gradient(&objects[met[lanes[0]].0].distance, grad, &points, 0.0);
            for (&i, g) in lanes.iter().zip(g) {
                normals[i] = DVec4::from_array(g.g.map(f64::from)).normalize_or_zero();
            }
        }
    }
    let mut out = vec![];
    let mut path = field.cells.map(|c| c.path());
    for (&(_, r, p), n) in met.iter().zip(normals) {
        // Facing the ray, whichever side of the surface it came from.
        let n = if n.dot(r.d) > 0.0 { -n } else { n };
        if n == DVec4::ZERO {
            continue;
        }
        let cell = (field.cells.zip(path.as_mut())).map(|(cells, path)| cells.locate(path, p));
        let eps = hit_epsilon(cell, p, limits.epsilon, r.interior);
        out.push(Ray {
            o: p + n * (4.0 * eps),
            d: (r.d - 2.0 * r.d.dot(n) * n).normalize(),
            tmax: f64::INFINITY,
            // A mirror bounce stays on the side the ray came from.
            interior: r.interior,
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Where no ray shares a cell the render builds per ray what the probe did; where the
    /// first quarter built every cell, the probe's build is spread over the render's rays;
    /// in between, each doubling of density builds `1 + s` times as much again.
    #[test]
    fn building_extrapolates_by_the_share_of_new_cells() {
        let at = |first, second| Building {
            first,
            second,
            rays: 100.0,
            samples: 6400.0,
        };
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs().max(1.0);
        assert!(close(at(50.0, 50.0).per_probe(300.0), 300.0));
        assert!(close(at(50.0, 80.0).per_probe(300.0), 300.0));
        assert!(close(at(50.0, 0.0).per_probe(300.0), 300.0 / 64.0));
        // 64 times the density: six doublings of 1.5 times as much.
        assert!(close(
            at(40.0, 20.0).per_probe(300.0),
            300.0 * 1.5f64.powi(6) / 64.0
        ));
        assert!(close(at(0.0, 5.0).per_probe(300.0), 300.0));
        assert!(close(at(0.0, 0.0).per_probe(0.0), 0.0));
        // A frame with fewer samples than the probe has rays builds no more than it.
        let small = Building {
            samples: 10.0,
            ..at(50.0, 50.0)
        };
        assert!(close(small.per_probe(300.0), 300.0));
    }
}
