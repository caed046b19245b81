//! A directory of film files: where a render keeps its units as they finish, and where a
//! resumed render or `merge` finds them.
//!
//! A unit of all of a frame's samples is `frame_0003.exr`; a sample range of it (a sample
//! shard) is `frame_0003.samples_16-32.exr`. Every file carries the render's fingerprint; a
//! film of another scene or other settings is refused, never mixed in.

use super::plan::Part;
use super::{FORMAT, FilmMeta, Fingerprint};
use crate::denoise::{AtrousOptions, Denoiser, Scales};
use crate::error::{Error, Result};
use crate::film::Film;
use crate::film::file::{self, FilmFile};
use crate::render::driver::{Options, Progress, Store, Unit};
use crate::scene::Scene;
use std::path::{Path, PathBuf};

/// The file name of `unit` when every pixel takes `spp` samples in all.
pub fn file_name(unit: &Unit, spp: u32) -> String {
    if unit.samples == (0..spp) {
        format!("frame_{:04}.exr", unit.frame)
    } else {
        format!(
            "frame_{:04}.samples_{}-{}.exr",
            unit.frame, unit.samples.start, unit.samples.end
        )
    }
}

/// What a film directory holds of a render's units.
#[derive(Debug, Default)]
pub struct Survey {
    /// Units whose film is finished.
    pub complete: usize,
    /// Units with a film that holds some passes but not all.
    pub partial: usize,
    /// The finished units.
    pub finished: Vec<Unit>,
    /// Samples taken in the part-done units.
    pub samples: u64,
}

/// A film directory for one render (one part of it).
pub struct FilmDir {
    dir: PathBuf,
    fingerprint: Fingerprint,
    /// The fields every film of this render shares.
    template: FilmMeta,
    spp: u32,
}

impl FilmDir {
    /// Open `dir` for rendering `part` of `scene`, named `scene_name` in messages. The directory
    /// is created when the first film is saved, so a render refused or stopped before that
    /// leaves none behind.
    pub fn open(
        dir: &Path,
        scene: &Scene,
        scene_name: &str,
        options: &Options,
        part: Part,
    ) -> Result<FilmDir> {
        let r = &scene.render;
        let fingerprint = Fingerprint::of(scene, options);
        let template = FilmMeta {
            format: FORMAT,
            fingerprint: fingerprint.digest.clone(),
            description: fingerprint.description.clone(),
            scene: scene_name.to_string(),
            frame: 0,
            frames: r.frames,
            samples: [0, r.spp],
            spp: r.spp,
            width: r.width,
            height: r.height,
            complete: false,
            stats: Default::default(),
            part,
            denoise: r.denoise,
            exposure: r.exposure,
            fps: r.fps,
            scales: None,
        };
        Ok(FilmDir {
            dir: dir.to_path_buf(),
            fingerprint,
            template,
            spp: r.spp,
        })
    }

    /// The directory the films are kept in.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The path of `unit`'s film in this directory (whether or not it exists yet).
    pub fn path_of(&self, unit: &Unit) -> PathBuf {
        self.dir.join(file_name(unit, self.spp))
    }

    /// What earlier runs left of `units`, checking that it belongs to this render.
    pub fn survey(&self, units: &[Unit]) -> Result<Survey> {
        let mut s = Survey::default();
        for u in units {
            let path = self.path_of(u);
            if !path.exists() {
                continue;
            }
            let meta = read_meta(&path)?;
            self.check(&path, &meta)?;
            if meta.complete {
                s.complete += 1;
                s.finished.push(u.clone());
            } else {
                s.partial += 1;
                s.samples += meta.stats.samples;
            }
        }
        Ok(s)
    }

