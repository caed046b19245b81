//! `hyperslice render`: compile a scene, apply command-line overrides, render every frame with
//! a progress bar, and write the frames.

use clap::Args;
use hyperslice::output::{self, OutputSettings};
use hyperslice::render::driver::{self, Options};
use hyperslice::render::sampler::SamplerKind;
use hyperslice::scene::{Denoise, Quality, RenderSettings, Scene};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

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
    /// Denoising filter applied to the frames.
    #[arg(long)]
    denoise: Option<Denoise>,
    /// Render progressively and stop when this much time is spent (e.g. 30s, 2m, 500ms); `spp`
    /// becomes the most samples a pixel takes (default then 1000000).
    #[arg(long, value_parser = parse_duration)]
    time_budget: Option<Duration>,
    /// Adaptive sampling: a pixel stops once the standard error of its luminance is below this
    /// fraction of its mean (e.g. 0.02); `spp` is the most it takes.
    #[arg(long, value_parser = parse_fraction)]
    noise_threshold: Option<f64>,
    /// Next-event estimation towards spherical lights (with multiple importance sampling).
    #[arg(long, default_value = "on")]
    light_sampling: Switch,
    /// Where the random numbers come from: independent PCG streams, or an Owen-scrambled
    /// Sobol sequence per pixel.
    #[arg(long, value_enum, default_value_t)]
    sampler: SamplerKind,
    /// Re-check and re-render whenever the scene or a file it imports changes, printing
    /// diagnostics instead of stopping on errors. Renders at `--quality draft` unless a
    /// quality is given.
    #[arg(long)]
    watch: bool,
    #[command(flatten)]
    scene: crate::SceneArgs,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Switch {
    On,
    Off,
}

fn parse_duration(s: &str) -> Result<Duration, String> {
    let err = || format!("`{s}` is not a duration; write e.g. 30s, 2m or 500ms");
    let (number, unit) = s
        .find(|c: char| c.is_ascii_alphabetic())
        .map_or((s, "s"), |i| s.split_at(i));
    let x: f64 = number.trim().parse().map_err(|_| err())?;
    let seconds = match unit {
        "ms" => x / 1e3,
        "s" => x,
        "m" | "min" => x * 60.0,
        "h" => x * 3600.0,
        _ => return Err(err()),
    };
    if seconds.is_finite() && seconds > 0.0 && seconds < 1e7 {
        Ok(Duration::from_secs_f64(seconds))
    } else {
        Err(err())
    }
}

fn parse_fraction(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(x) if x > 0.0 && x < 1.0 => Ok(x),
        _ => Err(format!("`{s}` is not in (0, 1)")),
    }
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum QualityArg {
    Draft,
    Preview,
    Final,
}

/// `WIDTHxHEIGHT`, each side in 1..=16384 (also used by `bench --size`).
pub(crate) fn parse_size(s: &str) -> Result<(u32, u32), String> {
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
        if self.watch && self.quality.is_none() {
            Quality::Draft.apply(r);
        }
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
        if (self.time_budget.is_some() || self.noise_threshold.is_some()) && self.spp.is_none() {
            r.spp = 1_000_000;
        }
        macro_rules! set { ($($f:ident)*) => { $(if let Some(v) = self.$f { r.$f = v; })* } }
        set!(frames spp bounces epsilon max_steps seed threads exposure fps);
        if let Some(d) = self.denoise {
            r.denoise = d;
        }
    }
}

/// `W x H, N frames` of a render, for a command's first line.
pub(crate) fn extent(r: &RenderSettings) -> String {
    let plural = if r.frames == 1 { "" } else { "s" };
    format!("{} x {}, {} frame{plural}", r.width, r.height, r.frames)
}

pub fn run(args: RenderArgs, color: bool) -> ExitCode {
    if args.watch {
        return watch(&args, color);
    }
    match crate::compile(&args.file, &args.scene, color) {
        Some(scene) => crate::finish(render(&args, scene)),
        None => ExitCode::FAILURE,
    }
}

