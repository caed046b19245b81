//! Rendering a whole animation: the (frame, tile) pieces of a group of frames spread over a
//! rayon pool. Every sample's random stream depends only on the seed, frame, pixel and sample
//! index, so the result is bit-identical whatever the number of threads.
//!
//! The work comes as units (a frame's range of samples) and is kept in a [`Store`] as it
//! finishes, so an interrupted render resumes where it stopped: a tile takes a pass whole or not
//! at all, and which pixels take the next pass is judged from the sums alone, so a resumed
//! render adds exactly the samples an uninterrupted one would, in the same order.
//!
//! Samples are taken in passes (1, 1, 2, 4, 8, ... per pixel) when the render is progressive:
//! with a time budget, a pass starts only if it is expected to end within the frame's share of
//! the budget; with a noise threshold, a pixel stops taking samples once its relative standard
//! error is below it.
//!
//! The driver renders and keeps the work, nothing more: denoising and encoding the frames is
//! the finishing stage ([`crate::farm::assemble`]).

use super::frame::{Build, FrameScene, FrameSource, Shot};
use super::integrator::{self, Scratch, Settings, Stack, Stats, Tile};
use super::march::MarcherKind;
use super::sampler::SamplerKind;
use crate::error::{Error, Result};
use crate::film::{Film, PixelSums};
use crate::math::color::luminance;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// The integrator's working memory, kept from one piece of work to the next: rayon asks
/// `map_init` for a fresh one in every job it splits off, and paths, rays and marcher state
/// grown from empty each time (a megabyte of new pages) were a third of a small frame's render.
#[derive(Default)]
struct Scratches(std::sync::Mutex<Vec<(Scratch, Vec<bool>)>>);

/// A scratch space out of `Scratches`, which it goes back to when dropped.
struct Held<'a> {
    scratch: (Scratch, Vec<bool>),
    home: &'a Scratches,
}

impl Scratches {
    fn take(&self) -> Held<'_> {
        let kept = self.0.lock().unwrap_or_else(|e| e.into_inner()).pop();
        Held {
            scratch: kept.unwrap_or_default(),
            home: self,
        }
    }
}

impl Drop for Held<'_> {
    fn drop(&mut self) {
        let scratch = std::mem::take(&mut self.scratch);
        (self.home.0.lock().unwrap_or_else(|e| e.into_inner())).push(scratch);
    }
}

/// Tile edge in pixels.
const TILE: u32 = 16;
/// Samples a pixel takes before adaptive sampling judges its noise.
pub const ADAPTIVE_MIN: u32 = 16;
/// Most frames in flight at once (there are as many as worker threads, up to this).
pub const FRAME_GROUP: usize = 16;

/// Choices of a render that are not part of the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// Worker threads; `None` uses the scene's (every core unless it sets `threads`).
    pub threads: Option<usize>,
    /// Russian roulette from this many bounces on (`u32::MAX` turns it off, which makes
    /// closed furnaces deterministic).
    pub roulette_from: u32,
    /// Render every feature's code path even when the scene does not need it (to measure what
    /// the specialisation saves).
    pub general: bool,
    /// Next-event estimation towards spherical lights, combined with BSDF sampling by multiple
    /// importance sampling (on by default). Off, the estimator is pure BSDF sampling.
    pub light_sampling: bool,
    /// Where the random numbers come from.
    pub sampler: SamplerKind,
    /// How rays are marched: through pruned cells (the default) or plainly on the whole tape.
    pub marcher: MarcherKind,
    /// Progressive rendering: stop taking samples once this much time is spent (after at
    /// least one sample per pixel), up to the scene's `spp`.
    pub time_budget: Option<Duration>,
    /// Adaptive sampling: a pixel stops once the standard error of its luminance is below
    /// this fraction of its mean luminance (judged after `ADAPTIVE_MIN` samples).
    pub noise_threshold: Option<f64>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            threads: None,
            roulette_from: 3,
            general: false,
            light_sampling: true,
            sampler: SamplerKind::default(),
            marcher: MarcherKind::default(),
            time_budget: None,
            noise_threshold: None,
        }
    }
}

/// A piece of a render's work: samples `samples` of every pixel of frame `frame` (all of
/// `0..spp`, unless the render is split across machines by samples).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Unit {
    /// The frame (0-based).
    pub frame: u32,
    /// The sample indices taken of every pixel, half-open.
    pub samples: std::ops::Range<u32>,
}

impl Unit {
    fn key(&self) -> (u32, u32, u32) {
        (self.frame, self.samples.start, self.samples.end)
    }
}

