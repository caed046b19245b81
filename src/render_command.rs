//! `hyperslice render`: compile a scene, apply command-line overrides, render every frame with
//! a progress bar, and write the frames.

use clap::Args;
use hyperslice::output;
use hyperslice::render::driver::{self, Options};
use hyperslice::render::march::MarcherKind;
use hyperslice::render::sampler::SamplerKind;
use hyperslice::scene::{Denoise, Quality, RenderSettings, Scene};
use indicatif::HumanCount;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::OnceLock;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

#[derive(Args)]
pub struct RenderArgs {
    /// The scene to render.
    file: PathBuf,
    /// Output file: .gif (one animated GIF), .png (numbered PNG frames) or .exr (numbered linear
    /// HDR frames). Default: the scene's name with .gif, in the current directory.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Image size, as WIDTHxHEIGHT (e.g. 160x120).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_size)]
    size: Option<(u32, u32)>,
    /// Number of frames (t goes from 0 to 1 over them).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_frames)]
    frames: Option<u32>,
    /// Samples per pixel.
    #[arg(long, allow_hyphen_values = true, value_parser = parse_spp)]
    spp: Option<u32>,
    /// Most bounces of one light path.
    #[arg(long, allow_hyphen_values = true, value_parser = parse_bounces)]
    bounces: Option<u32>,
    /// Marching epsilon: how close to a surface counts as a hit, in (0, 1].
    #[arg(long, allow_hyphen_values = true, value_parser = parse_epsilon)]
    epsilon: Option<f64>,
    /// Most marching steps along one ray.
    #[arg(long, allow_hyphen_values = true, value_parser = parse_max_steps)]
    max_steps: Option<u32>,
    /// Random seed, from 0 to 2^53.
    #[arg(long, allow_hyphen_values = true, value_parser = parse_seed)]
    seed: Option<u64>,
    /// Worker threads (0: every core).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_threads)]
    threads: Option<u32>,
    /// Quality preset: sets spp, bounces, epsilon and max steps (explicit flags win).
    #[arg(long)]
    quality: Option<QualityArg>,
    /// Brightness multiplier, in (0, 1000000].
    #[arg(long, allow_hyphen_values = true, value_parser = parse_exposure)]
    exposure: Option<f64>,
    /// Frames per second of the animation, in (0, 100].
    #[arg(long, allow_hyphen_values = true, value_parser = parse_fps)]
    fps: Option<f64>,
    /// Denoising filter applied to the frames.
    #[arg(long)]
    denoise: Option<DenoiseArg>,
    /// Render progressively within this much time for the whole run, denoising and encoding
    /// included (e.g. 30s, 2m, 500ms); every pixel takes at least one sample. `spp` becomes the
    /// most samples a pixel takes (default then 1000000).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_duration)]
    time_budget: Option<Duration>,
    /// Adaptive sampling: a pixel stops once the standard error of its luminance is below this
    /// fraction of its mean (e.g. 0.02); `spp` is the most it takes.
    #[arg(long, allow_hyphen_values = true, value_parser = parse_fraction)]
    noise_threshold: Option<f64>,
    /// Next-event estimation towards spherical lights (with multiple importance sampling).
    #[arg(long, default_value = "on")]
    light_sampling: Switch,
    /// Where the random numbers come from: independent PCG streams, or an Owen-scrambled
    /// Sobol sequence per pixel.
    #[arg(long, value_enum, default_value = SamplerKind::default().name())]
    sampler: SamplerArg,
    /// How rays are marched: through the frame's pruned cells where a probe of rays shows that
    /// they pay (auto), through them always (cells), or plainly on the whole scene tape
    /// (plain: the baseline the others are measured against).
    #[arg(long, value_enum, default_value = MarcherKind::default().name())]
    marcher: MarcherArg,
    /// Render only frame N of the scene's animation (0-based; `t` as in the whole animation).
    /// The file gets the frame's own number, e.g. out_0012.png.
    #[arg(long, value_name = "N", conflicts_with = "frame_range", allow_hyphen_values = true, value_parser = parse_frame)]
    frame: Option<u32>,
    /// Render only frames A..B (half-open, 0-based; A..=B includes B) of the animation, each
    /// identical to the same frame of a whole render and numbered as in it.
    #[arg(long, value_name = "A..B", value_parser = parse_frame_range)]
    frame_range: Option<FrameRange>,
    /// Keep the films (each frame's linear accumulation, multi-layer EXR) in DIR. An
    /// interrupted render run again with the same DIR resumes where it stopped. Without it,
    /// the films live in a hidden directory beside the output until the output is written.
    #[arg(long, value_name = "DIR")]
    films: Option<PathBuf>,
    /// Render the K-th (0-based) of N parts of the work into --films DIR, for several machines:
    /// whole frames when there are at least N frames, otherwise sample ranges of every frame.
    /// `hyperslice merge` puts the parts' films together.
    #[arg(long, value_name = "K/N", value_parser = parse_shard, requires = "films")]
    shard: Option<(u32, u32)>,
    /// Discard the films an earlier, interrupted render of this output (or this part of the
    /// --films DIR) left, instead of resuming from them. Without it, films of other settings
    /// are refused, never thrown away.
    #[arg(long)]
    restart: bool,
    /// Remove numbered frames (out_0042.png) beyond the animation's last frame that an earlier,
    /// longer render left beside the output (without it they are only reported).
    #[arg(long)]
    remove_stale: bool,
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

/// A duration with its unit: `30s`, `2m`, `500ms`, `1.5h`. A bare number is refused, since
/// whether `5` means seconds or minutes would be a guess.
fn parse_duration(s: &str) -> Result<Duration, String> {
    let err = || format!("`{s}` is not a duration; write e.g. 30s, 2m or 500ms");
    let t = s.trim();
    // The unit is the letters at the end, so that `1e3s` is a thousand seconds.
    let i = t.trim_end_matches(|c: char| c.is_ascii_alphabetic()).len();
    if i == t.len() {
        return Err(match t.parse::<f64>() {
            Ok(_) => format!("`{s}` has no unit; write {t}s for seconds (or {t}m, {t}ms)"),
            Err(_) => err(),
        });
    }
    let (number, unit) = t.split_at(i);
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
        Err(format!(
            "`{s}` is out of range: a duration must be more than 0s and less than 10000000s"
        ))
    }
}

