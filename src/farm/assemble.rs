//! The finishing stage. Films into final frames: each frame's sample ranges summed, the frames
//! denoised across neighbours, and encoded. A render on one machine and a merge of shards both
//! end here, so they make the same bytes. Frames rendered in memory are denoised here too
//! ([`denoise_frames`]).

use super::FilmMeta;
use super::films::{self, file_name};
use crate::denoise::{AtrousOptions, Denoiser, Scales};
use crate::error::{Error, Result};
use crate::film::{Film, PixelSums};
use crate::output::{self, OutputSettings, Written};
use crate::render::driver::{self, Monitor, Unit};
use crate::render::integrator::Stats;
use crate::scene::Denoise;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;

/// The films of a render's frames, found and checked.
pub struct Films {
    /// What every film shares (the first one's meta).
    pub meta: FilmMeta,
    /// Each frame's film files, in sample order.
    pub frames: BTreeMap<u32, Vec<PathBuf>>,
    /// The counts of all the work in them.
    pub stats: Stats,
    /// The denoiser's scales of the whole animation, where every frame is one film whose
    /// header holds its own (`FilmMeta::scales`).
    pub scales: Option<Scales>,
}

impl Films {
    /// The films of `units`, all in `dir` (a render's own).
    pub fn of_units(dir: &Path, units: &[Unit], spp: u32) -> Result<Films> {
        let paths: Vec<PathBuf> = units.iter().map(|u| dir.join(file_name(u, spp))).collect();
        let metas = (paths.iter().enumerate())
            .map(|(i, p)| {
                let mut m = films::read_meta(p)?;
                // Only the first description is kept (see `scan`).
                if i > 0 {
                    m.description = String::new();
                }
                Ok(m)
            })
            .collect::<Result<Vec<_>>>()?;
        Films::new(paths.into_iter().zip(metas).collect())
    }

    /// Every film in `dirs` (the shards of one render), checked to be all of it: the same
    /// fingerprint, every shard's every unit present and finished.
    pub fn scan(dirs: &[PathBuf]) -> Result<Films> {
        let mut found: BTreeMap<String, (PathBuf, FilmMeta)> = BTreeMap::new();
        // The first film read, whole: the others are checked against it.
        let mut reference: Option<FilmMeta> = None;
        for dir in dirs {
            let entries = std::fs::read_dir(dir).map_err(|source| Error::ReadFilms {
                path: dir.clone(),
                source,
            })?;
            let mut names: Vec<(String, PathBuf)> = entries
                .filter_map(|e| e.ok())
                .map(|e| (e.file_name().to_string_lossy().into_owned(), e.path()))
                .filter(|(n, _)| n.starts_with("frame_") && n.ends_with(".exr"))
                .collect();
            names.sort();
            for (name, path) in names {
                let mut meta = films::read_meta(&path)?;
                // One description is enough to say what differs; the others would make
                // memory grow with the frames.
                match &reference {
                    None => reference = Some(meta.clone()),
                    Some(r) if r.fingerprint == meta.fingerprint => meta.description.clear(),
                    Some(_) => {}
                }
                if let Some((first, _)) = found.get(&name) {
                    return Err(Error::MergeDuplicate {
                        name,
                        first: first.clone(),
                        second: path,
                    });
                }
                found.insert(name, (path, meta));
            }
        }
        let Some(first) = reference else {
            return Err(Error::NoFilms {
                dirs: dirs.to_vec(),
            });
        };
        for (path, meta) in found.values() {
            if meta.fingerprint != first.fingerprint || meta.part.frames != first.part.frames {
                let fp = super::Fingerprint {
                    digest: first.fingerprint.clone(),
                    description: first.description.clone(),
                };
                let (ours, theirs) = (fp.difference(&meta.description)).unwrap_or_else(|| {
                    (
                        format!("frames {:?}", first.part.frames),
                        format!("frames {:?}", meta.part.frames),
                    )
                });
                return Err(Error::FilmMismatch {
                    path: path.clone(),
                    ours,
                    theirs,
                });
            }
        }
        // Every shard's units must be there and finished.
        let spp = first.spp;
        let n = found
            .values()
            .map(|(_, m)| m.part.shard[1])
            .max()
            .unwrap_or(1);
        let mut problems = vec![];
        let mut chosen = vec![];
        for k in 0..n {
            let part = super::plan::Part {
                shard: [k, n],
                ..first.part
            };
            for unit in part.units(spp) {
                match found.get(&file_name(&unit, spp)) {
                    None => problems.push(format!(
                        "{} is missing (shard {k}/{n} renders it)",
                        file_name(&unit, spp)
                    )),
                    Some((path, meta)) if !meta.complete => problems.push(format!(
                        "{} is unfinished (run shard {k}/{n} again to resume it)",
                        path.display()
                    )),
                    Some(found) => chosen.push(found.clone()),
                }
            }
        }
        if !problems.is_empty() {
            return Err(Error::MergeIncomplete { problems });
        }
        Films::new(chosen)
    }

