//! Speed against accuracy (`hyperslice bench`, see `docs/performance.md`, "Speed against
//! accuracy: `hyperslice bench`"): a reference render, then a sweep of configurations, each
//! rendered, timed, and compared with the reference (RMSE, PSNR, SSIM, mean luminance bias).
//!
//! The families swept: samples per pixel with light sampling on and no denoiser (the baseline
//! curve, with the default Sobol sampler); the same without light sampling; the same with
//! independent random numbers; the median and a-trous denoisers on top of the baseline; marching
//! epsilon, marching step limit and bounce depth at a middle sample count; the quality presets.
//! Every configuration renders with the scene's seed and the reference
//! with a different one (`seed + REFERENCE_SEED_OFFSET`), so the reference's noise is
//! independent of every configuration's. Only the denoiser families denoise, whatever the
//! scene's `denoise` says. Renders are deterministic, so repeating one changes only its time:
//! each configuration is rendered `repeats` times and its time is the median.
//!
//! [`pareto_front`] marks the configurations no other beats on both time and error, and
//! [`time_to_error`] reads off a curve how long it takes to reach an error. The results become
//! CSV, Markdown ([`report`]) and a PNG plot ([`plot`]).

pub mod corpus;
pub mod costs;
mod error;
pub mod plot;
pub mod report;

pub use error::SweepError;

use crate::error::Result;
use crate::metrics::{self, ImageError};
use crate::render::driver::{self, Options};
use crate::render::sampler::SamplerKind;
use crate::scene::{Denoise, Quality, RenderSettings, Scene};
use glam::DVec3;
use std::path::{Path, PathBuf};

/// The reference takes at least this many times the samples of any configuration: its own
/// error is then about a tenth of theirs (`REFERENCE_NOISE_RATIO`).
pub const REFERENCE_FACTOR: u32 = 100;
/// The reference renders with the scene's seed plus this, every configuration with the seed.
pub const REFERENCE_SEED_OFFSET: u64 = 1000;
/// The reference's own error should be below this fraction of the smallest error measured.
pub const REFERENCE_NOISE_RATIO: f64 = 0.1;

/// A group of configurations that differ in one setting; the first five are curves over
/// samples per pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Family {
    /// Light sampling on, no denoiser, the scene's bounces, epsilon and step limit.
    Baseline,
    /// Light sampling off: plain path tracing (BSDF sampling only).
    NoLightSampling,
    /// The baseline with independent random numbers instead of the Sobol sampler.
    Random,
    /// The baseline, median-filtered.
    Median,
    /// The baseline, a-trous-filtered.
    Atrous,
    /// Marching epsilon, at the middle sample count.
    Epsilon,
    /// Marching step limit, at the middle sample count.
    MaxSteps,
    /// Bounce depth, at the middle sample count.
    Bounces,
    /// A quality preset (samples, bounces, epsilon and step limit together).
    Preset,
}

impl Family {
    pub const ALL: [Family; 9] = [
        Family::Baseline,
        Family::NoLightSampling,
        Family::Random,
        Family::Median,
        Family::Atrous,
        Family::Epsilon,
        Family::MaxSteps,
        Family::Bounces,
        Family::Preset,
    ];

    /// Its name in tables, CSV and the plot's legend.
    pub fn name(self) -> &'static str {
        match self {
            Family::Baseline => "baseline",
            Family::NoLightSampling => "no light sampling",
            Family::Random => "random",
            Family::Median => "median",
            Family::Atrous => "atrous",
            Family::Epsilon => "epsilon",
            Family::MaxSteps => "max steps",
            Family::Bounces => "bounces",
            Family::Preset => "preset",
        }
    }

    /// Whether the family is a curve over samples per pixel (drawn as a line).
    pub fn is_curve(self) -> bool {
        matches!(
            self,
            Family::Baseline
                | Family::NoLightSampling
                | Family::Random
                | Family::Median
                | Family::Atrous
        )
    }
}

