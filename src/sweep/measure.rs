//! One configuration rendered, timed and compared with the reference.

use super::{Config, Reference, SweepError};
use crate::error::Result;
use crate::metrics::{self, ImageError};
use crate::render::driver::{Monitor, Options};
use crate::scene::Scene;
use glam::DVec3;

/// One measured configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub config: Config,
    /// Wall time of the whole render, denoising included, in seconds.
    pub time: f64,
    pub error: ImageError,
    /// Ray segments that ran out of marching steps.
    pub out_of_steps: u64,
    /// Samples dropped as NaN or infinite.
    pub dropped: u64,
    /// On the Pareto front of (time, RMSE) among all rows.
    pub pareto: bool,
}

/// Render `config` over `scene` (whose size and frames must be the reference's) `repeats`
/// times (at least once) and compare it with `reference`; the row's time is the median and its
/// `pareto` is left false.
pub fn measure(
    scene: &Scene,
    config: &Config,
    reference: &Reference,
    threads: Option<usize>,
    repeats: u32,
) -> Result<Row> {
    let mut scene = scene.clone();
    config.apply(&mut scene.render);
    let r = &scene.render;
    if (r.width as usize, r.height as usize, r.frames as usize)
        != (reference.width, reference.height, reference.frames.len())
    {
        return Err(SweepError::ReferenceMismatch {
            reference: (reference.width, reference.height, reference.frames.len()),
            config: config.label.clone(),
            renders: (r.width, r.height, r.frames),
        }
        .into());
    }
    let options = Options {
        threads,
        light_sampling: config.light_sampling,
        sampler: config.sampler,
        ..Options::default()
    };
    let rendered = crate::render(&scene, &options, Monitor::SILENT)?;
    let mut times = vec![rendered.elapsed.as_secs_f64()];
    for _ in 1..repeats {
        times.push(
            crate::render(&scene, &options, Monitor::SILENT)?
                .elapsed
                .as_secs_f64(),
        );
    }
    let frames: Vec<&[DVec3]> = rendered.frames.iter().map(|f| f.color.as_slice()).collect();
    let refs: Vec<&[DVec3]> = reference.frames.iter().map(Vec::as_slice).collect();
    let error = metrics::compare(
        &frames,
        &refs,
        reference.width,
        reference.height,
        r.exposure,
    );
    Ok(Row {
        config: config.clone(),
        time: median(&mut times),
        error,
        out_of_steps: rendered.stats.out_of_steps,
        dropped: rendered.stats.dropped,
        pareto: false,
    })
}

/// The median of `v` (the mean of the middle two for an even count; NaN when empty).
pub fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}
