//! The reference every configuration is compared with: rendered with many more samples, or
//! loaded from OpenEXR frames.

use super::{Config, SweepError};
use crate::error::Result;
use crate::render::driver::{Monitor, Options};
use crate::render::sampler::SamplerKind;
use crate::scene::{Denoise, RenderSettings, Scene};
use glam::DVec3;
use std::path::{Path, PathBuf};

/// The reference takes at least this many times the samples of any configuration: its own
/// error is then about a tenth of theirs (`REFERENCE_NOISE_RATIO`).
pub const REFERENCE_FACTOR: u32 = 100;
/// The reference renders with the scene's seed plus this, every configuration with the seed.
pub const REFERENCE_SEED_OFFSET: u64 = 1000;
/// The reference's own error should be below this fraction of the smallest error measured.
pub const REFERENCE_NOISE_RATIO: f64 = 0.1;

/// Samples per pixel of the reference: `REFERENCE_FACTOR` times the most any configuration
/// takes, or `least` if that is more.
pub fn reference_spp(configs: &[Config], least: Option<u32>) -> u32 {
    let most = configs.iter().map(|c| c.spp).max().unwrap_or(1);
    most.saturating_mul(REFERENCE_FACTOR)
        .max(least.unwrap_or(0))
        .max(1)
}

/// The image every configuration is compared with.
#[derive(Clone, Debug, PartialEq)]
pub struct Reference {
    pub width: usize,
    pub height: usize,
    /// Linear radiance of every frame (before exposure).
    pub frames: Vec<Vec<DVec3>>,
    /// Samples per pixel, when rendered here.
    pub spp: Option<u32>,
    /// Seed, when rendered here.
    pub seed: Option<u64>,
    /// Its own estimated RMSE: the root mean square of its pixels' standard errors over every
    /// channel and frame (when rendered here; an EXR holds no standard errors).
    pub noise: Option<f64>,
    /// Seconds it took, when rendered here.
    pub time: Option<f64>,
    /// Where it came from, for people.
    pub source: String,
}

/// The most accurate marching and depth among `configs` and the scene's own settings `r`:
/// the most bounces, the smallest epsilon and the most steps. The reference renders with them,
/// so that what a configuration gives up (light from deeper paths, rays that stop early) shows
/// as error instead of being shared with the reference.
pub fn reference_settings(configs: &[Config], r: &RenderSettings) -> RenderSettings {
    let mut out = r.clone();
    for c in configs {
        out.bounces = out.bounces.max(c.bounces);
        out.epsilon = out.epsilon.min(c.epsilon);
        out.max_steps = out.max_steps.max(c.max_steps);
    }
    out
}

/// Render the reference for `scene` (its settings, as overridden by the caller, should come
/// from [`reference_settings`]): `spp` samples
/// per pixel, light sampling on, no denoiser, seed `seed + REFERENCE_SEED_OFFSET`, and
/// independent random numbers, so that its pixels' standard errors (which assume independent
/// samples) measure its own error honestly.
pub fn render_reference(scene: &Scene, spp: u32, threads: Option<usize>) -> Result<Reference> {
    let mut scene = scene.clone();
    let r = &mut scene.render;
    r.spp = spp;
    r.denoise = Denoise::None;
    r.seed = r.seed.wrapping_add(REFERENCE_SEED_OFFSET);
    let seed = r.seed;
    let options = Options {
        threads,
        light_sampling: true,
        sampler: SamplerKind::Random,
        ..Options::default()
    };
    let rendered = crate::render(&scene, &options, Monitor::SILENT)?;
    let (mut sq, mut n) = (0.0, 0usize);
    for f in &rendered.frames {
        for e in &f.std_error {
            sq += e.length_squared();
            n += 3;
        }
    }
    Ok(Reference {
        width: scene.render.width as usize,
        height: scene.render.height as usize,
        frames: rendered.frames.into_iter().map(|f| f.color).collect(),
        spp: Some(spp),
        seed: Some(seed),
        noise: Some((sq / n.max(1) as f64).sqrt()),
        time: Some(rendered.elapsed.as_secs_f64()),
        source: format!(
            "rendered at {spp} spp, seed {seed}, bounces {}, epsilon {:e}, max steps {}",
            scene.render.bounces, scene.render.epsilon, scene.render.max_steps
        ),
    })
}

/// Load a reference from OpenEXR: `path` itself for one frame, else (or when `path` does not
/// exist) the numbered frames `stem_0000.exr`, `stem_0001.exr`, ... beside it, as `render`
/// writes them. The first RGBA layer is read and divided by the scene's exposure (which
/// `render` multiplies EXRs by); it must match the sweep's size and frame count.
pub fn load_reference(path: &Path, r: &RenderSettings) -> Result<Reference> {
    let frames = r.frames as usize;
    let files: Vec<PathBuf> = if frames == 1 && path.is_file() {
        vec![path.to_path_buf()]
    } else {
        let numbered: Vec<PathBuf> = (0..frames)
            .map(|i| crate::output::numbered_path(path, i))
            .collect();
        if let Some(missing) = numbered.iter().find(|p| !p.is_file()) {
            return Err(if frames == 1 && !numbered[0].is_file() {
                SweepError::ReferenceMissing {
                    path: path.to_path_buf(),
                }
            } else if path.is_file() {
                SweepError::ReferenceOneFrame {
                    path: path.to_path_buf(),
                    frames,
                    numbered: numbered[0].clone(),
                }
            } else {
                SweepError::ReferenceFrameMissing {
                    path: missing.clone(),
                }
            }
            .into());
        }
        numbered
    };
    let (width, height) = (r.width as usize, r.height as usize);
    let scale = if r.exposure > 0.0 {
        1.0 / r.exposure
    } else {
        1.0
    };
    let mut out = Vec::with_capacity(frames);
    for file in &files {
        let image = exr::prelude::read_first_rgba_layer_from_file(
            file,
            |size, _| {
                (
                    size.width(),
                    vec![DVec3::ZERO; size.width() * size.height()],
                )
            },
            |(w, px): &mut (usize, Vec<DVec3>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                px[pos.y() * *w + pos.x()] = DVec3::new(r as f64, g as f64, b as f64);
            },
        )
        .map_err(|source| SweepError::ReferenceUnreadable {
            path: file.clone(),
            source,
        })?;
        let size = image.layer_data.size;
        if (size.width(), size.height()) != (width, height) {
            return Err(SweepError::ReferenceSize {
                path: file.clone(),
                size: (size.width(), size.height()),
                expected: (width, height),
            }
            .into());
        }
        let pixels = image.layer_data.channel_data.pixels.1;
        if pixels.iter().any(|c| !c.is_finite()) {
            return Err(SweepError::ReferenceNotFinite { path: file.clone() }.into());
        }
        out.push(pixels.into_iter().map(|c| c * scale).collect());
    }
    Ok(Reference {
        width,
        height,
        frames: out,
        spp: None,
        seed: None,
        noise: None,
        time: None,
        source: match files.as_slice() {
            [one] => format!("loaded from `{}`", one.display()),
            many => format!(
                "loaded from `{}` .. `{}`",
                many[0].display(),
                many[many.len() - 1].display()
            ),
        },
    })
}
