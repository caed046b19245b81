//! `hyperslice render` and `hyperslice merge`: compile a scene, apply command-line overrides,
//! and run it as a [`Job`] (or merge shards with [`job::merge`]) with Ctrl-C as its cancel flag,
//! showing progress bars and printing what it did. The work itself is the library's.

use clap::Args;
use hyperslice::farm::assemble::Films;
use hyperslice::farm::job::{
    self, Finished, FrameRange, Frames, Interrupted, Job, MergeSettings, Outcome, Report, Resume,
    Start,
};
use hyperslice::output;
use hyperslice::render::driver::Options;
use hyperslice::render::march::MarcherKind;
use hyperslice::render::sampler::SamplerKind;
use hyperslice::scene::{Denoise, Quality, RenderSettings, Scene};
use indicatif::HumanCount;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::str::FromStr;
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
    #[arg(long, value_name = "A..B", value_parser = FrameRange::from_str)]
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
    /// on the whole tape (as `whole`, or with plain steps where those cost less) where they do
    /// not (the default).
    Auto,
    /// Through the frame's pruned cells, with over-relaxed steps and exact planes, spheres,
    /// boxes and polytopes, whether or not they pay.
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

/// The flags that change what a long render refused (the library names the settings).
pub fn flags_for(e: &hyperslice::Error) -> Option<&'static str> {
    use hyperslice::farm::refusal::Refusal;
    let hyperslice::Error::Refused(r) = e else {
        return matches!(e, hyperslice::Error::FilmMismatch { .. })
            .then_some("render into another --films directory");
    };
    Some(match r {
        Refusal::FrameOutside { .. } | Refusal::FramesOutside { .. } => {
            "--frames N renders more frames"
        }
        Refusal::Shard { .. } => "--shard K/N takes 0 <= K < N",
        Refusal::ProgressiveShards { .. } => {
            "--time-budget and --noise-threshold split by frames only; drop them for a fixed --spp"
        }
        Refusal::ForeignFilms { hidden: true, .. } => "pass --restart to discard them",
        Refusal::ForeignFilms { hidden: false, .. } => {
            "pass --restart to discard them (or render into another --films directory)"
        }
        Refusal::Memory {
            many_frames: true, ..
        } => "--size makes the image smaller; --threads 1 or --frame-range holds fewer frames",
        Refusal::Memory { .. } => "--size makes the image smaller",
    })
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

/// `495,370 samples/s`: the progress bar's rate of `n` samples in `secs` seconds.
fn sample_rate(n: u64, secs: f64) -> String {
    format!(
        "{} samples/s",
        HumanCount((n as f64 / secs.max(1e-9)) as u64)
    )
}

fn plural(n: usize, one: &str) -> String {
    format!("{n} {one}{}", if n == 1 { "" } else { "s" })
}

/// A render on the terminal: its first lines and progress bars.
struct Terminal<'a> {
    file: &'a Path,
    r: &'a RenderSettings,
    bar: Option<ProgressBar>,
    /// What the rendering bar's message counts: when rendering started, the units, those
    /// finished before, and the samples of each.
    started: Instant,
    units: usize,
    before: usize,
    per_frame: u64,
    progressive: bool,
}

