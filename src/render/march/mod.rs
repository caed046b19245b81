//! Sphere tracing through the frame's cells (`vm::cells`), a wavefront at a time.
//!
//! Each step, every ray still marching finds the cell it is in. A cell whose distance is
//! bounded away from zero is crossed in one jump to its far side; a cell where the distance is
//! a few planes, spheres, boxes and polytopes (a halfspace, a hypersphere alone, a glass box
//! from inside or out) is intersected exactly, in `f64`, so rays grazing them do not crawl; in
//! every other cell the ray is grouped with the rays in the same cell and their cell's pruned
//! tape runs `LANES` rays at a time.
//! Steps are over-relaxed (Keinert et al. 2014, "Enhanced Sphere Tracing"): a step of
//! `omega * d`, taken back to the plain step `d` whenever the unbounding spheres of two
//! consecutive points fail to overlap. `omega` follows the distance's slope along the ray
//! (Bán and Valasek 2023, "Automatic Step Size Relaxation in Sphere Tracing"): rays leaving
//! a surface, where the distance grows, take long steps, and rays closing in on one plain
//! ones. A ray sees the sky only when it provably leaves every object (`Escape::escapes`),
//! never by travelling far (`vm::escape`). A ray that crawls beside a surface leaps over
//! what it proves clear (`crawl`), and rays inside objects, whose unsigned `f32` distance
//! shows no sign change where a step crosses a surface, decide near one in `f64`
//! (`careful`). `--marcher whole` marches the whole tape with the
//! same relaxed steps, and `--marcher plain` with plain ones (`plain`): the baseline the
//! others are measured and tested against.

mod lanes;
mod plain;

use crate::ir::exact::{CELLS, Pieces, Rays};
use crate::vm::Tape;
use crate::vm::cells::{Cell, Cells, Met, epsilon_at, meet, meet_lanes};
use crate::vm::escape::{Ahead, Escape, Proofs};
use glam::DVec4;
use lanes::Lanes;
use std::collections::HashMap;

/// Which marcher a render uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MarcherKind {
    /// Through the frame's cells where a probe of at most about 1,700 rays shows that they pay,
    /// on the whole tape (as `whole`, or with plain steps where those cost less) where they do
    /// not (the default).
    #[default]
    Auto,
    /// Through the frame's pruned cells, with over-relaxed steps and exact planes, spheres,
    /// boxes and polytopes, whether or not they pay.
    Cells,
    /// Over-relaxed sphere tracing on the whole scene tape: no cells, no exact shortcuts.
    Whole,
    /// Plain sphere tracing on the whole scene tape: no cells, no relaxation, no exact
    /// shortcuts. The in-process baseline for measurements and tests.
    Plain,
}

impl MarcherKind {
    /// The name `--marcher` takes and film fingerprints record.
    pub fn name(self) -> &'static str {
        match self {
            MarcherKind::Auto => "auto",
            MarcherKind::Cells => "cells",
            MarcherKind::Whole => "whole",
            MarcherKind::Plain => "plain",
        }
    }
}

/// What a frame's rays march through: its cells (none for the whole-tape marchers), the whole
/// scene and interior tapes, and the proof that a ray has left the scene.
#[derive(Clone, Copy)]
pub struct Field<'a> {
    /// The frame's pruned cells; `None` for the whole-tape marchers.
    pub cells: Option<&'a Cells>,
    /// Whether rays outside objects over-relax their steps (all but the plain marcher).
    pub relax: bool,
    /// The whole scene tape: signed distance to the nearest visible object, and its index.
    pub scene: &'a Tape,
    /// The unsigned distance to any surface, for rays inside objects; `None` when no object
    /// can be entered.
    pub interior: Option<&'a Tape>,
    /// What proves that a ray has left every object.
    pub escape: &'a Escape,
}

impl Field<'_> {
    /// Where the frame marches without cells and its whole scene is a few exact pieces
    /// (`Escape::pieces`): the pieces a ray outside objects (inside them) meets, once.
    pub fn pieces(&self, interior: bool) -> Option<&Pieces> {
        self.cells
            .is_none()
            .then(|| self.escape.pieces(interior))
            .flatten()
    }
}

/// A ray segment to march: from `o` along the unit direction `d` up to `tmax`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin, in world space.
    pub o: DVec4,
    /// Unit direction.
    pub d: DVec4,
    /// Farthest distance to march, in world units.
    pub tmax: f64,
    /// The ray may be inside an object: march on the unsigned distance to every surface.
    pub interior: bool,
}

/// How a march ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Hit {
    /// Within the marching epsilon of `object`'s surface, `t` along the ray.
    Surface {
        /// Distance along the ray, in world units.
        t: f64,
        /// The object's index in the scene.
        object: usize,
    },
    /// Nothing before `tmax`, or the ray left the scene.
    Beyond,
    /// The step limit ran out first.
    OutOfSteps,
}

/// The marching settings of a render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// How close to a surface counts as a hit, in world units (the scene's `epsilon`).
    pub epsilon: f64,
    /// Most steps one ray segment may take before it is given up (the scene's `max_steps`).
    pub max_steps: u32,
}

