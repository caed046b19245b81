//! A long render in one call, as `hyperslice render` runs it: the units of the frames asked for
//! (or of one shard of them) planned, the films an earlier run left checked against this
//! render's fingerprint and resumed, the rest rendered with checkpoints until done or
//! cancelled, and, once every unit is there, the frames finished into the output. [`merge`]
//! finishes the films of a render's shards, as `hyperslice merge` does.
//!
//! The caller watches through a [`Report`] and stops the work with a flag: a stopped job
//! returns [`Outcome::Interrupted`], and the same job run again resumes where it stopped.

use super::assemble::{self, Films, Finish};
use super::films::{FilmDir, Survey};
use super::memory;
use super::plan::Part;
use super::refusal::Refusal;
use crate::compile;
use crate::error::{Error, Result};
use crate::output::{self, Written};
use crate::render::driver::{self, Monitor, Options, Unit};
use crate::render::integrator::Stats;
use crate::scene::{Denoise, RenderSettings, Scene};
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

/// Which frames of the animation a job renders. Each is identical to the same frame of a
/// whole render, and its file is numbered as in it.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum Frames {
    /// Every frame.
    #[default]
    All,
    /// Frame N (0-based).
    One(u32),
    /// A range of frames.
    Range(FrameRange),
}

/// Frames `A..B` (B excluded), `A..=B` or `A..` (to the last frame), parsed from that text and
/// named by it in messages.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameRange {
    start: u32,
    /// Excluded; `None` to the last frame.
    end: Option<u32>,
    text: String,
}

impl std::str::FromStr for FrameRange {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<FrameRange, String> {
        let err = || format!("`{s}` is not a frame range; write A..B (B excluded) or A..=B");
        let (a, b, inclusive) = if let Some((a, b)) = s.split_once("..=") {
            (a, b, true)
        } else if let Some((a, b)) = s.split_once("..") {
            (a, b, false)
        } else {
            return Err(err());
        };
        let start: u32 = a.trim().parse().map_err(|_| err())?;
        let end: Option<u32> = match b.trim() {
            "" if !inclusive => None,
            b => Some(
                (b.parse::<u32>().map_err(|_| err())?)
                    .checked_add(inclusive as u32)
                    .ok_or_else(err)?,
            ),
        };
        if end.is_some_and(|b| b <= start) {
            return Err(format!("`{s}` holds no frames"));
        }
        Ok(FrameRange {
            start,
            end,
            text: s.trim().to_string(),
        })
    }
}

impl std::fmt::Display for FrameRange {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.text)
    }
}

/// What a job does with the films an earlier run left in its film directory.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Resume {
    /// Resume from the films of this render; refuse films of another scene or other settings
    /// (the work of an earlier run is never thrown away unasked).
    #[default]
    Resume,
    /// Discard the films of this job's units (the whole directory when it is the hidden one)
    /// and start afresh.
    Restart,
    /// Resume from the films of this render, and discard those of another scene or other
    /// settings instead of refusing them: for a draft rendered again on every change.
    Replace,
}

/// A long render: what to render, where its films and output go, and which part of it.
#[derive(Clone)]
pub struct Job {
    /// The scene, with its render settings as they are to be (size, frames, spp, denoiser).
    pub scene: Scene,
    /// The scene's file, or a name for a scene from text: the output may not overwrite it,
    /// and the films name it.
    pub scene_file: PathBuf,
    /// The output: `.gif` (one animated GIF), `.png` or `.exr` (numbered frames), by its
    /// extension.
    pub output: PathBuf,
    /// Where the films are kept. `None`: in a hidden directory beside the output, removed once
    /// the output is written.
    pub films: Option<PathBuf>,
    /// Which frames of the animation to render (numbered frames keep their numbers).
    pub frames: Frames,
    /// `(k, n)`: the k-th (0-based) of n parts of the work, for several machines; `(0, 1)` is
    /// all of it. Whole frames when there are at least n frames, otherwise sample ranges of
    /// every frame. A part of several never writes the output: [`merge`] puts the parts' films
    /// together.
    pub shard: (u32, u32),
    /// What to do with films an earlier run left.
    pub resume: Resume,
    /// Remove numbered frames beyond the animation's last that an earlier, longer render left
    /// beside the output (otherwise they are only reported).
    pub remove_stale: bool,
    /// How samples are taken. A time budget is for the whole job, finishing included.
    pub options: Options,
}

