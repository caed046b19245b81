//! Cost curves (`hyperslice bench FILE --costs`): render time against image pixels, samples per
//! pixel, frames, worker threads and number of objects, each varied alone from a small base
//! setting (no denoiser), with the exponent of the power law `time ~ x^k` fitted to each curve.
//! Rendering is linear in pixels, samples and frames (`k = 1`) apart from fixed costs (compiling
//! each frame's tapes, starting the pool), which flatten the curve's small end; threads should
//! give `k = -1` up to the cores there are. Objects are not linear: the scene distance is a
//! minimum over every object, so each step of the marcher costs more with more objects, while
//! how many steps a ray takes depends on the layout.
//!
//! The object curve renders a generated scene (a floor, a lamp and `n` hyperspheres on a 4D
//! grid), since a user's scene has the objects it has; the other curves render the given scene.

use super::{median, sig};
use crate::Compilation;
use crate::error::Result;
use crate::render::driver::{Monitor, Options};
use crate::scene::{Denoise, Scene};
use std::fmt::Write as _;

/// What a cost curve varies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Knob {
    Pixels,
    Spp,
    Frames,
    Threads,
    Objects,
}

impl Knob {
    pub const ALL: [Knob; 5] = [
        Knob::Pixels,
        Knob::Spp,
        Knob::Frames,
        Knob::Threads,
        Knob::Objects,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Knob::Pixels => "pixels",
            Knob::Spp => "samples per pixel",
            Knob::Frames => "frames",
            Knob::Threads => "threads",
            Knob::Objects => "objects",
        }
    }
}

/// One measured point of a cost curve.
#[derive(Clone, Debug, PartialEq)]
pub struct CostPoint {
    pub knob: Knob,
    /// The knob's value.
    pub x: u64,
    /// Median wall time of the renders, in seconds.
    pub time: f64,
    /// Samples taken, and distance evaluations per sample (from the first render).
    pub samples: u64,
    pub evaluations_per_sample: f64,
}

/// The base setting every curve starts from, and how far each goes.
#[derive(Clone, Debug, PartialEq)]
pub struct CostOptions {
    /// Base image size; the pixel curve scales its area by 1, 4, 16 and 64 from a quarter side.
    pub size: (u32, u32),
    pub spp: u32,
    pub frames: u32,
    /// Values of each curve.
    pub spp_list: Vec<u32>,
    pub frame_list: Vec<u32>,
    pub thread_list: Vec<usize>,
    pub object_list: Vec<u32>,
    /// Renders per point (the median time is kept).
    pub repeats: u32,
    /// Threads of every curve but the thread curve (`None`: the scene's).
    pub threads: Option<usize>,
}

impl Default for CostOptions {
    fn default() -> Self {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        let mut thread_list: Vec<usize> = (0..)
            .map(|i| 1usize << i)
            .take_while(|&t| t < cores)
            .collect();
        thread_list.push(cores);
        CostOptions {
            size: (128, 96),
            spp: 4,
            frames: 2,
            spp_list: vec![1, 2, 4, 8, 16, 32],
            frame_list: vec![1, 2, 4, 8, 16],
            thread_list,
            object_list: vec![1, 4, 16, 64, 256],
            repeats: 5,
            threads: None,
        }
    }
}

impl CostOptions {
    /// Tiny curves for tests.
    pub fn quick() -> Self {
        CostOptions {
            size: (16, 12),
            spp: 1,
            frames: 1,
            spp_list: vec![1, 2],
            frame_list: vec![1, 2],
            thread_list: vec![1],
            object_list: vec![1, 2],
            repeats: 1,
            ..CostOptions::default()
        }
    }
}

/// A scene of a floor, a lamp and `n` unit-spaced hyperspheres of radius 0.3 filling a 4D grid
/// in front of the camera (side `ceil(n^(1/4))`).
pub fn objects_scene(n: u32) -> String {
    let side = (1..).find(|s: &u32| s.pow(4) >= n).unwrap_or(1);
    let mut src = String::from(
        "render { size = 64 x 48  spp = 4  frames = 1 }\n\
         camera { from = [0, 1.5, -6, 0] fov = 60deg }\n\
         object floor { shape = halfspace(offset: -1) material = diffuse(albedo: rgb(0.6)) }\n\
         object lamp { shape = hypersphere(0.5) |> translate([0, 5, -2, 0]) material = light(intensity: 200) }\n",
    );
    let c = (side as f64 - 1.0) / 2.0;
    for i in 0..n {
        let k = [
            i % side,
            i / side % side,
            i / side / side % side,
            i / side.pow(3),
        ];
        let p = k.map(|v| v as f64 - c);
        let _ = writeln!(
            src,
            "object s{i} {{ shape = hypersphere(0.3) |> translate([{}, {}, {}, {}]) material = diffuse(albedo: rgb(0.8)) }}",
            p[0],
            p[1] * 0.6,
            p[2],
            p[3] * 0.2
        );
    }
    src
}

/// What the cost curves are doing, for progress lines.
pub enum CostProgress<'a> {
    Start { knob: Knob, x: u64 },
    Done { point: &'a CostPoint },
}