/// The queue's tape class of rays in a partial cell (after 0, the scene's, and 1, the
/// interior's).
const PARTIAL: usize = 2;

/// The over-relaxation factor of a ray's first step.
const OMEGA: f64 = 1.6;
/// The most a step is over-relaxed, and the share of the step at which the spheres of two
/// points would just touch were the distance's slope to stay as it was.
const OMEGA_MAX: f64 = 32.0;
const SAFETY: f64 = 0.95;

/// Where one ray is in its march.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct State {
    t: f64,
    steps: u32,
    /// The unbounding radius at the previous point and the step taken from it (0 after a
    /// step that was not a sphere step).
    radius: f64,
    step: f64,
    omega: f64,
    /// Whether the ray may over-relax its steps at all.
    relax: bool,
    /// The next `t` at which to try to prove that the ray has left the scene.
    escape_at: f64,
    /// The unbounded objects the ray may still meet (`Escape::escapes`).
    keep: u64,
    /// Where the ray enters the cells' cube from outside (`Cells::enter`).
    enter: f64,
    /// The point at `t`, and the distance below which it is on a surface.
    p: DVec4,
    tol: f64,
    /// How far from `p` its cell's distances hold (`Cells::gap`).
    holds: f64,
    /// How far an interior ray's distance from its cell's tape may be off (`Cell::slack`).
    slack: f64,
    /// The partial cell whose pieces the ray has met, by address (0: none), the nearest
    /// piece where it entered (infinity after that), the `t` of the first it meets and the
    /// `t` at which it leaves the cell.
    partial: usize,
    near: (f64, f64),
    first: (f64, f64),
    leave: f64,
    /// The partial cell the pending step was taken in, by address (0: none).
    from: usize,
    /// The most a crawling ray tries to leap next (0: not set yet), the step count before
    /// which it does not try and how long it waited last, and the point (`t`, distance) where
    /// it last could (`crawl`).
    leap: f64,
    leap_at: u32,
    wait: u32,
    last: (f64, f64),
    /// On the whole tape, what the exact unbounded objects say of the ray (`Escape::ahead`).
    ahead: Ahead,
}

impl State {
    /// How far the ray at `p` in `cell` may go on the cell's own bounds: to the cell's far
    /// side, or from outside to the cube.
    fn exit(&self, cells: &Cells, cell: &Cell, p: DVec4, d: DVec4) -> f64 {
        if !cells.is_outside(cell) {
            cell.exit(p, d)
        } else if self.t <= self.enter {
            self.enter - self.t
        } else {
            f64::INFINITY
        }
    }
}

/// Per-thread scratch space of the marcher.
#[derive(Default)]
pub struct Marcher {
    lanes: Lanes,
    state: Vec<State>,
    active: Vec<u32>,
    next: Vec<u32>,
    /// Rays that need a tape run this step, with their cell's address as the sort key.
    queue: Vec<(usize, u32)>,
    /// Escape proofs' buffers, and the nodes they bounded.
    pub proofs: Proofs,
    /// Distance evaluations (tape lanes and exact evaluations in affine cells), for the
    /// statistics.
    pub evaluations: u64,
    /// Instructions those evaluations ran (a tape's length per lane, an affine cell's
    /// pieces): the work a step costs, which pruning shortens.
    pub instructions: u64,
    /// Where rays evaluated distances in the frame's cells, when set (`Some`, empty): for
    /// tests. `None` (the default) records nothing.
    pub trace: Option<Trace>,
}

/// The cells in which the marcher evaluated distances (`Marcher::trace`): what tests hold
/// `--emit bytecode --cell` to. Set it to `Some(Trace::default())` before `march`; each
/// `march` adds to it. One frame per trace: cells are known by address, which a later frame's
/// cells may reuse.
#[derive(Default)]
pub struct Trace {
    /// Each ray's first point in each cell where it ran a tape or met the exact pieces, in the
    /// order it got there (a ray back in a cell it left is recorded again).
    pub visits: Vec<Visit>,
    /// Each cell visited, as `--emit bytecode --cell` prints it (`Cell`'s `Display`), formatted
    /// when first visited; `Visit::cell` indexes it.
    pub cells: Vec<String>,
    /// Where in `cells` each cell is, by address.
    index: HashMap<usize, usize>,
    /// The cell each ray of the current `march` was last recorded in, by address (0: none).
    last: Vec<usize>,
}

/// One ray's arrival in a cell where it evaluated distances (`Trace`).
#[derive(Clone, Copy, Debug)]
pub struct Visit {
    /// The ray's index in the `march` call's rays.
    pub ray: usize,
    /// The point, in world space.
    pub p: DVec4,
    /// The cell's `Cell::id`.
    pub id: (u32, [u64; 4]),
    /// Outside the cells' cube, when the ray had proved some unbounded objects out of its
    /// way and ran the cell of the others (`Cells::outside`): which ones it kept. A point
    /// alone does not name that cell.
    pub keep: Option<u64>,
    /// The cell's text, in `Trace::cells`.
    pub cell: usize,
}

