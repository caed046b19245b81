//! The marcher corpus (`hyperslice bench --marcher-corpus`): the default marcher against the
//! plain one (`--marcher plain`, whole-tape sphere tracing in the same binary), in wall clock,
//! paired and alternating, on scenes wider than the examples: the five examples, sphere unions
//! of 16 and 1024, a custom `sdf` field of 625 spheres, a grid tiling, a room of rounded boxes,
//! a turned slab, glass and a sphere seen from 3e4 away (whose cells keep splitting), and
//! generated scenes (`crate::generate`). Each scene's ratio is the median
//! over its pairs of the default's time over plain's; a ratio above 1 means the default
//! marcher is slower there. Short scenes take more pairs (`measure`).

use super::median;
use crate::Compilation;
use crate::compile::Frames;
use crate::error::Result;
use crate::render::driver::{Monitor, Options};
use crate::render::frame::Build;
use crate::render::march::MarcherKind;
use crate::render::probe::Choice;
use crate::scene::{Denoise, Scene};
use std::path::Path;

/// One scene of the corpus: where its source is (a file of the repository, with `-D` defines,
/// or a generated scene), and the image it renders.
pub struct Entry {
    pub name: String,
    source: Source,
    size: (u32, u32),
    frames: u32,
    spp: u32,
}