fn render(args: &RenderArgs, mut scene: Scene) -> hyperslice::error::Result<()> {
    args.apply(&mut scene.render);
    let out = args
        .output
        .clone()
        .unwrap_or_else(|| default_output(&args.file));
    // Fail on an unwritable path before spending any time rendering.
    output::check_writable(&out, &args.file)?;
    let r = &scene.render;
    eprintln!(
        "rendering {}: {}, {} spp, {} bounces",
        args.file.display(),
        extent(r),
        r.spp,
        r.bounces
    );
    // A progressive render's length is its time budget, or unknown: the bar then shows the
    // samples taken and their rate.
    let bar = if args.time_budget.is_some() || args.noise_threshold.is_some() {
        let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
        bar.set_style(
            ProgressStyle::with_template("{spinner} {elapsed_precise} {pos} samples, {per_sec}")
                .expect("a valid template"),
        );
        bar
    } else {
        let total = driver::total_samples(&scene);
        let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
        bar.set_style(
            ProgressStyle::with_template(
                "{bar:40} {percent:>3}% {elapsed_precise} eta {eta} {per_sec} samples",
            )
            .expect("a valid template"),
        );
        bar
    };
    let options = Options {
        threads: (r.threads > 0).then_some(r.threads as usize),
        light_sampling: args.light_sampling == Switch::On,
        sampler: args.sampler,
        time_budget: args.time_budget,
        noise_threshold: args.noise_threshold,
        ..Options::default()
    };
    let rendered = driver::render(&scene, &options, &|n| bar.inc(n));
    bar.finish_and_clear();
    let rendered = rendered?;
    let images: Vec<_> = rendered.frames.iter().map(|f| f.image()).collect();
    let settings = OutputSettings {
        exposure: r.exposure,
        fps: r.fps,
    };
    let written = output::write(&out, &images, &settings)?;
    let s = &rendered.stats;
    let secs = rendered.elapsed.as_secs_f64();
    let pixels = r.width as f64 * r.height as f64 * r.frames as f64;
    eprintln!(
        "rendered in {secs:.2} s: {} samples ({:.0}/s, {:.1} per pixel), {} distance evaluations",
        s.samples,
        s.samples as f64 / secs.max(1e-9),
        s.samples as f64 / pixels,
        s.evaluations
    );
    if r.denoise != Denoise::None {
        eprintln!(
            "denoised ({}) in {:.2} s",
            r.denoise.name(),
            rendered.denoise_time.as_secs_f64()
        );
    }
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
    if args.scene.message_format == crate::MessageFormat::Json {
        let stats = serde_json::json!({
            "type": "render-stats",
            "file": args.file.display().to_string(),
            "width": r.width,
            "height": r.height,
            "frames": r.frames,
            "spp": r.spp,
            "seconds": secs,
            "samples": s.samples,
            "samples_per_second": s.samples as f64 / secs.max(1e-9),
            "samples_per_pixel": s.samples as f64 / pixels,
            "distance_evaluations": s.evaluations,
            "out_of_steps": s.out_of_steps,
            "dropped": s.dropped,
            "denoise": r.denoise.name(),
            "denoise_seconds": rendered.denoise_time.as_secs_f64(),
            "gif_psnr": written.gif_psnr,
            "files": written.files.iter().map(|f| f.display().to_string()).collect::<Vec<_>>(),
        });
        println!("{stats}");
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
    Ok(())
}

/// `render --watch`: check and render, then wait for a change to any file the scene was read
/// from, and again. Errors are printed and waited out; only a broken watcher ends it.
fn watch(args: &RenderArgs, color: bool) -> ExitCode {
    use notify::Watcher;
    let (tx, rx) = std::sync::mpsc::channel();
    let mut watcher = match notify::recommended_watcher(tx) {
        Ok(w) => w,
        Err(e) => {
            eprintln!("error: cannot watch files: {e}");
            return ExitCode::FAILURE;
        }
    };
    let canon = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
    loop {
        let c = args.scene.compile(&args.file);
        args.scene.report(&c, color);
        if let Some(scene) = c.scene.clone().filter(|_| !c.has_errors())
            && let Err(e) = render(args, scene)
        {
            eprintln!("error: {e}");
        }
        // The scene and its imports; their folders are watched, since editors often save by
        // replacing a file.
        let mut files: Vec<PathBuf> = (c.sources.files())
            .filter_map(|(_, f)| f.path.as_deref().map(canon))
            .collect();
        files.push(canon(&args.file));
        files.sort();
        files.dedup();
        let dirs: std::collections::BTreeSet<PathBuf> = (files.iter())
            .filter_map(|f| f.parent().map(Path::to_path_buf))
            .collect();
        for d in &dirs {
            if let Err(e) = watcher.watch(d, notify::RecursiveMode::NonRecursive) {
                eprintln!("error: cannot watch `{}`: {e}", d.display());
                return ExitCode::FAILURE;
            }
        }
        eprintln!(
            "watching {} file{} for changes (Ctrl-C stops)",
            files.len(),
            if files.len() == 1 { "" } else { "s" }
        );
        loop {
            match rx.recv() {
                Ok(Ok(event))
                    if !event.kind.is_access()
                        && event.paths.iter().any(|p| files.contains(&canon(p))) =>
                {
                    break;
                }
                Ok(_) => {}
                Err(_) => return ExitCode::FAILURE,
            }
        }
        // One save is often several events: let them settle.
        std::thread::sleep(Duration::from_millis(150));
        while rx.try_recv().is_ok() {}
        for d in &dirs {
            let _ = watcher.unwatch(d);
        }
        eprintln!("changed; checking again");
    }
}

fn default_output(scene: &Path) -> PathBuf {
    let stem = scene.file_stem().unwrap_or_default().to_string_lossy();
    PathBuf::from(format!("{stem}.gif"))
}