impl Trace {
    /// Ray `ray` evaluates `cell` at `p`: record it if that cell is not the last it was
    /// recorded in.
    fn record(&mut self, ray: usize, p: DVec4, cell: &Cell, keep: Option<u64>) {
        let here = address(cell);
        if self.last[ray] == here {
            return;
        }
        self.last[ray] = here;
        let next = self.cells.len();
        let index = *self.index.entry(here).or_insert(next);
        if index == next {
            self.cells.push(cell.to_string());
        }
        self.visits.push(Visit {
            ray,
            p,
            id: cell.id(),
            keep,
            cell: index,
        });
    }
}

/// What one step found for one ray.
enum Step {
    Hit {
        t: f64,
        object: usize,
    },
    /// Move on by this much (a sphere step or a jump within a cell).
    Advance(f64),
}

impl Marcher {
    /// March every ray through `field`; `hits[i]` receives ray `i`'s result. Rays with
    /// `interior` set march on the interior tapes.
    pub fn march(&mut self, field: Field, rays: &[Ray], limits: Limits, hits: &mut Vec<Hit>) {
        // Every ray starts at its origin, may still meet every unbounded object, and has
        // found nothing yet.
        hits.clear();
        hits.resize(rays.len(), Hit::Beyond);
        // A scene of a few exact pieces, off the cells (which `--marcher cells` keeps): each
        // ray ends where it first meets one.
        if field.pieces(false).is_some() {
            let pieces = |r: &Ray| field.pieces(r.interior).expect("set for both or neither");
            return self.meet(pieces, rays, limits, hits);
        }
        let keep = field.escape.unbounded();
        self.state.clear();
        // An unsigned distance does not change sign where a relaxed step crosses a surface,
        // and the spheres of the two points still touch there: rays inside objects take
        // plain steps.
        (self.state).extend(rays.iter().map(|r| {
            let relax = field.relax && !r.interior;
            State {
                keep,
                relax,
                omega: if relax { OMEGA } else { 1.0 },
                ..State::default()
            }
        }));
        match field.cells {
            Some(cells) => self.march_cells(cells, field.escape, rays, limits, hits),
            None => self.march_whole(field, rays, limits, hits),
        }
    }