    fn new(list: Vec<(PathBuf, FilmMeta)>) -> Result<Films> {
        let meta = list
            .first()
            .map(|(_, m)| m.clone())
            .ok_or(Error::NoFilms { dirs: vec![] })?;
        let mut frames: BTreeMap<u32, Vec<(u32, PathBuf)>> = BTreeMap::new();
        let mut stats = Stats::default();
        let mut scales = Some(Scales::default());
        for (path, m) in list {
            stats += m.stats;
            scales = scales.zip(m.scales).map(|(a, b)| a.max(b));
            frames
                .entry(m.frame)
                .or_default()
                .push((m.samples[0], path));
        }
        // A frame of several films (sample shards) has the scales of their sum, which no
        // header holds.
        if frames.values().any(|v| v.len() > 1) {
            scales = None;
        }
        Ok(Films {
            meta,
            frames: (frames.into_iter())
                .map(|(f, mut v)| {
                    v.sort();
                    (f, v.into_iter().map(|(_, p)| p).collect())
                })
                .collect(),
            stats,
            scales,
        })
    }

    /// Frame `frame`'s sums: its sample ranges added in order.
    fn sums(&self, paths: &[PathBuf]) -> Result<Vec<PixelSums>> {
        let mut total: Option<Vec<PixelSums>> = None;
        for path in paths {
            let (_, film) = films::read(path)?;
            match &mut total {
                None => total = Some(film.sums),
                Some(t) => {
                    for (a, b) in t.iter_mut().zip(&film.sums) {
                        a.merge(b);
                    }
                }
            }
        }
        Ok(total.unwrap_or_default())
    }
}

/// How films are finished into images.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Finish {
    /// The filter run over the summed frames.
    pub denoise: Denoise,
    /// Exposure and frame rate for encoding.
    pub output: OutputSettings,
}

impl Finish {
    /// A render's own settings.
    pub fn of_render(r: &crate::scene::RenderSettings) -> Finish {
        Finish {
            denoise: r.denoise,
            output: OutputSettings {
                exposure: r.exposure,
                fps: r.fps,
            },
        }
    }

    /// The settings the films were rendered with.
    pub fn of(meta: &FilmMeta) -> Finish {
        Finish {
            denoise: meta.denoise,
            output: OutputSettings {
                exposure: meta.exposure,
                fps: meta.fps,
            },
        }
    }
}