impl Report for Terminal<'_> {
    fn rendering(&mut self, s: &Start) {
        let r = self.r;
        let shard = s.part.shard;
        eprintln!(
            "rendering {}: {} x {}, {}{}{}, {} spp, {} bounces",
            self.file.display(),
            r.width,
            r.height,
            if s.frames == (0..r.frames) {
                plural(r.frames as usize, "frame")
            } else {
                format!("frames {} of {}", s.asked, r.frames)
            },
            if shard[1] > 1 {
                format!(", shard {}/{}", shard[0], shard[1])
            } else {
                String::new()
            },
            if shard[1] > 1 && !s.part.splits_frames() {
                s.units.first().map_or(" (no samples)".to_string(), |u| {
                    format!(" (samples {}..{})", u.samples.start, u.samples.end)
                })
            } else {
                String::new()
            },
            r.spp,
            r.bounces
        );
        if s.earlier.complete + s.earlier.partial > 0 {
            eprintln!(
                "resuming from {}: {} of {} finished, {} part-done",
                s.dir.display(),
                s.earlier.complete,
                plural(s.units.len(), "frame"),
                s.earlier.partial
            );
        }
        // A progressive render's length is its time budget, or unknown: the bar then shows the
        // samples taken and their rate.
        let bar = if s.progressive {
            let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
            bar.set_style(
                ProgressStyle::with_template(
                    "{spinner} {elapsed_precise} {human_pos} samples, {msg}",
                )
                .expect("a valid template"),
            );
            bar
        } else {
            let bar = ProgressBar::with_draw_target(Some(s.samples), ProgressDrawTarget::stderr());
            bar.set_style(
                ProgressStyle::with_template(
                    "{bar:40} {percent:>3}% {elapsed_precise} eta {eta} {msg}",
                )
                .expect("a valid template"),
            );
            bar
        };
        self.bar = Some(bar);
        self.started = Instant::now();
        self.units = s.units.len();
        self.before = s.earlier.complete;
        // Samples per pixel of each unit (they are alike).
        let part_samples = s.units.first().map_or(0, |u| u.samples.len() as u64);
        self.per_frame = (r.width as u64 * r.height as u64 * part_samples).max(1);
        self.progressive = s.progressive;
    }

    fn samples(&self, n: u64) {
        let Some(bar) = &self.bar else { return };
        bar.inc(n);
        let rate = sample_rate(bar.position(), self.started.elapsed().as_secs_f64());
        if self.progressive {
            bar.set_message(rate);
        } else {
            let done = (self.before + (bar.position() / self.per_frame) as usize).min(self.units);
            bar.set_message(format!("{done}/{} frames, {rate}", self.units));
        }
    }

    fn rendered(&mut self) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
    }

    fn finishing(&mut self, frames: usize) {
        eprintln!(
            "{} {}",
            if self.r.denoise == Denoise::None {
                "encoding"
            } else {
                "denoising and encoding"
            },
            plural(frames, "frame")
        );
        let bar = ProgressBar::with_draw_target(Some(frames as u64), ProgressDrawTarget::stderr());
        bar.set_style(
            ProgressStyle::with_template("{bar:40} {pos}/{len} frames {elapsed_precise} eta {eta}")
                .expect("a valid template"),
        );
        self.bar = Some(bar);
    }

    fn frame_finished(&self) {
        if let Some(bar) = &self.bar {
            bar.inc(1);
        }
    }

    fn finished(&mut self) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
    }
}

/// The job `render` runs: the scene with the flags applied, and what the flags ask of it.
fn job(args: &RenderArgs, mut scene: Scene) -> Job {
    args.apply(&mut scene.render);
    let out = args
        .output
        .clone()
        .unwrap_or_else(|| default_output(&args.file));
    let mut job = Job::new(scene, &args.file, out);
    job.films = args.films.clone();
    job.frames = match (args.frame, &args.frame_range) {
        (Some(f), _) => Frames::One(f),
        (None, Some(range)) => Frames::Range(range.clone()),
        (None, None) => Frames::All,
    };
    job.shard = args.shard.unwrap_or((0, 1));
    job.resume = if args.restart {
        Resume::Restart
    } else if args.watch && args.films.is_none() {
        // `--watch` re-renders a draft on every change: its own hidden films of the scene
        // before the change are of no use.
        Resume::Replace
    } else {
        Resume::Resume
    };
    job.remove_stale = args.remove_stale;
    job.options = Options {
        light_sampling: args.light_sampling == Switch::On,
        sampler: args.sampler.into(),
        marcher: args.marcher.into(),
        time_budget: args.time_budget,
        noise_threshold: args.noise_threshold,
        ..job.options
    };
    job
}