/// One configuration of the sweep: every setting it renders with.
#[derive(Clone, Debug, PartialEq)]
pub struct Config {
    /// What makes it differ, for people: `baseline`, `epsilon 1e-3`, `preset draft`, ...
    pub label: String,
    pub family: Family,
    pub spp: u32,
    pub bounces: u32,
    pub epsilon: f64,
    pub max_steps: u32,
    pub light_sampling: bool,
    pub sampler: SamplerKind,
    pub denoise: Denoise,
}

impl Config {
    /// The baseline at `spp`: the scene's bounces, epsilon and step limit, light sampling on,
    /// no denoiser.
    fn base(family: Family, label: impl Into<String>, r: &RenderSettings, spp: u32) -> Config {
        Config {
            label: label.into(),
            family,
            spp,
            bounces: r.bounces,
            epsilon: r.epsilon,
            max_steps: r.max_steps,
            light_sampling: true,
            sampler: SamplerKind::default(),
            denoise: Denoise::None,
        }
    }

    /// Set the render settings this configuration changes.
    pub fn apply(&self, r: &mut RenderSettings) {
        r.spp = self.spp;
        r.bounces = self.bounces;
        r.epsilon = self.epsilon;
        r.max_steps = self.max_steps;
        r.denoise = self.denoise;
    }
}

/// What a sweep measures.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepOptions {
    /// Samples per pixel of the five curves.
    pub spp_list: Vec<u32>,
    /// Marching epsilons tried at the middle sample count.
    pub epsilons: Vec<f64>,
    /// Marching step limits tried at the middle sample count.
    pub max_steps: Vec<u32>,
    /// Bounce depths tried at the middle sample count.
    pub bounces: Vec<u32>,
    /// Quality presets tried.
    pub presets: Vec<Quality>,
    /// Least samples per pixel of the reference (it takes at least `REFERENCE_FACTOR` times the
    /// most any configuration takes, whatever this says).
    pub reference_spp: Option<u32>,
    /// Image size instead of the scene's.
    pub size: Option<(u32, u32)>,
    /// Frame count instead of the scene's.
    pub frames: Option<u32>,
    /// Worker threads; `None` uses every core.
    pub threads: Option<usize>,
    /// Renders of each configuration; its time is their median.
    pub repeats: u32,
    /// The families measured; empty measures all.
    pub families: Vec<Family>,
}

impl Default for SweepOptions {
    /// The full sweep at the scene's size.
    fn default() -> Self {
        SweepOptions {
            spp_list: vec![1, 2, 4, 8, 16, 32],
            epsilons: vec![1e-2, 1e-3, 1e-4, 1e-5],
            max_steps: vec![50, 200, 1000, 5000],
            bounces: vec![1, 2, 4, 8, 16],
            presets: vec![Quality::Draft, Quality::Preview, Quality::Final],
            reference_spp: None,
            size: None,
            frames: None,
            threads: None,
            repeats: 5,
            families: vec![],
        }
    }
}

impl SweepOptions {
    /// Everything shrunk, for tests: 32 x 24, one frame, 1, 2 and 4 spp (so a 400-spp reference),
    /// only the draft preset (the others take more samples than the reference allows for), and
    /// one render per configuration.
    pub fn quick() -> Self {
        SweepOptions {
            repeats: 1,
            spp_list: vec![1, 2, 4],
            presets: vec![Quality::Draft],
            size: Some((32, 24)),
            frames: Some(1),
            ..SweepOptions::default()
        }
    }

    /// The scene's render settings with the size and frame count overridden.
    pub fn settings(&self, scene: &RenderSettings) -> RenderSettings {
        let mut r = scene.clone();
        if let Some((w, h)) = self.size {
            (r.width, r.height) = (w, h);
        }
        if let Some(f) = self.frames {
            r.frames = f;
        }
        r
    }
}

/// The sample counts of the curves, sorted, without repeats or zeros.
fn spp_list(opts: &SweepOptions) -> Vec<u32> {
    let mut v: Vec<u32> = opts.spp_list.iter().copied().filter(|&s| s > 0).collect();
    v.sort_unstable();
    v.dedup();
    v
}

/// The sample count the single-setting families use: the middle of the list (the upper
/// middle when its length is even).
pub fn middle_spp(spp_list: &[u32]) -> u32 {
    let mut v = spp_list.to_vec();
    v.sort_unstable();
    v.dedup();
    v.get(v.len() / 2).copied().unwrap_or(1)
}

