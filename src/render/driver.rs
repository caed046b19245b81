//! Rendering a whole animation: the (frame, tile) pieces of a group of frames spread over a
//! rayon pool. Every sample's random stream depends only on the seed, frame, pixel and sample
//! index, so the result is bit-identical whatever the number of threads.
//!
//! Samples are taken in passes (1, 1, 2, 4, 8, ... per pixel) when the render is progressive:
//! with a time budget, a pass starts only if it is expected to end within the budget; with a
//! noise threshold, a pixel stops taking samples once its relative standard error is below it.

use super::frame::{Features, FrameScene};
use super::integrator::{self, Scratch, Settings, Stack, Stats, Tile};
use super::march::Limits;
use super::sampler::SamplerKind;
use crate::compile::{Compiled, frame_time};
use crate::error::{Error, Result};
use crate::film::{Film, PixelSums};
use crate::scene::Scene;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Tile edge in pixels.
const TILE: u32 = 16;
/// Samples a pixel takes before adaptive sampling judges its noise.
pub const ADAPTIVE_MIN: u32 = 16;
/// Frames prepared and rendered together when the render is not progressive (a progressive
/// render keeps every frame's tapes for all its passes).
const FRAME_GROUP: usize = 16;

/// Choices of a render that are not part of the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// Worker threads; `None` uses every core.
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
            time_budget: None,
            noise_threshold: None,
        }
    }
}

pub struct Rendered {
    /// The frames, denoised with the scene's `denoise` filter.
    pub frames: Vec<Film>,
    pub stats: Stats,
    /// Time spent denoising (part of `elapsed`).
    pub denoise_time: Duration,
    pub elapsed: Duration,
}

/// Samples a render takes at most, for progress bars.
pub fn total_samples(scene: &Scene) -> u64 {
    let r = &scene.render;
    r.width as u64 * r.height as u64 * r.spp as u64 * r.frames as u64
}

/// The sample ranges of the passes: everything at once, or 1, 1, 2, 4, ... up to `spp`.
fn passes(spp: u32, progressive: bool) -> Vec<std::ops::Range<u32>> {
    if !progressive {
        return std::iter::once(0..spp).collect();
    }
    let mut out = vec![];
    let mut start = 0;
    while start < spp {
        let end = (start + start.max(1)).min(spp);
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
    let lum = |c: glam::DVec3| crate::metrics::luminance(c);
    let mean = lum(s.radiance) / n;
    let var = (lum(s.radiance_sq) / n - mean * mean).max(0.0);
    // Channel squares summed with luminance weights bound the luminance's second moment
    // from above (Jensen), so this errs on the side of sampling more.
    let error = (var / (n - 1.0)).sqrt();
    error > threshold * mean.max(1e-3)
}

/// One frame in flight: its tapes, the media around the camera, and per tile the pixel sums
/// and which pixels still take samples.
struct Work {
    index: u32,
    scene: FrameScene,
    initial: Stack,
    sums: Vec<Vec<PixelSums>>,
    active: Vec<Vec<bool>>,
}

/// What a caller watching a render hands in: a callback told how many samples each piece of
/// work took (from any worker thread), and a flag that stops the render when set.
#[derive(Clone, Copy)]
pub struct Monitor<'a> {
    pub progress: &'a (dyn Fn(u64) + Sync),
    /// Set it (from any thread) to stop: pieces of work not yet started are skipped and the
    /// render returns [`Error::Cancelled`].
    pub cancel: Option<&'a AtomicBool>,
}

impl Monitor<'_> {
    fn cancelled(&self) -> bool {
        self.cancel.is_some_and(|c| c.load(Ordering::Relaxed))
    }
}