fn render(args: &RenderArgs, scene: Scene) -> hyperslice::error::Result<()> {
    use hyperslice::error::Error;
    let job = job(args, scene);
    let (r, out) = (&job.scene.render, &job.output);
    let mut terminal = Terminal {
        file: &args.file,
        r,
        bar: None,
        started: Instant::now(),
        units: 0,
        before: 0,
        per_frame: 1,
        progressive: false,
    };
    let done = match job.run(&mut terminal, Some(interrupted()))? {
        Outcome::Interrupted(Interrupted::Rendering {
            render_secs,
            complete,
            partial,
            units,
            dir,
        }) => {
            eprintln!(
                "interrupted after {render_secs:.1} s: {complete} of {} finished and {partial} part-done kept in {}",
                plural(units, "frame"),
                dir.display()
            );
            eprintln!("  run the same command again to resume where it stopped");
            return Err(Error::Cancelled);
        }
        Outcome::Interrupted(Interrupted::Finishing { dir }) => {
            eprintln!(
                "interrupted while finishing: every frame's film is kept in {}\n  run the same command again to finish",
                dir.display()
            );
            return Err(Error::Cancelled);
        }
        Outcome::Shard { render_secs, dir } => {
            let (k, n) = job.shard;
            eprintln!(
                "rendered shard {k}/{n} in {render_secs:.2} s into {}",
                dir.display()
            );
            eprintln!(
                "  when all {n} shards are done: hyperslice merge {} -o {}",
                dir.display(),
                out.display()
            );
            return Ok(());
        }
        Outcome::Written(done) => done,
    };
    summary(args, &job.scene, &done);
    if let Some(budget) = args.time_budget
        && done.elapsed > budget
    {
        eprintln!(
            "warning: the time budget of {:.1} s is too short for one sample per pixel of every frame; the run took {:.1} s\n  hint: a smaller --size, fewer frames, or a longer budget",
            budget.as_secs_f64(),
            done.elapsed.as_secs_f64()
        );
    }
    report_stale(&done.stale, args.remove_stale, r.frames);
    Ok(())
}

/// Say which files were written.
fn report_written(written: &output::Written) {
    if let Some(psnr) = written.gif_psnr {
        eprintln!("GIF quantisation: PSNR {psnr:.1} dB against the 8-bit frames");
    }
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

/// Say which numbered frames of an earlier, longer render remain, or that they were removed.
fn report_stale(stale: &[PathBuf], removed: bool, frames: u32) {
    let (Some(first), Some(last)) = (stale.first(), stale.last()) else {
        return;
    };
    let span = if stale.len() == 1 {
        first.display().to_string()
    } else {
        format!("{} .. {}", first.display(), last.display())
    };
    if removed {
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
}

/// What a finished render prints: times and rates of rendering and of finishing apart, the
/// counts of all the work in the films, warnings, and the files.
fn summary(args: &RenderArgs, scene: &Scene, t: &Finished) {
    let (s, written) = (&t.stats, &t.written);
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
            "shadow_rays": s.shadow_rays,
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

/// `hyperslice merge` on the terminal: what was found.
struct Merging;

impl Report for Merging {
    fn merging(&mut self, set: &Films) {
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
    }
}

/// `hyperslice merge`: check that the shards are all there, then finish them as one render
/// on one machine would.
pub fn merge(args: MergeArgs) -> hyperslice::error::Result<()> {
    let start = Instant::now();
    let settings = MergeSettings {
        denoise: args.denoise.map(Into::into),
        exposure: args.exposure,
        fps: args.fps,
    };
    let merged = job::merge(
        &args.dirs,
        &args.output,
        &settings,
        &mut Merging,
        Some(interrupted()),
    );
    if let Err(hyperslice::Error::Cancelled) = merged {
        eprintln!(
            "interrupted: no image was written and the films are untouched; run the same command again"
        );
    }
    let merged = merged?;
    eprintln!(
        "merged in {:.2} s ({} samples in the films)",
        start.elapsed().as_secs_f64(),
        HumanCount(merged.stats.samples)
    );
    report_written(&merged.written);
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