/// The flags of the render settings take the ranges the scene's `render` block takes.
macro_rules! setting_flags {
    ($($f:ident: $t:ty = $range:ident,)*) => {$(
        pub(crate) fn $f(s: &str) -> Result<$t, String> {
            hyperslice::scene::ranges::$range.parse(s).map(|x| x as $t)
        }
    )*};
}

setting_flags! {
    parse_frames: u32 = FRAMES,
    parse_spp: u32 = SPP,
    parse_bounces: u32 = BOUNCES,
    parse_max_steps: u32 = MAX_STEPS,
    parse_seed: u64 = SEED,
    parse_threads: u32 = THREADS,
    parse_epsilon: f64 = EPSILON,
    parse_fps: f64 = FPS,
    parse_exposure: f64 = EXPOSURE,
    parse_frame: u32 = FRAME,
}

/// `A..B`, `A..=B` or `A..` (to the last frame).
/// `--frame-range`: the frames, and the text as written, for messages.
#[derive(Clone)]
struct FrameRange {
    start: u32,
    /// Excluded; `None` to the last frame.
    end: Option<u32>,
    text: String,
}

fn parse_frame_range(s: &str) -> Result<FrameRange, String> {
    let (start, end) = parse_range(s)?;
    Ok(FrameRange {
        start,
        end,
        text: s.trim().to_string(),
    })
}

fn parse_range(s: &str) -> Result<(u32, Option<u32>), String> {
    let err = || format!("`{s}` is not a frame range; write A..B (B excluded) or A..=B");
    let (a, b, inclusive) = if let Some((a, b)) = s.split_once("..=") {
        (a, b, true)
    } else if let Some((a, b)) = s.split_once("..") {
        (a, b, false)
    } else {
        return Err(err());
    };
    let a: u32 = a.trim().parse().map_err(|_| err())?;
    let b: Option<u32> = match b.trim() {
        "" if !inclusive => None,
        b => Some(
            (b.parse::<u32>().map_err(|_| err())?)
                .checked_add(inclusive as u32)
                .ok_or_else(err)?,
        ),
    };
    if b.is_some_and(|b| b <= a) {
        return Err(format!("`{s}` holds no frames"));
    }
    Ok((a, b))
}