/// What a [`Job`] tells its caller as it goes. Every method does nothing unless implemented;
/// `()` watches nothing.
pub trait Report: Sync {
    /// The plan is made and the films checked: rendering starts.
    fn rendering(&mut self, _start: &Start) {}
    /// `n` more samples are taken (called from any worker thread).
    fn samples(&self, _n: u64) {}
    /// Rendering ended, done or stopped.
    fn rendered(&mut self) {}
    /// Every unit is there: finishing (denoising and encoding) `frames` frames starts.
    fn finishing(&mut self, _frames: usize) {}
    /// [`merge`] found and checked the shards' films: finishing them starts.
    fn merging(&mut self, _films: &Films) {}
    /// One more frame is finished.
    fn frame_finished(&self) {}
    /// Finishing ended, done or stopped.
    fn finished(&mut self) {}
}

impl Report for () {}

/// What a job is about to render, for [`Report::rendering`].
pub struct Start<'a> {
    /// The frames rendered (half-open) ...
    pub frames: Range<u32>,
    /// ... as the job names them: its [`FrameRange`], or `A..=B`.
    pub asked: &'a str,
    /// The part of the render this job is (its frames and its shard).
    pub part: Part,
    /// The units of this part, and what earlier runs left of them.
    pub units: &'a [Unit],
    /// What earlier runs left of `units` in the film directory.
    pub earlier: &'a Survey,
    /// Samples left to take (at most, when the render is progressive).
    pub samples: u64,
    /// Whether pixels take samples until a time budget or a noise threshold says stop.
    pub progressive: bool,
    /// The film directory.
    pub dir: &'a Path,
}

/// How a job ended (errors apart).
#[derive(Debug)]
pub enum Outcome {
    /// Stopped by the cancel flag; running the same job again resumes where it stopped.
    Interrupted(Interrupted),
    /// This shard's units are rendered into `dir` in `render_secs` seconds; once every shard's
    /// are, [`merge`] makes the output.
    Shard {
        /// Seconds this run spent rendering.
        render_secs: f64,
        /// The film directory the shard's films are in.
        dir: PathBuf,
    },
    /// The output is written.
    Written(Finished),
}

/// Where a job was stopped, and what it kept.
#[derive(Debug)]
pub enum Interrupted {
    /// While rendering, after `render_secs` seconds: `complete` of the `units` units are
    /// finished and `partial` part-done, kept in `dir`.
    Rendering {
        /// Seconds this run spent rendering.
        render_secs: f64,
        /// Units whose film is finished.
        complete: usize,
        /// Units with some passes kept but not all.
        partial: usize,
        /// Units of this job in all.
        units: usize,
        /// The film directory the work is kept in.
        dir: PathBuf,
    },
    /// While finishing: every unit's film is kept in `dir` (numbered frames already written
    /// stay; no partial GIF is left).
    Finishing {
        /// The film directory, every unit's film in it.
        dir: PathBuf,
    },
}

/// A finished job.
#[derive(Debug)]
pub struct Finished {
    /// Seconds rendering took in this run.
    pub render_secs: f64,
    /// Seconds finishing (denoising and encoding) took in this run.
    pub finish_secs: f64,
    /// Samples this run took (a resumed render took the others earlier).
    pub samples: u64,
    /// Frames written.
    pub frames: usize,
    /// The counts of all the work in the films.
    pub stats: Stats,
    /// The files written and, for a GIF, its quality.
    pub written: Written,
    /// Numbered frames beyond the animation's last that an earlier, longer render left beside
    /// the output: removed when the job says `remove_stale`, otherwise still there.
    pub stale: Vec<PathBuf>,
    /// Time since rendering started.
    pub elapsed: Duration,
}

