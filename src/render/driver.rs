//! Rendering a whole animation: frames one after another, each frame's tiles spread over a
//! rayon pool. Every sample's random stream depends only on the seed, frame, pixel and sample
//! index, so the result is bit-identical whatever the number of threads.

use super::film::Film;
use super::frame::Prepared;
use super::integrator::{self, Scratch, Settings, Stack, Stats, Tile};
use super::march::Limits;
use crate::check::Scene;
use glam::DVec4;
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// Tile edge in pixels.
const TILE: u32 = 16;

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
}

impl Default for Options {
    fn default() -> Self {
        Options {
            threads: None,
            roulette_from: 3,
            general: false,
            light_sampling: true,
        }
    }
}

pub struct Rendered {
    pub frames: Vec<Film>,
    pub stats: Stats,
    pub elapsed: Duration,
}

/// The animation time of frame `f` of `frames`: 0 on the first, 1 on the last.
pub fn frame_time(f: u32, frames: u32) -> f64 {
    if frames <= 1 {
        0.0
    } else {
        f as f64 / (frames - 1) as f64
    }
}

/// Samples a render takes in all, for progress bars.
pub fn total_samples(scene: &Scene) -> u64 {
    let r = &scene.render;
    r.width as u64 * r.height as u64 * r.spp as u64 * r.frames as u64
}

/// Render every frame of `scene`; `progress` is told how many samples each finished tile took.
pub fn render(
    scene: &Scene,
    options: &Options,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Rendered, String> {
    let start = Instant::now();
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = options.threads {
        builder = builder.num_threads(n);
    }
    let pool = builder
        .build()
        .map_err(|e| format!("cannot start worker threads: {e}"))?;
    let r = &scene.render;
    let mut prepared = Prepared::new(scene);
    if options.general {
        prepared.features.interiors = true;
    }
    let camera = &scene.camera;
    let reach = DVec4::from_array(camera.from)
        .abs()
        .max(DVec4::from_array(camera.to).abs())
        .max_element();
    let settings = Settings {
        width: r.width,
        height: r.height,
        spp: r.spp,
        bounces: r.bounces,
        limits: Limits {
            epsilon: r.epsilon,
            max_steps: r.max_steps,
        },
        seed: r.seed,
        roulette_from: options.roulette_from,
        far: 1e3 * (1.0 + reach),
        light_sampling: options.light_sampling,
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
    let mut frames = vec![];
    let mut stats = Stats::default();
    for f in 0..r.frames {
        let fs = prepared.frame(frame_time(f, r.frames));
        let initial = Stack::at_camera(&fs, r.epsilon);
        let results: Vec<_> = pool.install(|| {
            tiles
                .par_iter()
                .map_init(Scratch::default, |scratch, tile| {
                    let mut st = Stats::default();
                    let sums = integrator::render_tile(
                        &fs, &settings, f, *tile, initial, scratch, &mut st,
                    );
                    progress(st.samples);
                    (sums, st)
                })
                .collect()
        });
        let mut film = Film::new(r.width as usize, r.height as usize);
        for (tile, (sums, st)) in tiles.iter().zip(results) {
            stats += st;
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
    Ok(Rendered {
        frames,
        stats,
        elapsed: start.elapsed(),
    })
}