/// `K/N` with `K < N`.
fn parse_shard(s: &str) -> Result<(u32, u32), String> {
    let err = || format!("`{s}` is not a shard; write K/N with 0 <= K < N, e.g. 2/8");
    let (k, n) = s.split_once('/').ok_or_else(err)?;
    let k: u32 = k.trim().parse().map_err(|_| err())?;
    let n: u32 = n.trim().parse().map_err(|_| err())?;
    if n == 0 || k >= n || n > 100_000 {
        return Err(err());
    }
    Ok((k, n))
}

fn parse_fraction(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(x) if x > 0.0 && x < 1.0 => Ok(x),
        Ok(x) if x.is_finite() => Err(format!(
            "`{s}` is out of range: the noise threshold must be a number in (0, 1)"
        )),
        _ => Err(format!(
            "`{s}` is not a number: the noise threshold must be a number in (0, 1)"
        )),
    }
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum QualityArg {
    Draft,
    Preview,
    Final,
}

// The library's enums know nothing of clap: these stand for them on the command line, each
// value with the help it shows there.

#[derive(Clone, Copy, clap::ValueEnum)]
enum DenoiseArg {
    /// Leave every colour bit-identical.
    None,
    /// Median over 3x3 pixels times 3 frames, per channel (biased dark on skewed noise).
    Median,
    /// Edge-avoiding spatio-temporal a-trous wavelet filter, guided by albedo, 4D normal and
    /// 4D position, with colour weights relative to each pixel's standard error.
    Atrous,
}