impl Job {
    /// A job rendering every frame of `scene` into `output`, resuming from (and keeping its
    /// films in) a hidden directory beside it, on the threads the scene's settings ask for
    /// (`options.threads` is `None`: the scene's).
    pub fn new(scene: Scene, scene_file: impl Into<PathBuf>, output: impl Into<PathBuf>) -> Job {
        Job {
            scene,
            scene_file: scene_file.into(),
            output: output.into(),
            films: None,
            frames: Frames::All,
            shard: (0, 1),
            resume: Resume::Resume,
            remove_stale: false,
            options: Options::default(),
        }
    }

    /// Where the films are kept: [`Job::films`], or the hidden directory beside the output.
    pub fn film_dir(&self) -> PathBuf {
        self.films.clone().unwrap_or_else(|| {
            let name = self
                .output
                .file_name()
                .unwrap_or_default()
                .to_string_lossy();
            self.output.with_file_name(format!(".{name}.films"))
        })
    }

    /// The frames asked for, checked to be in the animation, and how messages name them.
    fn frames(&self) -> Result<(Range<u32>, String)> {
        let all = self.scene.render.frames;
        let frames = match &self.frames {
            Frames::All => 0..all,
            Frames::One(f) => *f..f.saturating_add(1),
            Frames::Range(range) => range.start..range.end.unwrap_or(all),
        };
        let asked = match &self.frames {
            Frames::Range(range) => range.text.clone(),
            _ => frame_span(&frames),
        };
        if let Frames::One(frame) = self.frames
            && frame >= all
        {
            return Err(Refusal::FrameOutside { frame, frames: all }.into());
        }
        if frames.end > all || frames.is_empty() {
            return Err(Refusal::FramesOutside { asked, frames: all }.into());
        }
        Ok((frames, asked))
    }