    /// Where each ray of `rays` first meets the exact pieces `pieces(ray)` gives it, once,
    /// before its `tmax`, into `hits`: the march of a frame whose scene is a few exact pieces
    /// (`Field::pieces`), or of shadow rays that meet fewer of them.
    pub fn meet<'p>(
        &mut self,
        pieces: impl Fn(&Ray) -> &'p Pieces,
        rays: &[Ray],
        limits: Limits,
        hits: &mut Vec<Hit>,
    ) {
        hits.clear();
        hits.resize(rays.len(), Hit::Beyond);
        self.state.clear();
        // Four at a time, where they meet the same pieces (`meet_lanes`).
        for (group, hits) in rays.chunks(4).zip(hits.chunks_mut(4)) {
            let first = pieces(&group[0]);
            let work = if group.iter().all(|r| std::ptr::eq(pieces(r), first)) {
                let four = Rays::of(group.len(), |l| {
                    let r = &group[l];
                    (r.o.to_array(), r.d.to_array(), (r.tmax, CELLS))
                });
                let met = meet_lanes(first, &four);
                for ((r, hit), met) in group.iter().zip(hits).zip(met) {
                    *hit = end_met(met, r, limits.epsilon);
                }
                group.len() * first.len()
            } else {
                let mut met = 0;
                for (r, hit) in group.iter().zip(hits) {
                    let pieces = pieces(r);
                    *hit = end_met(meet(pieces, r.o, r.d, (r.tmax, CELLS)), r, limits.epsilon);
                    met += pieces.len();
                }
                met
            };
            self.instructions += (work * PIECE_WORK) as u64;
        }
        self.evaluations += rays.len() as u64;
    }

    /// The steps each ray of the last `march` took.
    pub fn last_steps(&self) -> impl Iterator<Item = u32> + '_ {
        self.state.iter().map(|s| s.steps)
    }

    fn march_cells(
        &mut self,
        cells: &Cells,
        escape: &Escape,
        rays: &[Ray],
        limits: Limits,
        hits: &mut [Hit],
    ) {
        let unbounded = escape.unbounded();
        for (st, r) in self.state.iter_mut().zip(rays) {
            st.enter = cells.enter(r.o, r.d);
        }
        if let Some(trace) = &mut self.trace {
            trace.last.clear();
            trace.last.resize(rays.len(), 0);
        }
        let mut at: Vec<Option<&Cell>> = vec![None; rays.len()];
        // Filled on the first pass, which takes every ray in order.
        let mut paths = Vec::with_capacity(rays.len());
        self.active.clear();
        self.active.extend(0..rays.len() as u32);
        while !self.active.is_empty() {
            self.next.clear();
            self.queue.clear();
            for &i in &self.active {
                let k = i as usize;
                let (r, st) = (&rays[k], &mut self.state[k]);
                let p = r.o + r.d * st.t;
                st.p = p;
                // A ray's first cell is found from the last ray's: rays of one batch start
                // where their neighbours do (the camera, hits close by), and the cells near
                // a surface run 24 deep where the scene is far from the origin.
                if k == paths.len() {
                    paths.push(paths.last().copied().unwrap_or_else(|| cells.path()));
                }
                let mut cell = cells.locate(&mut paths[k], p);
                // Where what lies outside the cube is met exactly, the meeting says whether
                // the ray meets any of it: no escape proof is needed (where nothing lies
                // there, the proof is immediate).
                if cells.is_outside(cell) && cell.pieces(r.interior).is_none_or(|p| p.is_empty()) {
                    if st.t >= st.escape_at {
                        // The ray is known to be clear only up to where the last step would
                        // have ended as a plain one (a relaxed step is checked at the next
                        // point): the proof starts there.
                        let clear = p - r.d * (st.step - st.radius).max(0.0);
                        if escape.escapes(clear, r.d, r.interior, &mut st.keep, &mut self.proofs) {
                            hits[k] = Hit::Beyond;
                            continue;
                        }
                        st.escape_at = retry(st.t);
                    }
                    // Objects the ray provably never meets no longer shorten its steps.
                    if st.keep != unbounded {
                        cell = cells.outside(st.keep);
                    }
                }
                at[k] = Some(cell);
                // Where a partial cell's pieces were met holds while the ray stays in it: one
                // back in a cell it left (the region outside the cube is not convex) meets
                // them again.
                if st.partial != address(cell) {
                    st.partial = 0;
                }
                let class = r.interior as usize;
                // Outside the cube, distances hold only as far as the cube: so far reach
                // the spheres that check a relaxed step.
                st.holds = if cells.is_outside(cell) {
                    cells.gap(p)
                } else {
                    f64::INFINITY
                };
                let tol = cell.epsilon(p, limits.epsilon, r.interior);
                // Rays inside objects end within the epsilon, whatever the interior tape's
                // rounding (`careful`).
                (st.tol, st.slack) = if r.interior {
                    (epsilon_at(p - cell.origin, limits.epsilon), cell.slack())
                } else {
                    (tol, 0.0)
                };
                // Nothing in the cell: cross it, and a sphere step beyond, since the bound
                // holds on the cell's sides too; short of the sphere by the tolerance, since
                // a tight bound (a floor parallel to the cell) puts its edge on the surface,
                // and the bound is rounded to nearest. Outside the cube it holds only at `p`
                // (and only as far as the cube): go as far as the bound allows, or to the cube.
                if cell.lower[class] > tol {
                    let lower = cell.lower[class].min(st.holds);
                    let step = unrelax(st, lower).unwrap_or_else(|| {
                        let exit = st.exit(cells, cell, p, r.d);
                        Step::Advance(if cells.is_outside(cell) {
                            past(exit, cell).max(lower)
                        } else {
                            past(exit, cell).max(exit + lower - tol)
                        })
                    });
                    finish(st, &mut self.next, k, r, step, limits, hits);
                    continue;
                }
                if let Some(trace) = &mut self.trace {
                    let keep = (cells.is_outside(cell) && st.keep != unbounded).then_some(st.keep);
                    trace.record(k, p, cell, keep);
                }
                if let Some(pieces) = cell.pieces(r.interior) {
                    self.evaluations += 1;
                    // To the cell's side, and just past it: a root on the side may round to
                    // just beyond it. A tiled ball's crossing of its lattice may stop short
                    // (`Met::clear`); the ray goes on from there, crossing more cells in each
                    // step the more steps it has taken (up to 4 times as many after 8), so
                    // that a ray a hair off one of the D4 packing's channels, which meets a
                    // sphere only some 200,000 units on, mostly gets there within its steps.
                    // Not more: a ray that keeps a lattice coordinate between the copies'
                    // reach (a slice missing every sphere of a sparse packing) is known to
                    // meet none (`Tiled::window`), but one a hair off such a slice crosses
                    // cell after cell until its steps run out.
                    let beyond = past(st.exit(cells, cell, p, r.d), cell);
                    let reach = (beyond.min(r.tmax - st.t), CELLS << (st.steps / 4).min(2));
                    let met = meet(pieces, p - cell.origin, r.d, reach);
                    // A piece met and a lattice cell crossed cost about as much as
                    // `PIECE_WORK` and `CELL_WORK` instructions of a cell's tape: the probe's
                    // model weighs the cells' march by them.
                    self.instructions += (pieces.len() * PIECE_WORK + met.cells * CELL_WORK) as u64;
                    let (near, first) = (met.near(), met.first());
                    let step = if let Some(back) = unrelax(st, near.0.min(st.holds)) {
                        back
                    } else if near.0 < tol {
                        Step::Hit {
                            t: st.t,
                            object: object(near.1),
                        }
                    } else if first.0 <= beyond.min(met.clear) {
                        // (Infinity, none met and nothing beyond the cell, ends the ray.)
                        Step::Hit {
                            t: st.t + first.0,
                            object: object(first.1),
                        }
                    } else {
                        Step::Advance(beyond.min(met.clear))
                    };
                    finish(st, &mut self.next, k, r, step, limits, hits);
                    continue;
                }
                // Rays inside objects run the cell's other tape (and never build a partial
                // form), and rays in a partial cell its rest, having met its pieces.
                let partial = if r.interior { None } else { cell.partial() };
                let tape = match partial {
                    Some(partial) => {
                        // Where the ray meets the pieces is known once it is in the cell;
                        // how near they are matters only where it enters (a later step
                        // towards one ends at its root).
                        let here = address(cell);
                        if st.partial != here {
                            // No tiled ball is a partial cell's piece (`ir::exact::partition`):
                            // its pieces are met to any length.
                            let reach = (f64::INFINITY, CELLS);
                            let met = meet(&partial.pieces, p - cell.origin, r.d, reach);
                            let (near, first) = (met.near(), met.first());
                            (st.near, st.first) = (near, (st.t + first.0, first.1));
                            st.leave = st.t + st.exit(cells, cell, p, r.d);
                            st.partial = here;
                            self.instructions += (partial.pieces.len() * PIECE_WORK) as u64;
                        } else {
                            st.near.0 = f64::INFINITY;
                        }
                        PARTIAL
                    }
                    None => class,
                };
                let key = address(cell) << 2 | tape;
                self.queue.push((key, i));
            }
            // Rays mostly stay in their cell from one step to the next, so the queue comes
            // in long sorted runs (`next` is filled group by group), which a stable sort
            // merges in about linear time.
            self.queue.sort_by_key(|q| q.0);
            let queue = std::mem::take(&mut self.queue);
            for group in queue.chunk_by(|a, b| a.0 == b.0) {
                let cell = at[group[0].1 as usize].expect("located above");
                let (partial, interior) = (group[0].0 & 3 == PARTIAL, group[0].0 & 3 == 1);
                let tape = match (interior, &cell.interior) {
                    (true, Some(t)) => t,
                    // Built when the ray was queued.
                    (false, _) if partial => &cell.partial().expect("a partial cell").rest,
                    _ => &cell.scene,
                };
                self.lanes.points.clear();
                (self.lanes.points).extend(
                    (group.iter())
                        .map(|&(_, i)| (self.state[i as usize].p - cell.origin).as_vec4()),
                );
                self.lanes.run(tape);
                self.evaluations += group.len() as u64;
                self.instructions += (group.len() * tape.code.len()) as u64;
                {
                    for (&(_, i), &(d, near)) in group.iter().zip(&self.lanes.out) {
                        let d = d as f64;
                        let (k, r) = (i as usize, &rays[i as usize]);
                        let st = &mut self.state[k];
                        let step = if d.is_nan() {
                            // NaN from a user's field ends the ray like a ray that ran out.
                            hits[k] = Hit::OutOfSteps;
                            continue;
                        } else if partial {
                            partial_step(st, (d, near), cell, r, (escape, &mut self.proofs))
                        } else if r.interior {
                            let (tol, slack) = (st.tol, st.slack);
                            careful(escape, st, r, (d, tol, slack, tol), &mut self.proofs)
                        } else if let Some(back) = unrelax(st, d.min(st.holds)) {
                            back
                        } else if d < st.tol && near >= 0.0 {
                            Step::Hit {
                                t: st.t,
                                object: near as usize,
                            }
                        } else if let Some(s) = crawl(escape, r, st, d, &mut self.proofs) {
                            s
                        } else {
                            // A relaxed step is only verified at the next point, so none
                            // may end the segment: the last step to `tmax` is a plain one.
                            let mut step = st.omega * d;
                            if st.t + step >= r.tmax {
                                step = d;
                            }
                            // Outside the cube the tape leaves out the objects inside it:
                            // go no further than into the cube, a step still checked at the
                            // next point if it is longer than `d` (a tiling's spheres lie
                            // outside the cube too).
                            if cells.is_outside(cell) {
                                let exit = st.exit(cells, cell, st.p, r.d);
                                if step >= exit {
                                    step = past(exit, cell);
                                }
                            }
                            (st.radius, st.step) = (d, step);
                            Step::Advance(step)
                        };
                        let step = match step {
                            Step::Hit { t, object }
                                if !r.interior
                                    && (cells.is_outside(cell) || cell.scene_slack() > st.tol) =>
                            {
                                let first = escape.distance(r.o + r.d * t, false, &mut self.proofs);
                                // Short of the surface in `f64` (the tape's constants far
                                // larger than the point, and their `f32` rounding with
                                // them): step on by that distance, as `approach` does.
                                match first.0 > st.tol {
                                    true => Step::Advance(t - st.t + first.0),
                                    false => settle(
                                        escape,
                                        r,
                                        (t, object),
                                        first,
                                        st.tol,
                                        &mut self.proofs,
                                    ),
                                }
                            }
                            step => step,
                        };
                        finish(st, &mut self.next, k, r, step, limits, hits);
                    }
                }
            }
            self.queue = queue;
            std::mem::swap(&mut self.active, &mut self.next);
        }
    }
}