/// Every configuration of the sweep over `base` (the scene's settings), in the order they are
/// rendered.
pub fn plan(base: &RenderSettings, opts: &SweepOptions) -> Vec<Config> {
    let spps = spp_list(opts);
    let mid = middle_spp(&spps);
    let mut out = vec![];
    for &spp in &spps {
        out.push(Config::base(Family::Baseline, "baseline", base, spp));
    }
    for &spp in &spps {
        out.push(Config {
            light_sampling: false,
            ..Config::base(Family::NoLightSampling, "no light sampling", base, spp)
        });
    }
    for &spp in &spps {
        out.push(Config {
            sampler: SamplerKind::Random,
            ..Config::base(Family::Random, "random sampler", base, spp)
        });
    }
    for (family, denoise, label) in [
        (Family::Median, Denoise::Median, "median denoiser"),
        (Family::Atrous, Denoise::Atrous, "atrous denoiser"),
    ] {
        for &spp in &spps {
            out.push(Config {
                denoise,
                ..Config::base(family, label, base, spp)
            });
        }
    }
    // A single-setting configuration, its label marked when the setting is the scene's.
    let at_mid = |family, label: String, scene: bool| {
        let mark = if scene { " (scene)" } else { "" };
        Config::base(family, label + mark, base, mid)
    };
    for &e in &opts.epsilons {
        let label = format!("epsilon {e:e}");
        out.push(Config {
            epsilon: e,
            ..at_mid(Family::Epsilon, label, e == base.epsilon)
        });
    }
    for &s in &opts.max_steps {
        let label = format!("max steps {s}");
        out.push(Config {
            max_steps: s,
            ..at_mid(Family::MaxSteps, label, s == base.max_steps)
        });
    }
    for &b in &opts.bounces {
        let label = format!("bounces {b}");
        out.push(Config {
            bounces: b,
            ..at_mid(Family::Bounces, label, b == base.bounces)
        });
    }
    for &q in &opts.presets {
        let mut r = base.clone();
        q.apply(&mut r);
        let name = match q {
            Quality::Draft => "draft",
            Quality::Preview => "preview",
            Quality::Final => "final",
            Quality::Custom => continue,
        };
        out.push(Config {
            bounces: r.bounces,
            epsilon: r.epsilon,
            max_steps: r.max_steps,
            ..Config::base(Family::Preset, format!("preset {name}"), base, r.spp)
        });
    }
    out.retain(|c| opts.families.is_empty() || opts.families.contains(&c.family));
    out
}

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
    let rendered = driver::render(&scene, &options, &|_| {})?;
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
    let rendered = driver::render(&scene, &options, &|_| {})?;
    let mut times = vec![rendered.elapsed.as_secs_f64()];
    for _ in 1..repeats {
        times.push(
            driver::render(&scene, &options, &|_| {})?
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

/// What a sweep is doing, for progress lines.
#[derive(Debug)]
pub enum Progress<'a> {
    /// The reference render starts.
    Reference { spp: u32 },
    /// The reference is ready (rendered or loaded).
    ReferenceDone { reference: &'a Reference },
    /// Configuration `index` (from 1) of `total` starts.
    Start {
        index: usize,
        total: usize,
        config: &'a Config,
    },
    /// Configuration `index` of `total` is measured.
    Done {
        index: usize,
        total: usize,
        row: &'a Row,
    },
}

/// A finished sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct Bench {
    /// The scene's settings as swept (size and frames overridden).
    pub settings: RenderSettings,
    pub threads: Option<usize>,
    /// Renders of each configuration (its time is their median).
    pub repeats: u32,
    pub reference: Reference,
    /// Every configuration measured, in plan order, with the Pareto front marked.
    pub rows: Vec<Row>,
}

impl Bench {
    /// The reference's own error over the smallest RMSE measured (it should be below
    /// `REFERENCE_NOISE_RATIO`); `None` when the reference's error is unknown.
    pub fn reference_ratio(&self) -> Option<f64> {
        let noise = self.reference.noise?;
        let best = self
            .rows
            .iter()
            .map(|r| r.error.rmse)
            .filter(|e| e.is_finite())
            .fold(f64::INFINITY, f64::min);
        best.is_finite().then(|| noise / best)
    }

    /// Samples per pixel a rendered reference would need to bring its error ratio down to
    /// `REFERENCE_NOISE_RATIO` (noise falls as one over the square root of samples).
    pub fn reference_spp_needed(&self) -> Option<u32> {
        let ratio = self.reference_ratio()?;
        let spp = self.reference.spp? as f64;
        let need = spp * (ratio / REFERENCE_NOISE_RATIO).powi(2);
        Some(need.ceil().min(u32::MAX as f64) as u32)
    }

    /// How much faster the error of plain path tracing at its most samples is reached with
    /// light sampling and with each denoiser.
    pub fn speedups(&self, metric: Metric) -> Option<Speedups> {
        speedups(&self.rows, metric)
    }
}

/// Run the whole sweep: the reference (rendered, or loaded from `reference_file`), then every
/// configuration of [`plan`]; `progress` hears of each step.
pub fn bench(
    scene: &Scene,
    opts: &SweepOptions,
    reference_file: Option<&Path>,
    progress: &mut dyn FnMut(Progress),
) -> Result<Bench> {
    let mut scene = scene.clone();
    scene.render = opts.settings(&scene.render);
    let configs = plan(&scene.render, opts);
    if configs.is_empty() {
        return Err(SweepError::NothingToMeasure.into());
    }
    let reference = match reference_file {
        Some(path) => load_reference(path, &scene.render)?,
        None => {
            let spp = reference_spp(&configs, opts.reference_spp);
            progress(Progress::Reference { spp });
            let mut accurate = scene.clone();
            accurate.render = reference_settings(&configs, &scene.render);
            render_reference(&accurate, spp, opts.threads)?
        }
    };
    progress(Progress::ReferenceDone {
        reference: &reference,
    });
    let total = configs.len();
    let mut rows = Vec::with_capacity(total);
    for (i, config) in configs.iter().enumerate() {
        progress(Progress::Start {
            index: i + 1,
            total,
            config,
        });
        let row = measure(&scene, config, &reference, opts.threads, opts.repeats)?;
        progress(Progress::Done {
            index: i + 1,
            total,
            row: &row,
        });
        rows.push(row);
    }
    mark_pareto(&mut rows);
    Ok(Bench {
        settings: scene.render,
        threads: opts.threads,
        repeats: opts.repeats.max(1),
        reference,
        rows,
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

/// A number to `digits` significant digits, fixed-point when that stays short (for tables,
/// progress lines and the plot's tick labels).
pub fn sig(x: f64, digits: usize) -> String {
    if !x.is_finite() {
        return if x.is_nan() {
            "NaN".into()
        } else if x > 0.0 {
            "inf".into()
        } else {
            "-inf".into()
        };
    }
    if x == 0.0 {
        return "0".into();
    }
    let mag = x.abs().log10().floor() as i32;
    if (-3..5).contains(&mag) {
        let decimals = (digits as i32 - 1 - mag).max(0) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.prec$e}", prec = digits.saturating_sub(1))
    }
}

/// Set every row's `pareto` flag from its (time, RMSE).
pub fn mark_pareto(rows: &mut [Row]) {
    let points: Vec<(f64, f64)> = rows.iter().map(|r| (r.time, r.error.rmse)).collect();
    for (row, on) in rows.iter_mut().zip(pareto_front(&points)) {
        row.pareto = on;
    }
}

/// Which of the (cost, error) points are on the Pareto front: no other point is at most as
/// costly and at most as wrong while strictly better in one of the two. Points that tie
/// exactly are all on the front (neither beats the other); points with a NaN coordinate are
/// never on it and beat nothing.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<bool> {
    let valid = |p: &(f64, f64)| !p.0.is_nan() && !p.1.is_nan();
    points
        .iter()
        .map(|p| {
            valid(p)
                && !points
                    .iter()
                    .any(|q| valid(q) && q.0 <= p.0 && q.1 <= p.1 && (q.0 < p.0 || q.1 < p.1))
        })
        .collect()
}

/// When a curve reaches an error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reach {
    /// At this time, interpolated between two of the curve's points.
    At(f64),
    /// The curve's first point is already there: at this time or sooner.
    AtMost(f64),
    /// None of the curve's points gets there.
    NotReached,
}

impl Reach {
    /// The time, when reached.
    pub fn time(self) -> Option<f64> {
        match self {
            Reach::At(t) | Reach::AtMost(t) => Some(t),
            Reach::NotReached => None,
        }
    }
}

/// When the curve of (time, error) points, in order of increasing effort, first reaches
/// `target` error: log time is interpolated linearly against log error between the last point
/// above the target and the first at or below it (exact on a power law `time = c error^k`).
/// Points with a non-positive or non-finite coordinate are ignored.
pub fn time_to_error(curve: &[(f64, f64)], target: f64) -> Reach {
    let pts: Vec<(f64, f64)> = curve
        .iter()
        .copied()
        .filter(|&(t, e)| t.is_finite() && e.is_finite() && t > 0.0 && e > 0.0)
        .collect();
    let Some(&(t0, e0)) = pts.first() else {
        return Reach::NotReached;
    };
    if e0 <= target {
        return Reach::AtMost(t0);
    }
    for w in pts.windows(2) {
        let ((ta, ea), (tb, eb)) = (w[0], w[1]);
        if ea > target && eb <= target {
            let f = (target.ln() - ea.ln()) / (eb.ln() - ea.ln());
            return Reach::At((ta.ln() + f * (tb.ln() - ta.ln())).exp());
        }
    }
    Reach::NotReached
}

/// How much faster than plain path tracing a target error is reached.
#[derive(Clone, Debug, PartialEq)]
pub struct Speedups {
    /// The error compared.
    pub metric: Metric,
    /// The error of plain path tracing (no light sampling, no denoiser) at its most samples.
    pub target: f64,
    /// Samples per pixel and seconds plain path tracing took to get there.
    pub spp: u32,
    pub time: f64,
    /// For the baseline (light sampling), random-sampler, median and atrous curves: when each
    /// reaches the target.
    pub curves: Vec<(Family, Reach)>,
}

impl Speedups {
    /// Plain path tracing's time over a curve's (at least this when the curve reached the
    /// target at its first point already).
    pub fn factor(&self, reach: Reach) -> Option<f64> {
        reach.time().map(|t| self.time / t)
    }
}

/// Which error the speed-ups compare.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Metric {
    /// RMSE of linear radiance: every firefly counts at full strength.
    Rmse,
    /// RMSE of the displayed image, `10^(-PSNR / 20)`: what a viewer sees, after the tone
    /// curve has compressed the highlights.
    DisplayRmse,
}