impl Ord for Unit {
    fn cmp(&self, o: &Unit) -> std::cmp::Ordering {
        self.key().cmp(&o.key())
    }
}

impl PartialOrd for Unit {
    fn partial_cmp(&self, o: &Unit) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}

/// A unit's accumulation, finished or not: every pixel's sums (row-major from the top left) and
/// the counts of the work they took.
#[derive(Clone, Debug, PartialEq)]
pub struct Progress {
    /// The unit these sums belong to.
    pub unit: Unit,
    /// Every pixel's sums, row-major from the top left.
    pub sums: Vec<PixelSums>,
    /// The work counts of the samples taken so far.
    pub stats: Stats,
    /// Every pass ran (or a progressive render decided it was done).
    pub complete: bool,
}

/// Where a render keeps its work, so that an interrupted render resumes where it stopped: a
/// film directory on disk, or memory.
pub trait Store: Sync {
    /// What an earlier run left of `unit`, if anything.
    fn load(&self, unit: &Unit) -> Result<Option<Progress>>;
    /// Keep `progress` (called when a unit finishes, now and then while it runs, and for every
    /// unit in flight when the render is cancelled). By value: memory keeps it as it is,
    /// where a copy of a small frame's sums (a fresh megabyte) was a tenth of its render.
    fn save(&self, progress: Progress) -> Result<()>;
}

/// A [`Store`] in memory.
#[derive(Default)]
pub struct MemoryStore(std::sync::Mutex<std::collections::BTreeMap<Unit, Progress>>);

impl MemoryStore {
    /// Everything saved, by unit.
    pub fn into_map(self) -> std::collections::BTreeMap<Unit, Progress> {
        self.0.into_inner().unwrap_or_else(|e| e.into_inner())
    }
}

impl Store for MemoryStore {
    fn load(&self, unit: &Unit) -> Result<Option<Progress>> {
        Ok(self
            .0
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get(unit)
            .cloned())
    }
    fn save(&self, progress: Progress) -> Result<()> {
        (self.0.lock().unwrap_or_else(|e| e.into_inner())).insert(progress.unit.clone(), progress);
        Ok(())
    }
}

/// Samples of a pass when the render is not progressive: passes only set how often the work is
/// kept (a multiple of the batch a full tile traces at once, so they do not change it).
const PASS_SAMPLES: u32 = 16;
/// A unit in flight is kept at least this often (besides when it finishes or is cancelled).
const CHECKPOINT: Duration = Duration::from_secs(60);

/// The sample ranges of the passes over `samples`: chunks of [`PASS_SAMPLES`], or, when the
/// render is progressive, 1, 1, 2, 4, ... up to the end.
fn passes(samples: std::ops::Range<u32>, progressive: bool) -> Vec<std::ops::Range<u32>> {
    let mut out = vec![];
    let mut start = samples.start;
    while start < samples.end {
        let len = if progressive {
            start.max(1)
        } else {
            PASS_SAMPLES
        };
        let end = start.saturating_add(len).min(samples.end);
        out.push(start..end);
        start = end;
    }
    out
}

/// Whether a pixel's estimate is still noisier than `threshold` (relative standard error of
/// its luminance).
fn noisy(s: &PixelSums, threshold: f64) -> bool {
    if s.samples < ADAPTIVE_MIN {
        return true;
    }
    let n = s.samples as f64;
    let mean = luminance(s.radiance) / n;
    let var = (luminance(s.radiance_sq) / n - mean * mean).max(0.0);
    // Channel squares summed with luminance weights bound the luminance's second moment
    // from above (Jensen), so this errs on the side of sampling more.
    let error = (var / (n - 1.0)).sqrt();
    error > threshold * mean.max(1e-3)
}

/// Whether a pixel takes the samples of `pass`, judged from its sums alone, so that a resumed
/// render decides exactly as an uninterrupted one: it has taken every sample before the pass
/// (a tile takes a pass whole or not at all) and, under adaptive sampling, is still noisy.
fn takes(s: &PixelSums, start: u32, pass: &std::ops::Range<u32>, threshold: Option<f64>) -> bool {
    let done = start + s.samples;
    match threshold {
        None => done < pass.end,
        Some(t) => done == pass.start && noisy(s, t),
    }
}

/// One unit in flight: its frame's tapes, the media around the camera, and per tile the
/// pixel sums.
struct Work {
    unit: Unit,
    scene: FrameScene,
    initial: Stack,
    sums: Vec<Vec<PixelSums>>,
    stats: Stats,
    saved: Instant,
}