/// The step back to where the last over-relaxed step would have ended as a plain one, if the
/// spheres around this point (of radius `d`, the distance here or a lower bound of it) and
/// the previous one do not overlap: the relaxed step may have skipped a surface. The next
/// step is then a plain one. Otherwise the pending step is verified and forgotten, and the
/// distance's slope between the two points sets the next relaxation: were it to change
/// linearly at rate `m`, the spheres would touch at a step of `2 / (1 - m)` times it.
fn unrelax(st: &mut State, d: f64) -> Option<Step> {
    let (radius, step) = (st.radius, st.step);
    (st.radius, st.step, st.from) = (0.0, 0.0, 0);
    if !st.relax || step <= 0.0 {
        return None;
    }
    if d < 0.0 || d + radius < step {
        // Back before where a partial cell's pieces were met, perhaps: meet them again.
        (st.omega, st.partial) = (1.0, 0);
        return Some(Step::Advance(radius - step));
    }
    // `2 / (1 - m)` with `m` clamped to [-1, 1], in one division: `step (1 - m)`.
    let rest = (step + radius - d).clamp(0.0, 2.0 * step);
    st.omega = (SAFETY * 2.0 * step / rest).clamp(1.0, OMEGA_MAX);
    None
}

/// A cell's address: which cell a ray's cached state belongs to, and the queue's sort key
/// (cells live in the frame's tree, which does not move while rays march).
fn address(cell: &Cell) -> usize {
    cell as *const Cell as usize
}