impl From<DenoiseArg> for Denoise {
    fn from(d: DenoiseArg) -> Denoise {
        match d {
            DenoiseArg::None => Denoise::None,
            DenoiseArg::Median => Denoise::Median,
            DenoiseArg::Atrous => Denoise::Atrous,
        }
    }
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum SamplerArg {
    /// Independent uniform numbers (PCG32), one stream per sample.
    Random,
    /// Owen-scrambled Sobol points, one sequence per pixel, with PCG32 beyond its range (the
    /// default: it measured 1.0 to 3.1 dB higher PSNR at 16 spp on every example scene, see
    /// `docs/performance.md`).
    Sobol,
}

impl From<SamplerArg> for SamplerKind {
    fn from(s: SamplerArg) -> SamplerKind {
        match s {
            SamplerArg::Random => SamplerKind::Random,
            SamplerArg::Sobol => SamplerKind::Sobol,
        }
    }
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum MarcherArg {
    /// Through the frame's cells where a probe of at most about 1,700 rays shows that they pay,
    /// on the whole tape (as `whole`) where they do not (the default).
    Auto,
    /// Through the frame's pruned cells, with over-relaxed steps and exact planes and spheres,
    /// whether or not they pay.
    Cells,
    /// Over-relaxed sphere tracing on the whole scene tape: no cells, no exact shortcuts.
    Whole,
    /// Plain sphere tracing on the whole scene tape: no cells, no relaxation, no exact
    /// shortcuts. The in-process baseline for measurements and tests.
    Plain,
}

impl From<MarcherArg> for MarcherKind {
    fn from(m: MarcherArg) -> MarcherKind {
        match m {
            MarcherArg::Auto => MarcherKind::Auto,
            MarcherArg::Cells => MarcherKind::Cells,
            MarcherArg::Whole => MarcherKind::Whole,
            MarcherArg::Plain => MarcherKind::Plain,
        }
    }
}

/// `WIDTHxHEIGHT`, each side in 1..=16384 (also used by `bench --size`).
pub(crate) fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let err = || format!("`{s}` is not a size; write WIDTHxHEIGHT, e.g. 160x120");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(err)?;
    let side = |v: &str| hyperslice::scene::ranges::SIDE.parse(v).map(|x| x as u32);
    Ok((side(w)?, side(h)?))
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
            r.denoise = d.into();
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

/// Set by SIGINT or SIGTERM; a second signal exits at once.
fn interrupted() -> &'static AtomicBool {
    static FLAG: AtomicBool = AtomicBool::new(false);
    static HANDLER: OnceLock<()> = OnceLock::new();
    HANDLER.get_or_init(|| {
        let installed = ctrlc::set_handler(|| {
            if FLAG.swap(true, Ordering::SeqCst) {
                eprintln!("\ninterrupted again: stopping now");
                std::process::exit(130);
            }
            eprintln!("\ninterrupted: saving the work in flight (interrupt again to stop at once)");
        });
        if let Err(e) = installed {
            eprintln!("warning: cannot catch interrupts ({e}); an interrupted render keeps only finished frames");
        }
    });
    &FLAG
}

/// Refuse a render whose frames in flight (or, when `finishing`, whose denoising of `frames`
/// frames) need more memory than the machine has available, before anything is written: it
/// would otherwise abort part-way with a failed allocation.
fn refuse_what_memory_cannot_hold(
    r: &RenderSettings,
    units: &[driver::Unit],
    finishing: bool,
    frames: usize,
) -> hyperslice::error::Result<()> {
    use hyperslice::farm::memory;
    let threads = match r.threads {
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
        n => n as usize,
    };
    let in_flight = threads.min(driver::FRAME_GROUP).min(units.len()).max(1);
    let finish = finishing.then_some((r.denoise, frames));
    let needed = memory::needed(r.width, r.height, in_flight, finish);
    let (available, known) = match memory::available() {
        Some(a) => (a, true),
        None => (memory::UNKNOWN_AVAILABLE, false),
    };
    if needed <= available {
        return Ok(());
    }
    let per_pixel = needed as f64 / (r.width as f64 * r.height as f64) / 1000.0;
    let more = if in_flight > 1 || frames > 1 {
        ", or hold fewer frames at once with --threads 1 or --frame-range"
    } else {
        ""
    };
    Err(hyperslice::Error::Usage(format!(
        "a {} x {} render needs about {} of memory ({per_pixel:.2} KB a pixel), but {} {}; make the image smaller with --size{more}",
        r.width,
        r.height,
        memory::human(needed),
        memory::human(available),
        if known {
            "is available"
        } else {
            "is the most assumed when the memory available is unknown"
        },
    )))
}

/// `--restart`: remove the films of `units` (the whole folder when it is the hidden one).
fn discard_films(
    films: &hyperslice::farm::films::FilmDir,
    units: &[driver::Unit],
    hidden: bool,
) -> hyperslice::error::Result<()> {
    let gone = |r: std::io::Result<()>| match r {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(e),
        _ => Ok(()),
    };
    let removed = if hidden {
        gone(std::fs::remove_dir_all(films.dir()))
    } else {
        units
            .iter()
            .try_for_each(|u| gone(std::fs::remove_file(films.path_of(u))))
    };
    removed.map_err(|source| hyperslice::Error::RemoveFilms {
        path: films.dir().to_path_buf(),
        source,
    })
}

/// Frames as `--frame-range` takes them, the last included: `0..=6`, or `7..` when none.
fn frame_span(frames: &std::ops::Range<u32>) -> String {
    if frames.is_empty() {
        format!("{}..", frames.start)
    } else {
        format!("{}..={}", frames.start, frames.end - 1)
    }
}

/// `495,370 samples/s`: the progress bar's rate of `n` samples in `secs` seconds.
fn sample_rate(n: u64, secs: f64) -> String {
    format!(
        "{} samples/s",
        HumanCount((n as f64 / secs.max(1e-9)) as u64)
    )
}

/// The hidden film directory beside `out` for a render without `--films`.
fn hidden_films(out: &Path) -> PathBuf {
    let name = out.file_name().unwrap_or_default().to_string_lossy();
    out.with_file_name(format!(".{name}.films"))
}

fn plural(n: usize, one: &str) -> String {
    format!("{n} {one}{}", if n == 1 { "" } else { "s" })
}

fn render(args: &RenderArgs, mut scene: Scene) -> hyperslice::error::Result<()> {
    use hyperslice::error::Error;
    use hyperslice::farm::{assemble, films::FilmDir, plan::Part};
    args.apply(&mut scene.render);
    let out = args
        .output
        .clone()
        .unwrap_or_else(|| default_output(&args.file));
    // Fail on an unwritable path before spending any time rendering.
    output::check_writable(&out, &args.file)?;
    let r = &scene.render;
    let frames = match (args.frame, &args.frame_range) {
        (Some(f), _) => f..f.saturating_add(1),
        (None, Some(range)) => range.start..range.end.unwrap_or(r.frames),
        (None, None) => 0..r.frames,
    };
    // The frames as the user gave them.
    let asked = match &args.frame_range {
        Some(range) => range.text.clone(),
        None => frame_span(&frames),
    };
    if let Some(f) = args.frame
        && f >= r.frames
    {
        return Err(Error::Usage(format!(
            "frame {f} is not in the animation: it has {} (0..{}); set `frames` in the scene or --frames to render more",
            plural(r.frames as usize, "frame"),
            r.frames
        )));
    }
    if frames.end > r.frames || frames.is_empty() {
        return Err(Error::Usage(format!(
            "frames {} are not all in the animation: it has {} ({}); set `frames` in the scene or --frames to render more",
            asked,
            plural(r.frames as usize, "frame"),
            frame_span(&(0..r.frames))
        )));
    }
    let shard = args.shard.unwrap_or((0, 1));
    let part = Part::new(frames.clone(), shard);
    let progressive = args.time_budget.is_some() || args.noise_threshold.is_some();
    if shard.1 > 1 && !part.splits_frames() && progressive {
        return Err(Error::Usage(format!(
            "{} frames cannot be split {} ways by samples with --time-budget or --noise-threshold, which decide per pixel how many samples to take; give at least {} frames or a fixed spp",
            frames.len(),
            shard.1,
            shard.1
        )));
    }
    // The budget is for the whole run: what finishing the frames will take is kept back.
    let finishing = (args.time_budget.is_some() && shard.1 == 1)
        .then(|| assemble::finishing_time(r, frames.len(), &out))
        .transpose()?
        .unwrap_or_default();
    let options = Options {
        threads: (r.threads > 0).then_some(r.threads as usize),
        light_sampling: args.light_sampling == Switch::On,
        sampler: args.sampler.into(),
        marcher: args.marcher.into(),
        time_budget: args.time_budget.map(|b| b.saturating_sub(finishing)),
        noise_threshold: args.noise_threshold,
        ..Options::default()
    };
    let units = part.units(r.spp);
    refuse_what_memory_cannot_hold(r, &units, shard.1 == 1, frames.len())?;
    let dir = args.films.clone().unwrap_or_else(|| hidden_films(&out));
    let name = args.file.file_name().unwrap_or_default().to_string_lossy();
    let films = FilmDir::open(&dir, &scene, &name, &options, part)?;
    if args.restart {
        discard_films(&films, &units, args.films.is_none())?;
    }
    if shard.1 > 1 {
        // Another shard's films of other settings would only be refused at `merge`.
        films.check_shards(&units)?;
    }
    let earlier = match films.survey(&units) {
        // `--watch` re-renders a draft on every change: its own hidden films of the scene
        // before the change are of no use.
        Err(Error::FilmMismatch { .. }) if args.watch && args.films.is_none() => {
            discard_films(&films, &units, true)?;
            films.survey(&units)?
        }
        // Films of other settings: the work of an earlier run, kept unless asked.
        Err(Error::FilmMismatch { ours, theirs, path }) => {
            return Err(Error::Usage(format!(
                "{} holds the films of another scene or other settings: they have `{theirs}` where this render has `{ours}` (in {}); \
                 run with the same settings to resume or reuse them, or pass --restart to discard them{}",
                dir.display(),
                path.file_name().unwrap_or_default().to_string_lossy(),
                if args.films.is_some() {
                    " (or render into another --films directory)"
                } else {
                    " (or move the folder aside to keep it)"
                }
            )));
        }
        other => other?,
    };
    eprintln!(
        "rendering {}: {} x {}, {}{}{}, {} spp, {} bounces",
        args.file.display(),
        r.width,
        r.height,
        if frames == (0..r.frames) {
            plural(r.frames as usize, "frame")
        } else {
            format!("frames {asked} of {}", r.frames)
        },
        if shard.1 > 1 {
            format!(", shard {}/{}", shard.0, shard.1)
        } else {
            String::new()
        },
        if shard.1 > 1 && !part.splits_frames() {
            units.first().map_or(" (no samples)".to_string(), |u| {
                format!(" (samples {}..{})", u.samples.start, u.samples.end)
            })
        } else {
            String::new()
        },
        r.spp,
        r.bounces
    );
    if earlier.complete + earlier.partial > 0 {
        eprintln!(
            "resuming from {}: {} of {} finished, {} part-done",
            dir.display(),
            earlier.complete,
            plural(units.len(), "frame"),
            earlier.partial
        );
    }
    let todo: Vec<_> = units
        .iter()
        .filter(|u| !earlier.finished.contains(u))
        .cloned()
        .collect();
    let total: u64 = (todo.iter())
        .map(|u| r.width as u64 * r.height as u64 * u.samples.len() as u64)
        .sum::<u64>()
        .saturating_sub(earlier.samples);
    // A progressive render's length is its time budget, or unknown: the bar then shows the
    // samples taken and their rate.
    let bar = if progressive {
        let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
        bar.set_style(
            ProgressStyle::with_template("{spinner} {elapsed_precise} {human_pos} samples, {msg}")
                .expect("a valid template"),
        );
        bar
    } else {
        let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
        bar.set_style(
            ProgressStyle::with_template(
                "{bar:40} {percent:>3}% {elapsed_precise} eta {eta} {msg}",
            )
            .expect("a valid template"),
        );
        bar
    };
    let started = Instant::now();
    let rate = |n: u64| sample_rate(n, started.elapsed().as_secs_f64());
    let per_frame = (r.width as u64 * r.height as u64 * part_samples(&units)).max(1);
    let before = earlier.complete;
    let progress = |n: u64| {
        bar.inc(n);
        if progressive {
            bar.set_message(rate(bar.position()));
        } else {
            let done = (before + (bar.position() / per_frame) as usize).min(units.len());
            bar.set_message(format!(
                "{done}/{} frames, {}",
                units.len(),
                rate(bar.position())
            ));
        }
    };
    let monitor = driver::Monitor {
        progress: &progress,
        cancel: Some(interrupted()),
    };
    let rendered = driver::render_units(&scene, &options, &todo, &films, monitor);
    bar.finish_and_clear();
    let render_secs = started.elapsed().as_secs_f64();
    let this_run = match rendered {
        Err(Error::Cancelled) => {
            let after = films.survey(&units)?;
            eprintln!(
                "interrupted after {render_secs:.1} s: {} of {} finished and {} part-done kept in {}",
                after.complete,
                plural(units.len(), "frame"),
                after.partial,
                dir.display()
            );
            eprintln!("  run the same command again to resume where it stopped");
            return Err(Error::Cancelled);
        }
        Err(e) => return Err(e),
        Ok(stats) => stats,
    };
    if shard.1 > 1 {
        eprintln!(
            "rendered shard {}/{} in {render_secs:.2} s into {}",
            shard.0,
            shard.1,
            dir.display()
        );
        eprintln!(
            "  when all {} shards are done: hyperslice merge {} -o {}",
            shard.1,
            dir.display(),
            out.display()
        );
        return Ok(());
    }
    let set = assemble::Films::of_units(&dir, &units, r.spp)?;
    let finish_start = Instant::now();
    eprintln!(
        "{} {}",
        if r.denoise == Denoise::None {
            "encoding"
        } else {
            "denoising and encoding"
        },
        plural(units.len(), "frame")
    );
    let finish = assemble::Finish::of_render(r);
    let bar = ProgressBar::with_draw_target(Some(units.len() as u64), ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} frames {elapsed_precise} eta {eta}")
            .expect("a valid template"),
    );
    let monitor = driver::Monitor {
        progress: &|n| bar.inc(n),
        cancel: Some(interrupted()),
    };
    let written = assemble::assemble(&set, &finish, &out, monitor);
    bar.finish_and_clear();
    if let Err(Error::Cancelled) = written {
        eprintln!(
            "interrupted while finishing: every frame's film is kept in {}\n  run the same command again to finish",
            dir.display()
        );
    }
    let written = written?;
    let finish_secs = finish_start.elapsed().as_secs_f64();
    let stale: Vec<PathBuf> = output::stale_frames(&out, &written.files)
        .into_iter()
        .filter(|p| frame_number(p).is_some_and(|n| n >= r.frames))
        .collect();
    if args.films.is_none() {
        // The output is written; the hidden films have served.
        match std::fs::remove_dir_all(&dir) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                return Err(Error::RemoveFilms {
                    path: dir.clone(),
                    source: e,
                });
            }
            _ => {}
        }
    }
    let times = Times {
        render_secs,
        finish_secs,
        samples: this_run.samples,
        frames: units.len(),
    };
    summary(args, &scene, &set.stats, &times, &written);
    if let Some(budget) = args.time_budget
        && started.elapsed() > budget
    {
        eprintln!(
            "warning: the time budget of {:.1} s is too short for one sample per pixel of every frame; the run took {:.1} s\n  hint: a smaller --size, fewer frames, or a longer budget",
            budget.as_secs_f64(),
            started.elapsed().as_secs_f64()
        );
    }
    report_stale(&stale, args.remove_stale, r.frames)
}