enum Source {
    File(&'static str, &'static [&'static str]),
    Generated(u64),
}

/// The corpus's scenes from files of the repository: name, path, `-D` defines, size, frames,
/// samples per pixel.
type FileEntry = (
    &'static str,
    &'static str,
    &'static [&'static str],
    (u32, u32),
    u32,
    u32,
);

const FILES: [FileEntry; 12] = [
    ("d4_packing", "examples/d4_packing.4ds", &[], (96, 72), 2, 4),
    ("room", "examples/room.4ds", &[], (96, 72), 2, 4),
    ("glass_box", "examples/glass_box.4ds", &[], (96, 72), 2, 4),
    ("tesseract", "examples/tesseract.4ds", &[], (96, 72), 2, 4),
    ("polytopes", "examples/polytopes.4ds", &[], (96, 72), 2, 4),
    (
        "spheres_16",
        "benches/scenes/spheres.4ds",
        &["n=4"],
        (160, 120),
        1,
        4,
    ),
    (
        "spheres_1024",
        "benches/scenes/spheres.4ds",
        &["n=32"],
        (160, 120),
        1,
        4,
    ),
    (
        "sdf_625",
        "benches/scenes/spheres_sdf.4ds",
        &["n=25"],
        (128, 128),
        1,
        16,
    ),
    (
        "grid_tiling",
        "tests/in/grid_lattice.4ds",
        &[],
        (96, 60),
        1,
        4,
    ),
    (
        "rounded_room",
        "benches/scenes/rounded_room.4ds",
        &[],
        (96, 72),
        1,
        4,
    ),
    (
        "turned_slab",
        "benches/scenes/turned_slab.4ds",
        &[],
        (128, 128),
        1,
        1,
    ),
    (
        "far_glass",
        "benches/scenes/far_glass.4ds",
        &[],
        (96, 72),
        1,
        4,
    ),
];

/// The corpus, with `generated` generated scenes (seeds 1, 2, ...: 96 x 72, 4 spp).
pub fn entries(generated: u64) -> Vec<Entry> {
    let files = FILES
        .iter()
        .map(|&(name, path, defines, size, frames, spp)| Entry {
            name: name.to_string(),
            source: Source::File(path, defines),
            size,
            frames,
            spp,
        });
    let generated = (1..=generated).map(|seed| Entry {
        name: format!("generated_{seed}"),
        source: Source::Generated(seed),
        size: (96, 72),
        frames: 1,
        spp: 4,
    });
    files.chain(generated).collect()
}

impl Entry {
    /// The scene at the corpus's settings, without a denoiser (the marchers are measured).
    /// Files are read from the repository, relative to `root`.
    pub fn scene(&self, root: &Path) -> Result<Scene> {
        let compilation = match &self.source {
            Source::File(path, defines) => {
                let defines: Vec<String> = defines.iter().map(|d| d.to_string()).collect();
                Compilation::from_path_with(&root.join(path), &defines)
            }
            Source::Generated(seed) => {
                Compilation::from_source(&self.name, &crate::generate::generate(*seed).source)
            }
        };
        let mut scene = compilation.into_scene_named(&self.name)?;
        let r = &mut scene.render;
        (r.width, r.height, r.frames, r.spp) = (self.size.0, self.size.1, self.frames, self.spp);
        r.denoise = Denoise::None;
        Ok(scene)
    }
}

/// One scene's figures: median seconds with each marcher, the median of the paired ratios,
/// and segments out of steps.
#[derive(Clone, Debug)]
pub struct Measured {
    pub name: String,
    pub default_s: f64,
    pub plain_s: f64,
    /// The median over the pairs of default over plain: a pair's two renders run one after
    /// the other, so the machine's load drifting between pairs cancels in each ratio.
    pub ratio: f64,
    /// A 95% confidence interval of the ratio (`median_interval` of the pairs' ratios), where
    /// there are pairs enough for one: a ratio whose interval holds 1 is within the noise.
    pub interval: Option<(f64, f64)>,
    /// Paired renders taken (`measure`).
    pub pairs: u32,
    pub default_out_of_steps: u64,
    pub plain_out_of_steps: u64,
    /// What the default marcher chose for the first frame, and why.
    pub choice: Choice,
}

/// A scene's pairs go on past `runs` until the default marcher's renders add up to this
/// many seconds: a 5 ms render timed three times moved its ratio between 1.0 and 2.2 from
/// one run of the corpus to the next.
const MIN_SECONDS: f64 = 1.0;
/// The most pairs a scene takes (unless `runs` asks for more): 61 give a ratio's interval
/// (`median_interval`) between the 23rd and 39th of them, where 31 gave the 10th and 22nd.
const MAX_PAIRS: u32 = 61;

/// Render `scene` at least `runs` times with each marcher, alternating (each pair in the other
/// order from the last), on `threads`, and on until the default's renders add up to
/// `MIN_SECONDS` (at most `MAX_PAIRS` pairs).
pub fn measure(name: &str, scene: &Scene, runs: u32, threads: Option<usize>) -> Result<Measured> {
    let mut times = [vec![], vec![]];
    let mut out_of_steps = [0, 0];
    let mut pairs = 0;
    while pairs < runs || (times[0].iter().sum::<f64>() < MIN_SECONDS && pairs < MAX_PAIRS) {
        // Which goes first alternates: the first render of a pair ran a few per cent slower
        // than the second with the same marcher twice (medians over 31 pairs of 0.94 to
        // 1.13, four of five above 1), which a fixed order would charge to one marcher.
        let order = match pairs % 2 {
            0 => [0, 1],
            _ => [1, 0],
        };
        for i in order {
            let marcher = [MarcherKind::Auto, MarcherKind::Plain][i];
            let options = Options {
                threads,
                marcher,
                ..Options::default()
            };
            let rendered = crate::render(scene, &options, Monitor::SILENT)?;
            times[i].push(rendered.elapsed.as_secs_f64());
            out_of_steps[i] = rendered.stats.out_of_steps;
        }
        pairs += 1;
    }
    let mut ratios: Vec<f64> = times[0].iter().zip(&times[1]).map(|(d, p)| d / p).collect();
    ratios.sort_by(f64::total_cmp);
    let first = Frames::new(scene).at(0.0, Build::marcher(MarcherKind::Auto));
    Ok(Measured {
        choice: first.probe.map_or(Choice::Exact, |p| p.choice()),
        name: name.to_string(),
        default_s: median(&mut times[0]),
        plain_s: median(&mut times[1]),
        interval: median_interval(&ratios),
        ratio: median(&mut ratios),
        pairs,
        default_out_of_steps: out_of_steps[0],
        plain_out_of_steps: out_of_steps[1],
    })
}

/// A confidence interval of at least 95% for the median of the distribution `sorted` (in
/// increasing order) was drawn from, whatever that distribution: its `k`th smallest and `k`th
/// largest, `k` the largest with `P(B < k) <= 2.5%` for `B` binomial with `n` trials of
/// one half (the sign test's interval; Conover, "Practical Nonparametric Statistics", 3.2).
/// None below 6 samples, where even the extremes cover less.
pub fn median_interval(sorted: &[f64]) -> Option<(f64, f64)> {
    let n = sorted.len();
    // P(B = j) from ln C(n, j) - n ln 2, summed while the tail stays within 2.5%.
    let (mut ln_choose, mut tail, mut k) = (0.0f64, 0.0, 0);
    while k < n / 2 {
        let p = (ln_choose - n as f64 * std::f64::consts::LN_2).exp();
        if tail + p > 0.025 {
            break;
        }
        tail += p;
        k += 1;
        ln_choose += ((n + 1 - k) as f64 / k as f64).ln();
    }
    (k > 0).then(|| (sorted[k - 1], sorted[n - k]))
}

/// The geometric mean of the ratios.
pub fn geometric_mean(rows: &[Measured]) -> f64 {
    let logs: f64 = rows.iter().map(|m| m.ratio.ln()).sum();
    (logs / rows.len().max(1) as f64).exp()
}