/// Where the ray ends in a scene that is the few exact pieces, which it meets as `met`: on
/// the surface where it starts within `epsilon` of one (as in a cell of pieces), else where
/// it first meets one; either only before `tmax`. It counts crossings only: a ray that passes
/// within the epsilon of a surface without meeting it, which sphere tracing ends on, goes on.
fn end_met(met: Met, r: &Ray, epsilon: f64) -> Hit {
    let (near, first) = (met.near(), met.first());
    match near.0 < epsilon {
        true => plain::end(r, 0.0, object(near.1)),
        false => plain::end(r, first.0, object(first.1)),
    }
}

/// An object index from a piece's (-1, none, for the cut bound of what is far).
fn object(o: f64) -> usize {
    o.max(0.0) as usize
}

/// The step in a partial cell, where the rest's tape gave `d` and nearest object `near`
/// and the pieces and the cell's far side were met already (`State::partial`). The
/// pieces hold only in the cell and are met exactly up to its side; the rest's
/// sphere covers the rest, and a relaxed step is checked on it at the next point if that is
/// still in the cell (the pieces being clear up to there), and on the whole distance if not.
fn partial_step(
    st: &mut State,
    (d, near): (f64, f32),
    cell: &Cell,
    r: &Ray,
    (escape, proofs): (&Escape, &mut Proofs),
) -> Step {
    let here = address(cell);
    let (pieces, first) = (st.near, (st.first.0 - st.t, st.first.1));
    let exit = (st.leave - st.t).max(0.0);
    let check = if st.from == here { d } else { d.min(pieces.0) };
    if let Some(back) = unrelax(st, check.min(st.holds)) {
        back
    } else if pieces.0 < st.tol {
        Step::Hit {
            t: st.t,
            object: object(pieces.1),
        }
    } else if d < st.tol && near >= 0.0 {
        Step::Hit {
            t: st.t,
            object: near as usize,
        }
    } else if first.0 <= d.min(past(exit, cell)) {
        Step::Hit {
            t: st.t + first.0,
            object: object(first.1),
        }
    } else if let Some(s) = crawl(escape, r, st, d.min(pieces.0), proofs) {
        s
    } else {
        let mut step = (st.omega * d).min(first.0);
        if st.t + step >= r.tmax {
            step = d;
        }
        if step >= exit {
            step = past(exit, cell);
        }
        (st.radius, st.step, st.from) = (d, step, here);
        Step::Advance(step)
    }
}

/// A step to `exit` and just past it, into the next cell.
fn past(exit: f64, cell: &Cell) -> f64 {
    let nudge = if cell.size.is_finite() {
        cell.size
    } else {
        1.0 + exit
    };
    exit + 1e-9 * nudge
}

/// Where a ray whose escape proof failed at `t` tries again: once it has gone four times as
/// far. A proof costs a few steps' worth of interval bounds and fails all along a ray in a
/// lattice, which never leaves it; retrying at `2t + 1` was an eighth of a tiling's render.
fn retry(t: f64) -> f64 {
    4.0 * t + 4.0
}