/// Measure every curve over `scene` (its denoiser turned off).
pub fn cost_curves(
    scene: &Scene,
    opts: &CostOptions,
    progress: &mut dyn FnMut(CostProgress),
) -> Result<Vec<CostPoint>> {
    let mut base = scene.clone();
    let r = &mut base.render;
    (r.width, r.height) = opts.size;
    r.spp = opts.spp;
    r.frames = opts.frames;
    r.denoise = Denoise::None;
    let (w, h) = opts.size;
    let quarter = ((w / 4).max(1), (h / 4).max(1));
    let mut plan: Vec<(Knob, u64, Scene, Option<usize>)> = vec![];
    for f in [1, 2, 4, 8] {
        let mut s = base.clone();
        (s.render.width, s.render.height) = (quarter.0 * f, quarter.1 * f);
        let px = s.render.width as u64 * s.render.height as u64;
        plan.push((Knob::Pixels, px, s, opts.threads));
    }
    for &spp in &opts.spp_list {
        let mut s = base.clone();
        s.render.spp = spp;
        plan.push((Knob::Spp, spp as u64, s, opts.threads));
    }
    for &frames in &opts.frame_list {
        let mut s = base.clone();
        s.render.frames = frames;
        plan.push((Knob::Frames, frames as u64, s, opts.threads));
    }
    for &t in &opts.thread_list {
        plan.push((Knob::Threads, t as u64, base.clone(), Some(t)));
    }
    for &n in &opts.object_list {
        let c = Compilation::from_source("objects.4ds", &objects_scene(n));
        let mut s = c.into_scene_named(format!("the generated scene of {n} objects"))?;
        s.render = base.render.clone();
        plan.push((Knob::Objects, n as u64, s, opts.threads));
    }
    let mut out = Vec::with_capacity(plan.len());
    for (knob, x, scene, threads) in plan {
        progress(CostProgress::Start { knob, x });
        let options = Options {
            threads,
            ..Options::default()
        };
        let first = crate::render(&scene, &options, Monitor::SILENT)?;
        let mut times = vec![first.elapsed.as_secs_f64()];
        for _ in 1..opts.repeats {
            times.push(
                crate::render(&scene, &options, Monitor::SILENT)?
                    .elapsed
                    .as_secs_f64(),
            );
        }
        let samples = first.stats.samples;
        let point = CostPoint {
            knob,
            x,
            time: median(&mut times),
            samples,
            evaluations_per_sample: first.stats.evaluations as f64 / samples.max(1) as f64,
        };
        progress(CostProgress::Done { point: &point });
        out.push(point);
    }
    Ok(out)
}

/// The least-squares slope of log time against log x over a curve's points (`None` with fewer
/// than two distinct x).
pub fn exponent(points: &[&CostPoint]) -> Option<f64> {
    let pts: Vec<(f64, f64)> = points
        .iter()
        .filter(|p| p.x > 0 && p.time > 0.0)
        .map(|p| ((p.x as f64).ln(), p.time.ln()))
        .collect();
    slope(&pts)
}

/// The least-squares slope of `y` against `x` (`None` unless two `x` differ).
pub fn slope(points: &[(f64, f64)]) -> Option<f64> {
    let n = points.len() as f64;
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    (sxx > 0.0).then(|| points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>() / sxx)
}

/// The curves as Markdown: per knob, its points (time; the cost of a unit relative to the
/// first point, where a unit is one of `x` and for threads a thread's share, `time * x`; and
/// evaluations per sample) and the fitted exponent.
pub fn markdown(points: &[CostPoint]) -> String {
    let mut out = String::new();
    for knob in Knob::ALL {
        let curve: Vec<&CostPoint> = points.iter().filter(|p| p.knob == knob).collect();
        let Some(first) = curve.first() else { continue };
        let k = exponent(&curve).map_or("-".into(), |k| format!("{k:.2}"));
        let _ = writeln!(
            out,
            "\n**{}** (fitted exponent k = {k}):\n\n| {} | time (s) | {}, relative | evaluations per sample |\n|--:|--:|--:|--:|",
            knob.name(),
            knob.name(),
            if knob == Knob::Threads {
                "time x threads"
            } else {
                "time / x"
            }
        );
        let per_unit = |p: &CostPoint| {
            if knob == Knob::Threads {
                p.time * p.x as f64
            } else {
                p.time / p.x as f64
            }
        };
        for p in &curve {
            let _ = writeln!(
                out,
                "| {} | {} | {:.2} | {:.0} |",
                p.x,
                sig(p.time, 3),
                per_unit(p) / per_unit(first),
                p.evaluations_per_sample
            );
        }
    }
    out
}

/// The points as CSV.
pub fn csv(points: &[CostPoint]) -> String {
    let mut out = String::from("knob,x,time_s,samples,evaluations_per_sample\n");
    for p in points {
        let _ = writeln!(
            out,
            "{},{},{},{},{}",
            p.knob.name(),
            p.x,
            p.time,
            p.samples,
            p.evaluations_per_sample
        );
    }
    out
}
