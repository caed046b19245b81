//! `hyperslice render`: compile a scene, apply command-line overrides, render every frame with
//! a progress bar, and write the frames.

use clap::Args;
use hyperslice::Compilation;
use hyperslice::check::{Denoise, Quality, RenderSettings};
use hyperslice::output::{self, OutputSettings};
use hyperslice::render::driver::{self, Options};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Args)]
pub struct RenderArgs {
    /// The scene to render.
    file: PathBuf,
    /// Output file: .gif (one animated GIF), .png (numbered PNG frames) or .exr (numbered linear
    /// HDR frames). Default: the scene's name with .gif, in the current directory.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Image size, as WIDTHxHEIGHT (e.g. 160x120).
    #[arg(long, value_parser = parse_size)]
    size: Option<(u32, u32)>,
    /// Number of frames (t goes from 0 to 1 over them).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=10000))]
    frames: Option<u32>,
    /// Samples per pixel.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    spp: Option<u32>,
    /// Most bounces of one light path.
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=1000))]
    bounces: Option<u32>,
    /// Marching epsilon: how close to a surface counts as a hit, in (0, 1].
    #[arg(long, value_parser = parse_epsilon)]
    epsilon: Option<f64>,
    /// Most marching steps along one ray.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    max_steps: Option<u32>,
    /// Random seed.
    #[arg(long)]
    seed: Option<u64>,
    /// Worker threads (0: every core).
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=1024))]
    threads: Option<u32>,
    /// Quality preset: sets spp, bounces, epsilon and max steps (explicit flags win).
    #[arg(long)]
    quality: Option<QualityArg>,
    /// Brightness multiplier, in (0, 1000000].
    #[arg(long, value_parser = parse_positive)]
    exposure: Option<f64>,
    /// Frames per second of the animation, in (0, 100].
    #[arg(long, value_parser = parse_positive)]
    fps: Option<f64>,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum QualityArg {
    Draft,
    Preview,
    Final,
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let err = || format!("`{s}` is not a size; write WIDTHxHEIGHT, e.g. 160x120");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(err)?;
    let side = |v: &str| match v.trim().parse::<u32>() {
        Ok(n) if (1..=16384).contains(&n) => Ok(n),
        _ => Err(format!(
            "`{v}` is not a valid side; each side is a whole number in 1..=16384"
        )),
    };
    Ok((side(w)?, side(h)?))
}

fn parse_epsilon(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(x) if x > 0.0 && x <= 1.0 => Ok(x),
        _ => Err(format!("`{s}` is not in (0, 1]")),
    }
}

fn parse_positive(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(x) if x > 0.0 && x <= 1e6 && x.is_finite() => Ok(x),
        _ => Err(format!("`{s}` is not a positive number")),
    }
}

impl RenderArgs {
    /// Apply the overrides: the preset first, then explicit settings.
    fn apply(&self, r: &mut RenderSettings) {
        if let Some(q) = self.quality {
            match q {
                QualityArg::Draft => Quality::Draft,
                QualityArg::Preview => Quality::Preview,
                QualityArg::Final => Quality::Final,
            }
            .apply(r);
        }
        if let Some((w, h)) = self.size {
            (r.width, r.height) = (w, h);
        }
        macro_rules! set { ($($f:ident)*) => { $(if let Some(v) = self.$f { r.$f = v; })* } }
        set!(frames spp bounces epsilon max_steps seed threads exposure fps);
    }
}

pub fn run(args: RenderArgs, color: bool) -> ExitCode {
    let c = Compilation::from_path(&args.file);
    eprint!("{}", c.render_diagnostics(color));
    let Some(mut scene) = c.scene else {
        return ExitCode::FAILURE;
    };
    args.apply(&mut scene.render);
    let out = args
        .output
        .clone()
        .unwrap_or_else(|| default_output(&args.file));
    // Fail on an unwritable path before spending any time rendering.
    if let Err(e) = output::check_writable(&out, &args.file) {
        eprintln!("error: {e}");
        return ExitCode::FAILURE;
    }
    let r = &scene.render;
    if r.denoise != Denoise::None {
        eprintln!("note: denoising is not implemented yet; rendering without it");
    }
    eprintln!(
        "rendering {}: {} x {}, {} frame{}, {} spp, {} bounces",
        args.file.display(),
        r.width,
        r.height,
        r.frames,
        if r.frames == 1 { "" } else { "s" },
        r.spp,
        r.bounces
    );
    let total = driver::total_samples(&scene);
    let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template(
            "{bar:40} {percent:>3}% {elapsed_precise} eta {eta} {per_sec} samples",
        )
        .expect("a valid template"),
    );
    let options = Options {
        threads: (r.threads > 0).then_some(r.threads as usize),
        ..Options::default()
    };
    let rendered = match driver::render(&scene, &options, &|n| bar.inc(n)) {
        Ok(x) => x,
        Err(e) => {
            bar.finish_and_clear();
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    bar.finish_and_clear();
    let images: Vec<_> = rendered.frames.iter().map(|f| f.image()).collect();
    let settings = OutputSettings {
        exposure: r.exposure,
        fps: r.fps,
    };
    let written = match output::write(&out, &images, &settings) {
        Ok(w) => w,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let s = &rendered.stats;
    let secs = rendered.elapsed.as_secs_f64();
    eprintln!(
        "rendered in {secs:.2} s: {} samples ({:.0}/s), {} distance evaluations",
        s.samples,
        s.samples as f64 / secs.max(1e-9),
        s.evaluations
    );
    if s.out_of_steps > 0 {
        eprintln!(
            "warning: {} ray segment{} ran out of marching steps (max_steps {}); their paths were ended there",
            s.out_of_steps,
            if s.out_of_steps == 1 { "" } else { "s" },
            r.max_steps
        );
    }
    if s.dropped > 0 {
        eprintln!(
            "warning: {} sample{} came out NaN or infinite and {} dropped",
            s.dropped,
            if s.dropped == 1 { "" } else { "s" },
            if s.dropped == 1 { "was" } else { "were" }
        );
    }
    if let Some(psnr) = written.gif_psnr {
        eprintln!("GIF quantisation: PSNR {psnr:.1} dB against the 8-bit frames");
    }
    match written.files.as_slice() {
        [one] => eprintln!("wrote {}", one.display()),
        files => eprintln!(
            "wrote {} files: {} .. {}",
            files.len(),
            files[0].display(),
            files[files.len() - 1].display()
        ),
    }
    ExitCode::SUCCESS
}

fn default_output(scene: &Path) -> PathBuf {
    let stem = scene.file_stem().unwrap_or_default().to_string_lossy();
    PathBuf::from(format!("{stem}.gif"))
}
