//! The marcher corpus (`hyperslice bench --marcher-corpus`): the default marcher against the
//! plain one (`--marcher plain`, whole-tape sphere tracing in the same binary), in wall clock,
//! paired and alternating, on scenes wider than the examples: the five examples, sphere unions
//! of 16 and 1024, a custom `sdf` field of 625 spheres, a grid tiling, a room of rounded boxes,
//! a turned slab, and generated scenes (`crate::generate`). Each scene's ratio is the median
//! time of the default over the median of plain; a ratio above 1 means the default marcher is
//! slower there.

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

const FILES: [FileEntry; 11] = [
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

/// One scene's figures: median seconds with each marcher, and segments out of steps.
#[derive(Clone, Debug)]
pub struct Measured {
    pub name: String,
    pub default_s: f64,
    pub plain_s: f64,
    pub default_out_of_steps: u64,
    pub plain_out_of_steps: u64,
    /// What the default marcher chose for the first frame, and why.
    pub choice: Choice,
}

impl Measured {
    /// Default over plain.
    pub fn ratio(&self) -> f64 {
        self.default_s / self.plain_s
    }
}

/// Render `scene` `runs` times with each marcher, alternating (default first), on `threads`.
pub fn measure(name: &str, scene: &Scene, runs: u32, threads: Option<usize>) -> Result<Measured> {
    let mut times = [vec![], vec![]];
    let mut out_of_steps = [0, 0];
    for _ in 0..runs {
        for (i, marcher) in [MarcherKind::Auto, MarcherKind::Plain]
            .into_iter()
            .enumerate()
        {
            let options = Options {
                threads,
                marcher,
                ..Options::default()
            };
            let rendered = crate::render(scene, &options, Monitor::SILENT)?;
            times[i].push(rendered.elapsed.as_secs_f64());
            out_of_steps[i] = rendered.stats.out_of_steps;
        }
    }
    let first = Frames::new(scene).at(0.0, Build::marcher(MarcherKind::Auto));
    Ok(Measured {
        choice: first.probe.expect("the default marcher probes").choice(),
        name: name.to_string(),
        default_s: median(&mut times[0]),
        plain_s: median(&mut times[1]),
        default_out_of_steps: out_of_steps[0],
        plain_out_of_steps: out_of_steps[1],
    })
}

/// The geometric mean of the ratios.
pub fn geometric_mean(rows: &[Measured]) -> f64 {
    let logs: f64 = rows.iter().map(|m| m.ratio().ln()).sum();
    (logs / rows.len().max(1) as f64).exp()
}