impl Work {
    fn progress(&self, tiles: &[Tile], width: u32, height: u32, complete: bool) -> Progress {
        let mut sums = vec![PixelSums::default(); width as usize * height as usize];
        for (tile, ts) in tiles.iter().zip(&self.sums) {
            for (k, s) in ts.iter().enumerate() {
                let (x, y) = (
                    tile.x + k as u32 % tile.width,
                    tile.y + k as u32 / tile.width,
                );
                sums[(y * width + x) as usize] = *s;
            }
        }
        Progress {
            unit: self.unit.clone(),
            sums,
            stats: self.stats,
            complete,
        }
    }
}

/// The per-tile sums of a row-major frame.
fn tiled(sums: &[PixelSums], tiles: &[Tile], width: u32) -> Vec<Vec<PixelSums>> {
    (tiles.iter())
        .map(|t| {
            (0..t.height)
                .flat_map(|y| (0..t.width).map(move |x| ((t.y + y) * width + t.x + x) as usize))
                .map(|i| sums[i])
                .collect()
        })
        .collect()
}

/// What a caller watching a render hands in: a callback told how many samples each piece of
/// work took (from any worker thread), and a flag that stops the render when set.
#[derive(Clone, Copy)]
pub struct Monitor<'a> {
    /// Called with each number of samples just taken, from any worker thread.
    pub progress: &'a (dyn Fn(u64) + Sync),
    /// Set it (from any thread) to stop: pieces of work not yet started are skipped, the work
    /// in flight is saved, and the render returns [`Error::Cancelled`].
    pub cancel: Option<&'a AtomicBool>,
}

impl Monitor<'_> {
    /// Told nothing, never stopped.
    pub const SILENT: Monitor<'static> = Monitor {
        progress: &|_| {},
        cancel: None,
    };

    fn cancelled(&self) -> bool {
        self.cancel.is_some_and(|c| c.load(Ordering::Relaxed))
    }
}

/// Every sample of every frame, as units.
pub fn whole(shot: &Shot) -> Vec<Unit> {
    (0..shot.frames)
        .map(|frame| Unit {
            frame,
            samples: 0..shot.spp,
        })
        .collect()
}

/// Every frame of `frames` rendered in memory: the films as the samples left them, and the
/// counts of the work. Denoising is the finishing stage's ([`crate::farm::assemble`]).
pub fn render_films(
    frames: &dyn FrameSource,
    options: &Options,
    monitor: Monitor,
) -> Result<(Vec<Film>, Stats)> {
    let store = MemoryStore::default();
    let shot = frames.shot();
    let stats = render_units(frames, options, &whole(shot), &store, monitor)?;
    let films = (store.into_map().into_values())
        .map(|p| Film::from_sums(shot.width as usize, shot.height as usize, &p.sums))
        .collect();
    Ok((films, stats))
}

/// One worker thread per core (what a scene's `threads = 0` asks for).
pub fn every_core() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// The pool of worker threads: `threads`, or one per core.
pub(crate) fn pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = threads {
        builder = builder.num_threads(n);
    }
    builder.build().map_err(Error::Threads)
}

