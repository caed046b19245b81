//! What the sweep measures: the families of configurations and the plan of them.

use crate::render::sampler::SamplerKind;
use crate::scene::{Denoise, Quality, RenderSettings};

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
    /// Worker threads; `None` uses the scene's (every core unless it sets `threads`).
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