/// The step of a ray inside objects at `t`, whose tape gave the distance `d` there, `tol` the
/// distance below which it is on a surface: the unsigned distance shows no sign change where
/// a step crosses a surface, and the tape's `f32` distance may be off by more than the epsilon
/// (a hypersphere of radius 3e3 rounds by 2e-4; far from the origin, more). Where the cell
/// bounds that rounding (`slack`, `Cell::slack`), the tape's distance less it is a lower bound
/// of the true one; where nothing does (outside the cells' cube, or on the whole tape), the
/// tape is trusted only `NEAR` epsilons from a surface. Nearer, the distance in `f64` decides
/// (`Escape::distance`). Trusting the tape there ended rays that far from a surface, or let
/// them through it. A hit is a distance in `f64` below `fine`: `tol` in the cells (the
/// epsilon near a cell's origin, more outside their cube); the epsilon itself on the whole
/// tape, whose `tol` grows with the coordinates.
/// Crawling rays leap (`crawl`) here too.
fn careful(
    escape: &Escape,
    st: &mut State,
    r: &Ray,
    (d, tol, slack, fine): (f64, f64, f64, f64),
    proofs: &mut Proofs,
) -> Step {
    let (lower, clear) = if slack.is_finite() {
        (d - slack, tol)
    } else {
        (d, NEAR * tol)
    };
    let d = if lower >= clear {
        lower
    } else {
        let (exact, near) = escape.distance(r.o + r.d * st.t, true, proofs);
        if exact < fine && near >= 0.0 {
            return Step::Hit {
                t: st.t,
                object: near as usize,
            };
        }
        exact
    };
    crawl(escape, r, st, d, proofs).unwrap_or(Step::Advance(d))
}

/// A hit at `t` on the object `f64` finds nearest there (`near`, from `Escape::distance`),
/// where it finds one, else on `object`, the one the `f32` tape named: two objects within
/// the tape's rounding of each other may swap.
fn hit_nearest(t: f64, near: f64, object: usize) -> Step {
    Step::Hit {
        t,
        object: if near >= 0.0 { near as usize } else { object },
    }
}

/// Where a ray outside objects that its tape ended at `t` (on `object`) meets the surface,
/// where the tape's `f32` rounding may exceed the epsilon: a cell's bound of it
/// (`Cell::scene_slack`) says so, or nothing bounds it (outside the cells' cube, in
/// coordinates local to its centre; a hypersphere of radius 7e3 rounds by 5e-4). A step may
/// have ended inside by several epsilons, so that a path leaving the hit by its epsilon would
/// leave from inside. Where the distance in `f64` shows the point inside by more than `tol`,
/// the ray backs out to the surface: first by that distance (a ball of that radius lies
/// inside, so the step leaves no object), then by the secant of the last two distances, which
/// a ray grazing the surface needs, kept between the last points found inside and outside
/// (halving between them where the secant leaves them). The object is the nearest one where
/// the ray settles.
fn settle(
    escape: &Escape,
    r: &Ray,
    (t, object): (f64, usize),
    (d, near): (f64, f64),
    tol: f64,
    proofs: &mut Proofs,
) -> Step {
    let mut at = |t: f64| escape.distance(r.o + r.d * t, false, proofs);
    let hit = |t: f64, near: f64| hit_nearest(t, near, object);
    // A ray that starts inside has no surface behind it to settle back onto.
    if d.is_nan() || d >= -tol || t <= 0.0 {
        return hit(t, near);
    }
    // The last points inside and outside (beyond `tol`), and the distance at the former.
    let (mut inside, mut d_inside, mut outside) = (t, d, f64::NEG_INFINITY);
    let mut last = near;
    let mut next = (t + d).max(0.0);
    for _ in 0..SETTLE {
        let (dn, near) = at(next);
        if dn.is_nan() {
            break;
        }
        if dn.abs() <= tol {
            return hit(next, near);
        }
        let aim = if dn > tol {
            outside = next;
            // The secant through the points either side of the surface.
            next - dn * (inside - next) / (d_inside - dn)
        } else {
            // The secant through the last two points inside, back towards the surface.
            let slope = (dn - d_inside) / (next - inside);
            (inside, d_inside, last) = (next, dn, near);
            if slope < 0.0 {
                next - dn / slope
            } else {
                next + dn
            }
        };
        let lo = outside.max(0.0);
        next = if aim > lo && aim < inside {
            aim
        } else {
            0.5 * (lo + inside)
        };
    }
    hit(inside, last)
}

/// Where a ray outside objects that the whole tape ended at `st.t` (on `object`, the tape's
/// distance there `d`), within `tol` of a surface, meets it, where `tol` (grown with the
/// coordinates as `f32` needs) exceeds the epsilon `eps`: the distance in `f64` decides. Up
/// to `SETTLE` sphere steps in `f64` close in on the surface; within `eps` the ray hits,
/// settling back onto it if inside (`settle`); once the distance is above `tol` again the
/// ray passes the surface and marches on from there. Without this the whole tape's hits lay
/// up to `2^-21` of the coordinates off: 0.5 at 1e6 from the origin, against the epsilon's
/// 1e-4, and the probe kept such frames on cells, at up to 1.5 times plain's time.
fn approach(
    escape: &Escape,
    r: &Ray,
    st: &mut State,
    (d, object): (f64, usize),
    (tol, eps): (f64, f64),
    proofs: &mut Proofs,
) -> Step {
    let t = st.t;
    let hit = |t: f64, near: f64| hit_nearest(t, near, object);
    // A ray that starts well inside (a camera in an object) meets it where it starts, in
    // `f64` too: the tape's constants may be far larger than the point (an object moved
    // from far away to near the origin), and their rounding with them.
    let mut known = None;
    if t <= 0.0 && d < -tol {
        let (d, near) = escape.distance(r.o + r.d * t, false, proofs);
        if d < -tol {
            return hit(t, near);
        }
        known = Some((d, near));
    }
    let (mut at, mut last) = (t, -1.0);
    for i in 0..SETTLE {
        // (The first point's distance, where the check above took it already.)
        let (d, near) = known
            .take()
            .unwrap_or_else(|| escape.distance(r.o + r.d * at, false, proofs));
        if d.is_nan() || d < eps {
            return settle(escape, r, (at, object), (d, near), eps, proofs);
        }
        last = near;
        // A ray grazing the surface closer than `tol` crawls in steps of `d`: it leaps.
        if i == 0
            && let Some(s) = crawl(escape, r, st, d, proofs)
        {
            return s;
        }
        at += d;
        if d > tol {
            break;
        }
    }
    // An epsilon below `f64`'s spacing at `t` leaves nothing to step: the ray is as close as
    // it can be.
    if at == t {
        return hit(t, last);
    }
    Step::Advance(at - t)
}