/// Render every frame of `scene`; `progress` is told how many samples each piece of work took.
pub fn render(
    scene: &Scene,
    options: &Options,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Rendered> {
    render_monitored(
        scene,
        options,
        Monitor {
            progress,
            cancel: None,
        },
    )
}

/// [`render`] that the caller can also stop, through `monitor.cancel`.
pub fn render_monitored(scene: &Scene, options: &Options, monitor: Monitor) -> Result<Rendered> {
    let start = Instant::now();
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = options.threads {
        builder = builder.num_threads(n);
    }
    let pool = builder.build().map_err(Error::Threads)?;
    let r = &scene.render;
    let compiled = Compiled::new(scene);
    let mut features = Features::of(&compiled);
    if options.general {
        features.interiors = true;
    }
    let settings = Settings {
        width: r.width,
        height: r.height,
        bounces: r.bounces,
        limits: Limits {
            epsilon: r.epsilon,
            max_steps: r.max_steps,
        },
        seed: r.seed,
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
    let group = if progressive {
        r.frames as usize
    } else {
        FRAME_GROUP
    };
    let mut frames = vec![];
    let mut stats = Stats::default();
    let all: Vec<u32> = (0..r.frames).collect();
    for indices in all.chunks(group) {
        let mut work: Vec<Work> = indices
            .iter()
            .map(|&f| {
                let fs = FrameScene::new(scene, &compiled, features, frame_time(f, r.frames));
                let initial = Stack::at_camera(&fs, r.epsilon);
                let n = |t: &Tile| (t.width * t.height) as usize;
                Work {
                    index: f,
                    scene: fs,
                    initial,
                    sums: tiles
                        .iter()
                        .map(|t| vec![PixelSums::default(); n(t)])
                        .collect(),
                    active: tiles.iter().map(|t| vec![true; n(t)]).collect(),
                }
            })
            .collect();
        let mut spent_per_sample = None;
        for pass in passes(r.spp, progressive) {
            let busy: usize = work
                .iter()
                .flat_map(|w| &w.active)
                .map(|a| a.iter().filter(|x| **x).count())
                .sum();
            if busy == 0 {
                break;
            }
            if monitor.cancelled() {
                return Err(Error::Cancelled);
            }
            if let (Some(budget), Some(per)) = (options.time_budget, spent_per_sample) {
                let expected = per * (busy as f64 * pass.len() as f64);
                if start.elapsed().as_secs_f64() + expected > budget.as_secs_f64() {
                    break;
                }
            }
            let pass_start = Instant::now();
            let taken: Stats = pool.install(|| {
                work.par_iter_mut()
                    .flat_map(|w| {
                        let (scene, initial, index) = (&w.scene, w.initial, w.index);
                        (w.sums.par_iter_mut().zip(&w.active).zip(&tiles)).map(
                            move |((sums, active), tile)| {
                                (scene, initial, index, sums, active, tile)
                            },
                        )
                    })
                    .map_init(
                        Scratch::default,
                        |scratch, (fs, initial, f, sums, active, tile)| {
                            let mut st = Stats::default();
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
                            st
                        },
                    )
                    .reduce(Stats::default, |mut a, b| {
                        a += b;
                        a
                    })
            });
            if taken.samples > 0 {
                spent_per_sample = Some(pass_start.elapsed().as_secs_f64() / taken.samples as f64);
            }
            stats += taken;
            if monitor.cancelled() {
                return Err(Error::Cancelled);
            }
            if let Some(threshold) = options.noise_threshold {
                for w in &mut work {
                    for (sums, active) in w.sums.iter().zip(&mut w.active) {
                        for (s, a) in sums.iter().zip(active.iter_mut()) {
                            *a = *a && noisy(s, threshold);
                        }
                    }
                }
            }
        }
        for w in work {
            let mut film = Film::new(r.width as usize, r.height as usize);
            for (tile, sums) in tiles.iter().zip(&w.sums) {
                for (k, s) in sums.iter().enumerate() {
                    let (x, y) = (
                        tile.x + k as u32 % tile.width,
                        tile.y + k as u32 / tile.width,
                    );
                    film.set((y * r.width + x) as usize, s);
                }
            }
            frames.push(film);
        }
    }
    let denoise_start = Instant::now();
    let options = crate::denoise::AtrousOptions::default();
    pool.install(|| crate::denoise::denoise(&mut frames, r.denoise, &options));
    Ok(Rendered {
        frames,
        stats,
        denoise_time: denoise_start.elapsed(),
        elapsed: start.elapsed(),
    })
}
