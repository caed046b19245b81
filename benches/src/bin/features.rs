//! What a scene pays for features it does not use: each scene is rendered with the renderer
//! specialised to its features and with every feature's code path forced on (`general`),
//! alternating the two, and the median times are compared.
//!
//!     cargo run --release -p hyperslice-bench --bin features [-- --runs K SCENE...]

use clap::Parser;
use hyperslice::Compilation;
use hyperslice::{Monitor, RenderOptions as Options};
use std::path::PathBuf;
use std::time::Duration;

#[derive(Parser)]
struct Opts {
    /// Timed runs of each variant (after one warm-up each).
    #[arg(long, default_value_t = 5)]
    runs: usize,
    /// Image size override, WIDTHxHEIGHT.
    #[arg(long, default_value = "96x72")]
    size: String,
    /// Samples per pixel override.
    #[arg(long, default_value_t = 8)]
    spp: u32,
    /// Scenes to render (default: the examples without glass or fog).
    scenes: Vec<PathBuf>,
}

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v[v.len() / 2]
}

fn main() {
    let opts = Opts::parse();
    let scenes = if opts.scenes.is_empty() {
        ["d4_packing", "tesseract", "polytopes"]
            .map(|s| PathBuf::from(format!("examples/{s}.4ds")))
            .to_vec()
    } else {
        opts.scenes.clone()
    };
    let (w, h) = opts.size.split_once('x').expect("WIDTHxHEIGHT");
    println!(
        "features: {} runs, {} x {}, {} spp, 1 frame, 1 thread, load {}",
        opts.runs,
        w,
        h,
        opts.spp,
        std::fs::read_to_string("/proc/loadavg")
            .map(|s| s.split_whitespace().next().unwrap_or("?").to_string())
            .unwrap_or_else(|_| "?".into())
    );
    println!("| scene | specialised (ms) | general (ms) | general / specialised |");
    println!("|---|---|---|---|");
    for path in &scenes {
        let c = Compilation::from_path(path);
        let Some(mut scene) = c.scene else {
            eprintln!("{}", c.render_diagnostics(false));
            continue;
        };
        scene.render.width = w.parse().expect("width");
        scene.render.height = h.parse().expect("height");
        scene.render.spp = opts.spp;
        scene.render.frames = 1;
        let run = |general| {
            let options = Options {
                threads: Some(1),
                general,
                ..Options::default()
            };
            let r = hyperslice::render(&scene, &options, Monitor::SILENT).expect("render");
            (r.elapsed, r.frames)
        };
        let (_, a) = run(false);
        let (_, b) = run(true);
        assert_eq!(a, b, "both variants render the same image");
        let (mut fast, mut slow) = (vec![], vec![]);
        for _ in 0..opts.runs {
            fast.push(run(false).0);
            slow.push(run(true).0);
        }
        let (f, s) = (median(fast), median(slow));
        println!(
            "| {} | {:.1} | {:.1} | {:.2} |",
            path.display(),
            f.as_secs_f64() * 1e3,
            s.as_secs_f64() * 1e3,
            s.as_secs_f64() / f.as_secs_f64()
        );
    }
}