/// What crossing one cell of a tiled ball's lattice costs, in tape instructions per lane, as
/// the probe's model counts them (`render::probe`): on the D4 packing a cell took about 118
/// ns in `perf` (a crossing's own set-up included), and the model puts a whole-tape step
/// there at about a quarter of its measured time, so 118 / 4 ns at the cells' 0.77 ns an
/// instruction (see `docs/performance.md`, "A tiled ball met exactly").
const CELL_WORK: usize = 38;

/// What meeting one piece costs, in the same instructions: a hypersphere took 13 to 15 ns,
/// whatever the number of pieces (1 to 24 balls, 4,096 random rays each, the best of 30
/// runs), so a quarter of 14 ns at 0.77 ns an instruction.
const PIECE_WORK: usize = 4;

/// Most distances `settle` evaluates after the first, and most steps `approach` takes.
const SETTLE: u32 = 8;

/// How many epsilons from a surface a ray inside objects stops trusting a tape whose rounding
/// nothing bounds (`careful`): on the soak, 4 left 10 scenes wrong, 16 six, 64 four.
const NEAR: f64 = 64.0;

/// Steps after which a ray counts as crawling: sphere steps shrink beside a surface the ray
/// grazes or closes in on at a shallow angle, and it may take thousands of them.
const CRAWL: u32 = 128;
/// A crawling ray's first leap, in distances at its point.
const LEAP: f64 = 16.0;
/// The shortest leap worth a proof, in distances: a proof costs tens of tape steps.
const MIN_LEAP: f64 = 8.0;

/// A crawling ray's leap at `t` (where no relaxed step is pending, its distance there `d`): as
/// far along the stretch ahead as it provably meets no surface (`Escape::clear`; in a
/// lattice's channels, cell by cell), if that is at least `MIN_LEAP` distances. A try aims at
/// 0.9 of where the distance, falling as it did since the last point, would reach zero (a
/// plane met at a shallow angle), at most four times the last leap (or `LEAP` distances at
/// first); a failed try quarters the next, and the ray waits twice as many steps as after
/// the last failure before it tries again.
fn crawl(escape: &Escape, r: &Ray, st: &mut State, d: f64, proofs: &mut Proofs) -> Option<Step> {
    let last = std::mem::replace(&mut st.last, (st.t, d));
    if st.steps < CRAWL.max(st.leap_at) {
        return None;
    }
    if st.leap <= 0.0 {
        st.leap = LEAP * d;
    }
    let fall = (last.1 - d) / (st.t - last.0);
    let aim = if fall > 0.0 {
        0.9 * d / fall
    } else {
        f64::INFINITY
    };
    let len = aim.min(st.leap).min(r.tmax - st.t);
    // (NaN, where the distance is, fails too.)
    if len.partial_cmp(&(MIN_LEAP * d)) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let clear = escape.clear(r.o + r.d * st.t, r.d, len, r.interior, proofs);
    if clear > MIN_LEAP * d {
        (st.leap, st.wait) = (4.0 * clear, 0);
        return Some(Step::Advance(clear));
    }
    st.leap = if len > 4.0 * MIN_LEAP * d {
        len / 4.0
    } else {
        0.0
    };
    st.wait = (2 * st.wait).max(1);
    st.leap_at = st.steps + st.wait;
    None
}

/// Apply one step's outcome to ray `k`: record its hit, or move it on and keep it marching
/// (in `next`) unless it passed `tmax` or ran out of steps.
fn finish(
    st: &mut State,
    next: &mut Vec<u32>,
    k: usize,
    r: &Ray,
    step: Step,
    limits: Limits,
    hits: &mut [Hit],
) {
    match step {
        Step::Hit { t, object } => {
            hits[k] = if t < r.tmax {
                Hit::Surface { t, object }
            } else {
                Hit::Beyond
            };
            return;
        }
        Step::Advance(dt) => st.t += dt,
    }
    st.steps += 1;
    if st.t >= r.tmax {
        hits[k] = Hit::Beyond;
    } else if st.steps >= limits.max_steps {
        hits[k] = Hit::OutOfSteps;
    } else {
        next.push(k as u32);
    }
}