    /// Render what is left of this job, telling `report` how it goes, until every unit is
    /// there or `cancel` is set; then, unless the job is one shard of several, finish the
    /// frames into the output.
    ///
    /// Nothing is rendered when the output cannot be written, the frames or shard are not in
    /// the render, the machine lacks the memory, or the film directory holds films of
    /// another scene or other settings (unless [`Resume`] says otherwise).
    ///
    /// # Example
    ///
    /// Stop a render after its first frame, run it again, and get the bytes an uninterrupted
    /// render makes:
    ///
    /// ```
    /// use hyperslice::Compilation;
    /// use hyperslice::farm::job::{Job, Outcome, Report};
    /// use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
    ///
    /// let source = r#"
    ///     render { size = 8 x 8  frames = 2  spp = 2 }
    ///     object ball { shape = hypersphere(1) }
    ///     object lamp { shape = hypersphere(0.5) |> translate([1, 2, -1, 0]) material = light(intensity: 5) }
    /// "#;
    /// let scene = Compilation::from_source("ball.4ds", source).into_scene()?;
    /// let dir = std::env::temp_dir().join(format!("hyperslice-job-doc-{}", std::process::id()));
    /// std::fs::create_dir_all(&dir)?;
    ///
    /// /// Sets the flag once a frame's samples are taken.
    /// struct StopAfterOneFrame<'a> {
    ///     cancel: &'a AtomicBool,
    ///     taken: AtomicU64,
    /// }
    /// impl Report for StopAfterOneFrame<'_> {
    ///     fn samples(&self, n: u64) {
    ///         if self.taken.fetch_add(n, Ordering::Relaxed) + n >= 8 * 8 * 2 {
    ///             self.cancel.store(true, Ordering::Relaxed);
    ///         }
    ///     }
    /// }
    ///
    /// let mut job = Job::new(scene.clone(), "ball.4ds", dir.join("ball.exr"));
    /// job.films = Some(dir.join("films"));
    /// job.options.threads = Some(1); // one frame at a time
    /// let cancel = AtomicBool::new(false);
    /// let mut stop = StopAfterOneFrame { cancel: &cancel, taken: AtomicU64::new(0) };
    /// let first = job.run(&mut stop, Some(&cancel))?;
    /// assert!(matches!(first, Outcome::Interrupted(_)));
    /// assert!(dir.join("films/frame_0000.exr").exists());
    /// assert!(!dir.join("ball_0000.exr").exists());
    ///
    /// // The same job again resumes from the films, renders only the second frame, and
    /// // finishes both.
    /// let Outcome::Written(done) = job.run(&mut (), None)? else { panic!("not finished") };
    /// assert_eq!((done.frames, done.samples), (2, 8 * 8 * 2));
    ///
    /// // An uninterrupted render makes the same files.
    /// Job::new(scene, "ball.4ds", dir.join("straight.exr")).run(&mut (), None)?;
    /// for f in ["0000", "0001"] {
    ///     let resumed = std::fs::read(dir.join(format!("ball_{f}.exr")))?;
    ///     assert_eq!(resumed, std::fs::read(dir.join(format!("straight_{f}.exr")))?);
    /// }
    /// std::fs::remove_dir_all(&dir)?;
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn run(&self, report: &mut dyn Report, cancel: Option<&AtomicBool>) -> Result<Outcome> {
        let out = &self.output;
        // Fail on an unwritable path before spending any time rendering.
        output::check_writable(out, &self.scene_file)?;
        let r = &self.scene.render;
        let (frames, asked) = self.frames()?;
        let (k, n) = self.shard;
        if n == 0 || k >= n {
            return Err(Refusal::Shard { k, n }.into());
        }
        let part = Part::new(frames.clone(), self.shard);
        let progressive =
            self.options.time_budget.is_some() || self.options.noise_threshold.is_some();
        if n > 1 && !part.splits_frames() && progressive {
            let frames = frames.len();
            return Err(Refusal::ProgressiveShards { frames, n }.into());
        }
        // The budget is for the whole run: what finishing the frames will take is kept back.
        let finishing = (self.options.time_budget.is_some() && n == 1)
            .then(|| assemble::finishing_time(r, frames.len(), out))
            .transpose()?
            .unwrap_or_default();
        let options = Options {
            time_budget: (self.options.time_budget).map(|b| b.saturating_sub(finishing)),
            ..self.options
        };
        let units = part.units(r.spp);
        let threads = options.threads.or(r.threads());
        refuse_what_memory_cannot_hold(r, threads, &units, n == 1, frames.len())?;
        let dir = self.film_dir();
        let hidden = self.films.is_none();
        let name = self.scene_file.file_name().unwrap_or_default();
        let films = FilmDir::open(&dir, &self.scene, &name.to_string_lossy(), &options, part)?;
        if self.resume == Resume::Restart {
            discard_films(&films, &units, hidden)?;
        }
        if n > 1 {
            // Another shard's films of other settings would only be refused at `merge`.
            films.check_shards(&units)?;
        }
        let earlier = match films.survey(&units) {
            Err(Error::FilmMismatch { .. }) if self.resume == Resume::Replace => {
                discard_films(&films, &units, hidden)?;
                films.survey(&units)?
            }
            // Films of other settings: the work of an earlier run, kept unless asked.
            Err(Error::FilmMismatch { ours, theirs, path }) => {
                let file = path.file_name().unwrap_or_default().to_string_lossy();
                return Err(Refusal::ForeignFilms {
                    dir,
                    file: file.into_owned(),
                    ours,
                    theirs,
                    hidden,
                }
                .into());
            }
            other => other?,
        };
        let todo: Vec<Unit> = (units.iter())
            .filter(|u| !earlier.finished.contains(u))
            .cloned()
            .collect();
        let samples = (todo.iter())
            .map(|u| r.width as u64 * r.height as u64 * u.samples.len() as u64)
            .sum::<u64>()
            .saturating_sub(earlier.samples);
        report.rendering(&Start {
            frames: frames.clone(),
            asked: &asked,
            part,
            units: &units,
            earlier: &earlier,
            samples,
            progressive,
            dir: &dir,
        });
        let started = Instant::now();
        let source = compile::Frames::new(&self.scene);
        let rendered = {
            let shared: &dyn Report = report;
            let progress = |n: u64| shared.samples(n);
            let monitor = Monitor {
                progress: &progress,
                cancel,
            };
            driver::render_units(&source, &options, &todo, &films, monitor)
        };
        report.rendered();
        let render_secs = started.elapsed().as_secs_f64();
        let this_run = match rendered {
            Err(Error::Cancelled) => {
                let after = films.survey(&units)?;
                return Ok(Outcome::Interrupted(Interrupted::Rendering {
                    render_secs,
                    complete: after.complete,
                    partial: after.partial,
                    units: units.len(),
                    dir,
                }));
            }
            other => other?,
        };
        if n > 1 {
            return Ok(Outcome::Shard { render_secs, dir });
        }
        let set = Films::of_units(&dir, &units, r.spp)?;
        let finish_start = Instant::now();
        report.finishing(units.len());
        let written = finish(&set, &Finish::of_render(r), out, report, cancel);
        let written = match written {
            Err(Error::Cancelled) => {
                return Ok(Outcome::Interrupted(Interrupted::Finishing { dir }));
            }
            other => other?,
        };
        let finish_secs = finish_start.elapsed().as_secs_f64();
        let stale: Vec<PathBuf> = output::stale_frames(out, &written.files)
            .into_iter()
            .filter(|p| frame_number(p).is_some_and(|n| n >= r.frames))
            .collect();
        if hidden {
            // The output is written; the hidden films have served.
            match std::fs::remove_dir_all(&dir) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                    return Err(Error::RemoveFilms {
                        path: dir,
                        source: e,
                    });
                }
                _ => {}
            }
        }
        if self.remove_stale {
            for p in &stale {
                std::fs::remove_file(p).map_err(|source| output::OutputError::Io {
                    path: p.clone(),
                    source,
                })?;
            }
        }
        Ok(Outcome::Written(Finished {
            render_secs,
            finish_secs,
            samples: this_run.samples,
            frames: units.len(),
            stats: set.stats,
            written,
            stale,
            elapsed: started.elapsed(),
        }))
    }
}