/// Render `units`, resuming each from what `store` holds of it and keeping the work in `store`
/// as it finishes. Returns the counts of the work done in this call. Frames go through a few
/// at a time, so memory does not grow with their number.
pub fn render_units(
    frames: &dyn FrameSource,
    options: &Options,
    units: &[Unit],
    store: &dyn Store,
    monitor: Monitor,
) -> Result<Stats> {
    let start = Instant::now();
    let r = frames.shot();
    let pool = pool(options.threads.or(r.threads))?;
    let build = Build {
        marcher: options.marcher,
        general: options.general,
    };
    let settings = Settings {
        shot: *r,
        roulette_from: options.roulette_from,
        light_sampling: options.light_sampling,
        sampler: options.sampler,
    };
    let tiles: Vec<Tile> = (0..r.height.div_ceil(TILE))
        .flat_map(|ty| {
            (0..r.width.div_ceil(TILE)).map(move |tx| Tile {
                x: tx * TILE,
                y: ty * TILE,
                width: TILE.min(r.width - tx * TILE),
                height: TILE.min(r.height - ty * TILE),
            })
        })
        .collect();
    let progressive = options.time_budget.is_some() || options.noise_threshold.is_some();
    let pixels = r.width as usize * r.height as usize;
    // What earlier runs finished is skipped; what they left unfinished goes first.
    let mut todo = vec![];
    for u in units {
        match store.load(u)? {
            Some(p) if p.complete => {}
            Some(p) if p.sums.len() == pixels => todo.push((u.clone(), Some(p))),
            _ => todo.push((u.clone(), None)),
        }
    }
    let group = pool.current_num_threads().clamp(1, FRAME_GROUP);
    let scratches = Scratches::default();
    let mut stats = Stats::default();
    let mut spent_per_sample = None;
    let mut remaining = todo.len();
    let mut todo = todo.into_iter();
    loop {
        let batch: Vec<(Unit, Option<Progress>)> = todo.by_ref().take(group).collect();
        if batch.is_empty() {
            break;
        }
        // A time budget is shared out over the frames still to render.
        let deadline = options.time_budget.map(|b| {
            let left = b.saturating_sub(start.elapsed());
            Instant::now() + left.mul_f64(batch.len() as f64 / remaining as f64)
        });
        remaining -= batch.len();
        // Frames are prepared in parallel: pruning, compiling and probing are real work.
        let mut work: Vec<Work> = pool.install(|| {
            batch
                .into_par_iter()
                .map(|(unit, earlier)| {
                    let fs = frames.frame(unit.frame, build);
                    let initial = Stack::at_camera(&fs, r.limits.epsilon);
                    let (sums, stats) = match earlier {
                        Some(p) => (tiled(&p.sums, &tiles, r.width), p.stats),
                        None => (
                            (tiles.iter())
                                .map(|t| vec![PixelSums::default(); (t.width * t.height) as usize])
                                .collect(),
                            Stats::default(),
                        ),
                    };
                    Work {
                        unit,
                        scene: fs,
                        initial,
                        sums,
                        stats,
                        saved: Instant::now(),
                    }
                })
                .collect()
        });
        let samples = work[0].unit.samples.clone();
        debug_assert!(work.iter().all(|w| w.unit.samples == samples));
        for pass in passes(samples.clone(), progressive) {
            let takes = |s: &PixelSums| takes(s, samples.start, &pass, options.noise_threshold);
            let busy: usize = (work.iter())
                .flat_map(|w| w.sums.iter().flatten())
                .filter(|s| takes(s))
                .count();
            if busy == 0 || monitor.cancelled() {
                continue;
            }
            // Every pixel takes at least its first pass, whatever the budget.
            if let (Some(deadline), Some(per), true) = (deadline, spent_per_sample, pass.start > 0)
            {
                let expected = Duration::from_secs_f64(per * (busy as f64 * pass.len() as f64));
                if Instant::now() + expected > deadline {
                    break;
                }
            }
            let pass_start = Instant::now();
            let taken: Vec<(usize, Stats)> = pool.install(|| {
                (work.par_iter_mut().enumerate())
                    .flat_map(|(i, w)| {
                        let (scene, initial, frame) = (&w.scene, w.initial, w.unit.frame);
                        (w.sums.par_iter_mut().zip(&tiles))
                            .map(move |(sums, tile)| (i, scene, initial, frame, sums, tile))
                    })
                    .map_init(
                        || scratches.take(),
                        |held, (i, fs, initial, f, sums, tile)| {
                            let (scratch, active) = &mut held.scratch;
                            let mut st = Stats::default();
                            active.clear();
                            active.extend(sums.iter().map(takes));
                            if active.iter().any(|a| *a) && !monitor.cancelled() {
                                integrator::render_tile(
                                    fs,
                                    &settings,
                                    f,
                                    *tile,
                                    pass.clone(),
                                    active,
                                    initial,
                                    scratch,
                                    &mut st,
                                    sums,
                                );
                            }
                            (monitor.progress)(st.samples);
                            (i, st)
                        },
                    )
                    .collect()
            });
            let mut total = Stats::default();
            for (i, st) in taken {
                work[i].stats += st;
                total += st;
            }
            if total.samples > 0 {
                spent_per_sample = Some(pass_start.elapsed().as_secs_f64() / total.samples as f64);
            }
            stats += total;
            if monitor.cancelled() {
                break;
            }
            pool.install(|| {
                (work.par_iter_mut())
                    .filter(|w| w.saved.elapsed() >= CHECKPOINT)
                    .map(|w| {
                        w.saved = Instant::now();
                        store.save(w.progress(&tiles, r.width, r.height, false))
                    })
                    .collect::<Result<Vec<()>>>()
            })?;
        }
        let complete = !monitor.cancelled();
        // Encoding films is real work (compression): the frames of a group in parallel.
        pool.install(|| {
            (work.par_iter())
                .map(|w| store.save(w.progress(&tiles, r.width, r.height, complete)))
                .collect::<Result<Vec<()>>>()
        })?;
        if !complete {
            return Err(Error::Cancelled);
        }
    }
    Ok(stats)
}