/// Say which files were written.
fn report_written(written: &output::Written) {
    match written.files.as_slice() {
        [] => {}
        [one] => eprintln!("wrote {}", one.display()),
        [first, .., last] => eprintln!(
            "wrote {} files: {} .. {}",
            written.files.len(),
            first.display(),
            last.display()
        ),
    }
}

/// The frame number of a numbered file `stem_NNNN.ext`.
fn frame_number(p: &Path) -> Option<u32> {
    let stem = p.file_stem()?.to_str()?;
    stem.rsplit_once('_')?.1.parse().ok()
}

/// Say which numbered frames of an earlier, longer render remain, or remove them.
fn report_stale(stale: &[PathBuf], remove: bool, frames: u32) -> hyperslice::error::Result<()> {
    let (Some(first), Some(last)) = (stale.first(), stale.last()) else {
        return Ok(());
    };
    let span = if stale.len() == 1 {
        first.display().to_string()
    } else {
        format!("{} .. {}", first.display(), last.display())
    };
    if remove {
        for p in stale {
            std::fs::remove_file(p).map_err(|source| hyperslice::output::OutputError::Io {
                path: p.clone(),
                source,
            })?;
        }
        eprintln!(
            "removed {} from an earlier, longer render: {span}",
            plural(stale.len(), "frame")
        );
    } else {
        eprintln!(
            "warning: {} beyond this animation's {frames} frames remain from an earlier render: {span}\n  hint: --remove-stale removes them",
            plural(stale.len(), "numbered file")
        );
    }
    Ok(())
}