/// How [`merge`] finishes the shards' films: each setting `None` is the one they were
/// rendered with.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MergeSettings {
    /// The filter to finish with instead of the rendered scene's.
    pub denoise: Option<Denoise>,
    /// The exposure multiplier instead of the scene's.
    pub exposure: Option<f64>,
    /// The GIF frame rate instead of the scene's.
    pub fps: Option<f64>,
}

/// What [`merge`] made.
#[derive(Debug)]
pub struct Merged {
    /// The counts of all the work in the films.
    pub stats: Stats,
    /// The files written and, for a GIF, its quality.
    pub written: Written,
}

/// Check that the films in `dirs` are every shard of one render, all finished, and finish them
/// into `out` as the render on one machine would (the same bytes), telling `report` what was
/// found and of each frame finished. Stopped by `cancel`, this returns [`Error::Cancelled`]:
/// no partial GIF is left and the films are untouched.
///
/// # Example
///
/// Render a two-frame animation as two shards (one frame each, as two machines would), then
/// merge their films into the frames one machine makes.
///
/// ```
/// use hyperslice::Compilation;
/// use hyperslice::farm::job::{Job, MergeSettings, Outcome, merge};
///
/// let source = r#"
///     render { size = 8 x 8  frames = 2  spp = 1  denoise = "none" }
///     sky = rgb(1)
///     object ball { shape = hypersphere(1) }
/// "#;
/// let scene = Compilation::from_source("ball.4ds", source).into_scene()?;
/// let dir = std::env::temp_dir().join(format!("hyperslice-merge-doc-{}", std::process::id()));
/// std::fs::create_dir_all(&dir)?;
///
/// let mut shards = Vec::new();
/// for k in 0..2 {
///     let mut job = Job::new(scene.clone(), "ball.4ds", dir.join("ball.exr"));
///     job.films = Some(dir.join(format!("shard{k}")));
///     job.shard = (k, 2);
///     let Outcome::Shard { dir, .. } = job.run(&mut (), None)? else { panic!("not a shard") };
///     shards.push(dir);
/// }
/// assert!(!dir.join("ball_0000.exr").exists()); // shards never write the output
///
/// let merged = merge(&shards, &dir.join("ball.exr"), &MergeSettings::default(), &mut (), None)?;
/// assert_eq!(merged.written.files.len(), 2);
/// assert_eq!(merged.stats.samples, 2 * 8 * 8);
///
/// // The same bytes as the render on one machine.
/// Job::new(scene, "ball.4ds", dir.join("straight.exr")).run(&mut (), None)?;
/// for f in ["0000", "0001"] {
///     let merged = std::fs::read(dir.join(format!("ball_{f}.exr")))?;
///     assert_eq!(merged, std::fs::read(dir.join(format!("straight_{f}.exr")))?);
/// }
/// std::fs::remove_dir_all(&dir)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn merge(
    dirs: &[PathBuf],
    out: &Path,
    settings: &MergeSettings,
    report: &mut dyn Report,
    cancel: Option<&AtomicBool>,
) -> Result<Merged> {
    let set = Films::scan(dirs)?;
    let mut finishing = Finish::of(&set.meta);
    if let Some(d) = settings.denoise {
        finishing.denoise = d;
    }
    if let Some(x) = settings.exposure {
        finishing.output.exposure = x;
    }
    if let Some(x) = settings.fps {
        finishing.output.fps = x;
    }
    report.merging(&set);
    let written = finish(&set, &finishing, out, report, cancel)?;
    Ok(Merged {
        stats: set.stats,
        written,
    })
}