impl Metric {
    pub fn of(self, e: &ImageError) -> f64 {
        match self {
            Metric::Rmse => e.rmse,
            Metric::DisplayRmse => 10f64.powf(-e.psnr / 20.0),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Metric::Rmse => "RMSE",
            Metric::DisplayRmse => "display RMSE",
        }
    }
}

/// The (time, error) points of one family's curve, in order of samples per pixel.
pub fn curve(rows: &[Row], family: Family, metric: Metric) -> Vec<(f64, f64)> {
    let mut v: Vec<&Row> = rows.iter().filter(|r| r.config.family == family).collect();
    v.sort_by_key(|r| r.config.spp);
    v.iter().map(|r| (r.time, metric.of(&r.error))).collect()
}

/// See [`Speedups`]; `None` without rows of plain path tracing.
pub fn speedups(rows: &[Row], metric: Metric) -> Option<Speedups> {
    let plain = rows
        .iter()
        .filter(|r| r.config.family == Family::NoLightSampling)
        .max_by_key(|r| r.config.spp)?;
    let target = metric.of(&plain.error);
    let curves = [
        Family::Baseline,
        Family::Random,
        Family::Median,
        Family::Atrous,
    ]
    .into_iter()
    .filter(|f| rows.iter().any(|r| r.config.family == *f))
    .map(|f| (f, time_to_error(&curve(rows, f, metric), target)))
    .collect();
    Some(Speedups {
        metric,
        target,
        spp: plain.config.spp,
        time: plain.time,
        curves,
    })
}