/// Samples per pixel of each unit (they are alike).
fn part_samples(units: &[hyperslice::render::driver::Unit]) -> u64 {
    units.first().map_or(0, |u| u.samples.len() as u64)
}

/// How long this run took, and for how much work.
struct Times {
    render_secs: f64,
    finish_secs: f64,
    /// Samples this run took (a resumed render took the others earlier).
    samples: u64,
    frames: usize,
}

/// What a finished render prints: times and rates of rendering and of finishing apart, the
/// counts of all the work in the films (`s`), warnings, and the files.
fn summary(
    args: &RenderArgs,
    scene: &Scene,
    s: &hyperslice::render::integrator::Stats,
    t: &Times,
    written: &output::Written,
) {
    let r = &scene.render;
    let (render_secs, finish_secs) = (t.render_secs, t.finish_secs);
    let frames = t.frames.max(1) as f64;
    let pixels = r.width as f64 * r.height as f64 * frames;
    let rate = t.samples as f64 / render_secs.max(1e-9);
    eprintln!(
        "rendered in {render_secs:.2} s: {} samples ({}{}/s, {:.1} per pixel), {} distance evaluations ({:.1} instructions each)",
        HumanCount(s.samples),
        if t.samples == s.samples {
            String::new()
        } else {
            format!("{} in this run, ", HumanCount(t.samples))
        },
        HumanCount(rate as u64),
        s.samples as f64 / pixels,
        HumanCount(s.evaluations),
        s.instructions as f64 / s.evaluations.max(1) as f64
    );
    eprintln!(
        "{} in {finish_secs:.2} s ({:.1} frames/s)",
        if r.denoise == Denoise::None {
            "encoded".to_string()
        } else {
            format!("denoised ({}) and encoded", r.denoise.name())
        },
        frames / finish_secs.max(1e-9)
    );
    if s.out_of_steps > 0 {
        eprintln!(
            "warning: {} ray segment{} ran out of marching steps (max_steps {}); {} ended there",
            s.out_of_steps,
            if s.out_of_steps == 1 { "" } else { "s" },
            r.max_steps,
            if s.out_of_steps == 1 {
                "its path was"
            } else {
                "their paths were"
            }
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
            "frames": t.frames,
            "spp": r.spp,
            "seconds": render_secs + finish_secs,
            "render_seconds": render_secs,
            "samples": s.samples,
            "samples_per_second": rate,
            "samples_per_pixel": s.samples as f64 / pixels,
            "distance_evaluations": s.evaluations,
            "instructions": s.instructions,
            "out_of_steps": s.out_of_steps,
            "dropped": s.dropped,
            "denoise": r.denoise.name(),
            "denoise_seconds": finish_secs,
            "gif_psnr": written.gif_psnr,
            "files": written.files.iter().map(|f| f.display().to_string()).collect::<Vec<_>>(),
        });
        println!("{stats}");
    }
    report_written(written);
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
        if let Some(scene) = c.scene.clone().filter(|_| !c.has_errors()) {
            match render(args, scene) {
                Ok(()) => {}
                Err(hyperslice::Error::Cancelled) => return ExitCode::from(130),
                Err(e) => eprintln!("error: {e}"),
            }
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
            if interrupted().load(Ordering::Relaxed) {
                return ExitCode::from(130);
            }
            match rx.recv_timeout(Duration::from_millis(200)) {
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) => continue,
                Ok(Ok(event))
                    if !event.kind.is_access()
                        && event.paths.iter().any(|p| files.contains(&canon(p))) =>
                {
                    break;
                }
                Ok(_) => {}
                Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => return ExitCode::FAILURE,
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

#[derive(Args)]
pub struct MergeArgs {
    /// Film directories of the shards (from `render --shard K/N --films DIR`), one or several.
    #[arg(required = true)]
    dirs: Vec<PathBuf>,
    /// Output file: .gif, .png (numbered frames) or .exr (numbered frames).
    #[arg(short, long)]
    output: PathBuf,
    /// Denoising filter (default: the one the scene was rendered with).
    #[arg(long)]
    denoise: Option<DenoiseArg>,
    /// Brightness multiplier (default: the scene's).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_exposure)]
    exposure: Option<f64>,
    /// Frames per second of a GIF (default: the scene's).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_fps)]
    fps: Option<f64>,
}

/// `hyperslice merge`: check that the shards are all there, then finish them as one render
/// on one machine would.
pub fn merge(args: MergeArgs) -> hyperslice::error::Result<()> {
    use hyperslice::farm::assemble;
    let start = Instant::now();
    let set = assemble::Films::scan(&args.dirs)?;
    let mut finish = assemble::Finish::of(&set.meta);
    if let Some(d) = args.denoise {
        finish.denoise = d.into();
    }
    if let Some(x) = args.exposure {
        finish.output.exposure = x;
    }
    if let Some(x) = args.fps {
        finish.output.fps = x;
    }
    let m = &set.meta;
    let [k, n] = m.part.frames;
    eprintln!(
        "merging {}: {} x {}, frames {k}..{n} of {}, {} shard{} ({} film files), {} spp",
        m.scene,
        m.width,
        m.height,
        m.frames,
        m.part.shard[1],
        if m.part.shard[1] == 1 { "" } else { "s" },
        set.frames.values().map(Vec::len).sum::<usize>(),
        m.spp
    );
    let monitor = driver::Monitor {
        progress: &|_| {},
        cancel: Some(interrupted()),
    };
    let written = assemble::assemble(&set, &finish, &args.output, monitor);
    if let Err(hyperslice::Error::Cancelled) = written {
        eprintln!(
            "interrupted: no image was written and the films are untouched; run the same command again"
        );
    }
    let written = written?;
    eprintln!(
        "merged in {:.2} s ({} samples in the films)",
        start.elapsed().as_secs_f64(),
        HumanCount(set.stats.samples)
    );
    report_written(&written);
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_rate_reads_samples_per_second() {
        assert_eq!(super::sample_rate(990_740, 2.0), "495,370 samples/s");
    }

    /// The unit is the letters at the end, so an exponent is part of the number.
    #[test]
    fn durations_take_exponents_and_give_the_range() {
        use super::parse_duration;
        use std::time::Duration;
        assert_eq!(parse_duration("1e3s"), Ok(Duration::from_secs(1000)));
        assert_eq!(parse_duration("2.5e-1m"), Ok(Duration::from_secs(15)));
        assert_eq!(
            parse_duration("1e30h").unwrap_err(),
            "`1e30h` is out of range: a duration must be more than 0s and less than 10000000s"
        );
        for bad in ["NaNs", "infs", "10parsecs", "s", "1e"] {
            assert!(
                parse_duration(bad)
                    .unwrap_err()
                    .contains("is not a duration"),
                "{bad}"
            );
        }
    }
}