/// [`assemble::assemble`], telling `report` of each frame.
fn finish(
    set: &Films,
    finishing: &Finish,
    out: &Path,
    report: &mut dyn Report,
    cancel: Option<&AtomicBool>,
) -> Result<Written> {
    let written = {
        let shared: &dyn Report = report;
        let progress = |_| shared.frame_finished();
        let monitor = Monitor {
            progress: &progress,
            cancel,
        };
        assemble::assemble(set, finishing, out, monitor)
    };
    report.finished();
    written
}

/// Refuse a render whose frames in flight (or, when `finishing`, whose denoising of `frames`
/// frames) need more memory than the machine has available, before anything is written: it
/// would otherwise abort part-way with a failed allocation.
fn refuse_what_memory_cannot_hold(
    r: &RenderSettings,
    threads: Option<usize>,
    units: &[Unit],
    finishing: bool,
    frames: usize,
) -> Result<()> {
    let threads = threads.unwrap_or_else(driver::every_core);
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
    Err(Refusal::Memory {
        width: r.width,
        height: r.height,
        needed: memory::human(needed),
        available: memory::human(available),
        known,
        per_pixel: needed as f64 / (r.width as f64 * r.height as f64) / 1000.0,
        many_frames: in_flight > 1 || frames > 1,
    }
    .into())
}

/// Remove the films of `units` (the whole folder when it is the hidden one).
fn discard_films(films: &FilmDir, units: &[Unit], hidden: bool) -> Result<()> {
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
    removed.map_err(|source| Error::RemoveFilms {
        path: films.dir().to_path_buf(),
        source,
    })
}

/// Frames as a frame range names them, the last included: `0..=6`, or `7..` when none.
fn frame_span(frames: &Range<u32>) -> String {
    if frames.is_empty() {
        format!("{}..", frames.start)
    } else {
        format!("{}..={}", frames.start, frames.end - 1)
    }
}

/// The frame number of a numbered file `stem_NNNN.ext`.
fn frame_number(p: &Path) -> Option<u32> {
    let stem = p.file_stem()?.to_str()?;
    stem.rsplit_once('_')?.1.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::FrameRange;

    #[test]
    fn frame_ranges_read_as_written() {
        let r: FrameRange = " 2..=4 ".parse().unwrap();
        assert_eq!(
            (r.start, r.end, r.to_string()),
            (2, Some(5), "2..=4".into())
        );
        let open: FrameRange = "7..".parse().unwrap();
        assert_eq!((open.start, open.end), (7, None));
        assert_eq!(
            "3..3".parse::<FrameRange>().unwrap_err(),
            "`3..3` holds no frames"
        );
        for bad in ["3", "a..b", "1..=", "0..=4294967295"] {
            assert!(
                bad.parse::<FrameRange>()
                    .unwrap_err()
                    .contains("not a frame range"),
                "{bad}"
            );
        }
    }
}