    /// Refuse the films in the directory of other shards than this one's `units` when they
    /// come from another scene or other settings, or split other frames or another number of
    /// ways: `merge` could not put them together with this shard's.
    pub fn check_shards(&self, units: &[Unit]) -> Result<()> {
        let entries = match std::fs::read_dir(&self.dir) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
            other => other.map_err(|source| Error::ReadFilms {
                path: self.dir.clone(),
                source,
            })?,
        };
        let ours: Vec<String> = units.iter().map(|u| file_name(u, self.spp)).collect();
        let mut names: Vec<(String, PathBuf)> = entries
            .filter_map(|e| e.ok())
            .map(|e| (e.file_name().to_string_lossy().into_owned(), e.path()))
            .filter(|(n, _)| n.starts_with("frame_") && n.ends_with(".exr") && !ours.contains(n))
            .collect();
        names.sort();
        for (_, path) in names {
            let meta = read_meta(&path)?;
            self.check(&path, &meta)?;
            let (mine, theirs) = (self.template.part, meta.part);
            if mine.frames != theirs.frames || mine.shard[1] != theirs.shard[1] {
                let show = |p: Part| {
                    format!(
                        "frames {}..{} in {} shards",
                        p.frames[0], p.frames[1], p.shard[1]
                    )
                };
                return Err(Error::FilmMismatch {
                    path,
                    ours: show(mine),
                    theirs: show(theirs),
                });
            }
        }
        Ok(())
    }

    /// Refuse a film made from another scene or other settings, saying what differs.
    fn check(&self, path: &Path, meta: &FilmMeta) -> Result<()> {
        if meta.fingerprint == self.fingerprint.digest {
            return Ok(());
        }
        let (ours, theirs) = (self.fingerprint)
            .difference(&meta.description)
            .unwrap_or_else(|| ("this render".into(), "another render".into()));
        Err(Error::FilmMismatch {
            path: path.to_path_buf(),
            ours,
            theirs,
        })
    }
}

/// Read a film file and its meta.
pub fn read(path: &Path) -> Result<(FilmMeta, FilmFile)> {
    let film = FilmFile::read(path)?;
    let meta = parse(path, &film.header)?;
    if (meta.width as usize, meta.height as usize) != (film.width, film.height) {
        return Err(Error::FilmHeader {
            path: path.to_path_buf(),
            message: format!(
                "its header says {}x{} but its pixels are {}x{}",
                meta.width, meta.height, film.width, film.height
            ),
        });
    }
    Ok((meta, film))
}

/// A film's meta from its header, without reading its pixels.
pub fn read_meta(path: &Path) -> Result<FilmMeta> {
    parse(path, &file::read_header(path)?)
}

fn parse(path: &Path, header: &str) -> Result<FilmMeta> {
    let meta: FilmMeta = serde_json::from_str(header).map_err(|e| Error::FilmHeader {
        path: path.to_path_buf(),
        message: format!("its header does not describe a film ({e})"),
    })?;
    if meta.format != FORMAT {
        return Err(Error::FilmHeader {
            path: path.to_path_buf(),
            message: format!(
                "it is film format {}, and this hyperslice reads format {FORMAT}",
                meta.format
            ),
        });
    }
    Ok(meta)
}

impl Store for FilmDir {
    fn load(&self, unit: &Unit) -> Result<Option<Progress>> {
        let path = self.path_of(unit);
        if !path.exists() {
            return Ok(None);
        }
        let (meta, film) = read(&path)?;
        self.check(&path, &meta)?;
        if meta.frame != unit.frame || meta.samples != [unit.samples.start, unit.samples.end] {
            return Err(Error::FilmHeader {
                path,
                message: format!(
                    "it holds frame {} samples {}..{}, not what its name says",
                    meta.frame, meta.samples[0], meta.samples[1]
                ),
            });
        }
        Ok(Some(Progress {
            unit: unit.clone(),
            sums: film.sums,
            stats: meta.stats,
            complete: meta.complete,
        }))
    }

    fn save(&self, p: Progress) -> Result<()> {
        let (w, h) = (self.template.width as usize, self.template.height as usize);
        // The scales finishing needs, of a frame's finished film of all its samples: read
        // back, its sums are these, bit for bit.
        let whole_frame = p.complete && p.unit.samples == (0..self.spp);
        let scales = (whole_frame && Denoiser::needs_scales(self.template.denoise))
            .then(|| Scales::of(&Film::from_sums(w, h, &p.sums), &AtrousOptions::default()))
            .filter(|s| s.is_finite());
        let meta = FilmMeta {
            frame: p.unit.frame,
            samples: [p.unit.samples.start, p.unit.samples.end],
            complete: p.complete,
            stats: p.stats,
            scales,
            ..self.template.clone()
        };
        let header = serde_json::to_string(&meta).expect("film meta serialises");
        let bytes = file::encode(&header, w, h, &p.sums)?;
        std::fs::create_dir_all(&self.dir).map_err(|source| Error::CreateDirectory {
            path: self.dir.clone(),
            source,
        })?;
        Ok(crate::output::write_atomic(&self.path_of(&p.unit), &bytes)?)
    }
}