/// Denoise and encode the frames of `films` to `out`; numbered files carry the frames' own
/// numbers when the animation has more than one frame. Frames stream through: each film is
/// read just before the denoiser wants it (while the one before is filtered) and written
/// once it is final, so memory holds the denoiser's window and one film more, not the
/// animation. `monitor` is told of each frame written; stopped,
/// this returns [`Error::Cancelled`] and leaves no partial GIF (frames already written as
/// files stay, and the films are untouched).
pub fn assemble(films: &Films, finish: &Finish, out: &Path, monitor: Monitor) -> Result<Written> {
    use rayon::prelude::*;
    let (w, h) = (films.meta.width as usize, films.meta.height as usize);
    let film =
        |paths: &[PathBuf]| -> Result<Film> { Ok(Film::from_sums(w, h, &films.sums(paths)?)) };
    let opts = AtrousOptions::default();
    // Neighbouring frames' guides are compared at common scales: from the films' headers, or
    // a pass over the films first.
    let scales = if !Denoiser::needs_scales(finish.denoise) {
        Scales::default()
    } else if let Some(scales) = films.scales {
        scales
    } else {
        (films.frames.par_iter())
            .map(|(_, paths)| film(paths).map(|f| Scales::of(&f, &opts)))
            .try_reduce(Scales::default, |a, b| Ok(a.max(b)))?
    };
    let mut denoiser = Denoiser::new(finish.denoise, films.frames.len(), &opts, scales);
    let mut sink = output::Sink::create(out, &finish.output, films.meta.frames > 1)?;
    let numbers: Vec<u32> = films.frames.keys().copied().collect();
    let mut next = 0;
    let stopped = || monitor.cancel.is_some_and(|c| c.load(Ordering::Relaxed));
    // The next film is read while the one before is filtered and encoded: reading is serial
    // work the filter's threads would otherwise wait for.
    let mut paths = films.frames.values();
    let mut ahead = paths.next().map(|p| film(p));
    while let Some(read) = ahead {
        if stopped() {
            return Err(Error::Cancelled);
        }
        let current = read?;
        let (pushed, read) = rayon::join(
            || -> Result<()> {
                for done in denoiser.push(current) {
                    sink.push(numbers[next] as usize, &done.image())?;
                    next += 1;
                    (monitor.progress)(1);
                }
                Ok(())
            },
            || paths.next().map(|p| film(p)),
        );
        pushed?;
        ahead = read;
    }
    Ok(sink.finish()?)
}

/// Denoise frames rendered in memory with `denoise`, across neighbouring frames as
/// [`assemble`] does, on `threads` worker threads (`None`: one per core).
pub fn denoise_frames(frames: &mut [Film], denoise: Denoise, threads: Option<usize>) -> Result<()> {
    let opts = AtrousOptions::default();
    driver::pool(threads)?.install(|| crate::denoise::denoise(frames, denoise, &opts));
    Ok(())
}

/// About how long finishing `frames` frames of a render with settings `r` into `out` will
/// take (denoising, encoding, and reading the films, twice where their headers lack the
/// denoiser's scales), so that a time budget can keep it back: measured on three small frames
/// of noise, scaled by the pixels, with a margin.
pub fn finishing_time(
    r: &crate::scene::RenderSettings,
    frames: usize,
    out: &Path,
) -> Result<std::time::Duration> {
    use glam::{DVec3, DVec4};
    let (w, h) = (64, 48);
    let films: Vec<Film> = (0..3)
        .map(|k| {
            let mut f = Film::new(w, h);
            for i in 0..w * h {
                let noise = ((i * 7919 + k * 104_729) % 1000) as f64 / 1000.0;
                f.color[i] = DVec3::splat(noise);
                f.std_error[i] = DVec3::splat(0.1);
                f.albedo[i] = DVec3::splat(0.5);
                f.normal[i] = DVec4::new(0.0, 0.0, -1.0, 0.0);
                f.position[i] = DVec4::new((i % w) as f64, (i / w) as f64, 3.0, k as f64);
                f.samples[i] = r.spp;
            }
            f
        })
        .collect();
    let dir = tempfile::tempdir().map_err(|source| Error::CreateDirectory {
        path: std::env::temp_dir(),
        source,
    })?;
    let name = out.file_name().unwrap_or_default();
    let finish = Finish::of_render(r);
    let start = std::time::Instant::now();
    let opts = AtrousOptions::default();
    let scales = (films.iter()).fold(Scales::default(), |a, f| a.max(Scales::of(f, &opts)));
    let mut denoiser = Denoiser::new(finish.denoise, films.len(), &opts, scales);
    let mut sink = output::Sink::create(&dir.path().join(name), &finish.output, true)?;
    let mut next = 0;
    for f in films {
        for done in denoiser.push(f) {
            sink.push(next, &done.image())?;
            next += 1;
        }
    }
    sink.finish()?;
    let per_pixel = start.elapsed().as_secs_f64() / (3 * w * h) as f64;
    let pixels = r.width as f64 * r.height as f64 * frames as f64;
    Ok(std::time::Duration::from_secs_f64(2.0 * per_pixel * pixels))
}
