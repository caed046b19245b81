//! Frames into files as they come: numbered PNG or EXR files, or one animated GIF.

use super::files::{
    check_directory, dir_for_io, io_error, numbered_path, parent_dir, persist, write_temp,
};
use super::{Format, HdrImage, OutputError, OutputSettings, gif, openexr, png, tonemap};
use std::fs;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use tempfile::{NamedTempFile, TempPath};

/// What was written, for the summary the CLI prints.
#[derive(Clone, Debug, PartialEq)]
pub struct Written {
    /// Every file written, in frame order.
    pub files: Vec<PathBuf>,
    /// GIF only: PSNR (dB) of the quantised, dithered GIF frames against the 8-bit tone-mapped
    /// frames (mean over frames; frames kept exactly count as infinite and are left out of the
    /// mean unless all are).
    pub gif_psnr: Option<f64>,
}

/// Write all frames: `.gif` -> one animated, infinitely looping GIF at `fps`; `.png` -> numbered
/// tone-mapped 8-bit frames `stem_0000.png`, `stem_0001.png`, ... beside `path` (just `path`
/// itself when there is one frame); `.exr` -> linear 32-bit float RGB frames numbered the same
/// way, multiplied by the exposure but not tone-mapped. See [`Sink`], which this feeds.
pub fn write(
    path: &Path,
    frames: &[HdrImage],
    settings: &OutputSettings,
) -> Result<Written, OutputError> {
    let mut sink = Sink::create(path, settings, frames.len() > 1)?;
    // Check every frame before writing any, so bad input leaves no partial sequence behind.
    if let Some(first) = frames.first() {
        for (i, f) in frames.iter().enumerate() {
            sink.check(i, f, (first.width, first.height))?;
        }
    }
    for (i, f) in frames.iter().enumerate() {
        sink.push(i, f)?;
    }
    sink.finish()
}

/// Frames written as they come, so memory does not grow with their number. PNG and EXR frames
/// each go to their own file at once; GIF frames are appended to a temporary file beside the
/// output, which [`Sink::finish`] moves into place. Dropping a sink unfinished removes that
/// temporary file; PNG and EXR frames already written stay.
pub struct Sink {
    path: PathBuf,
    format: Format,
    settings: OutputSettings,
    numbered: bool,
    /// The size of the first frame pushed.
    first: Option<(usize, usize)>,
    /// The index of the last frame pushed.
    last: Option<usize>,
    files: Vec<PathBuf>,
    // Visible to the module for its tests, which check how many GIF frames wait.
    pub(super) kind: Kind,
}

pub(super) enum Kind {
    /// PNG or EXR: one file per frame.
    Files,
    /// A GIF before its first frame, whose size the header needs.
    GifPending,
    Gif(GifFile),
    /// A GIF that failed to encode or write a frame: its temporary file is gone, and it cannot be
    /// finished without that frame.
    GifFailed,
}

impl Sink {
    /// A sink for `path`, whose extension chooses the format. `numbered`: frames go to
    /// `stem_NNNN.ext` files (see [`numbered_path`]) by the index given to [`Sink::push`];
    /// otherwise the one frame goes to `path` itself. A GIF is always the one file `path`.
    /// Checks the settings and that `path` can be written; creates nothing that remains.
    pub fn create(
        path: &Path,
        settings: &OutputSettings,
        numbered: bool,
    ) -> Result<Sink, OutputError> {
        let format = Format::from_path(path)?;
        let invalid = |name, value| OutputError::InvalidSetting {
            path: path.to_path_buf(),
            name,
            value,
        };
        if !settings.exposure.is_finite() || settings.exposure < 0.0 {
            return Err(invalid("exposure", settings.exposure));
        }
        if format == Format::Gif && !(settings.fps.is_finite() && settings.fps > 0.0) {
            return Err(invalid("fps", settings.fps));
        }
        if path.is_dir() {
            return Err(OutputError::IsDirectory {
                path: path.to_path_buf(),
            });
        }
        check_directory(path)?;
        Ok(Sink {
            path: path.to_path_buf(),
            format,
            settings: *settings,
            numbered,
            first: None,
            last: None,
            files: Vec::new(),
            kind: if format == Format::Gif {
                Kind::GifPending
            } else {
                Kind::Files
            },
        })
    }

    /// Write frame `index`. Indices increase from push to push, and in a GIF follow on without
    /// gaps; a sink that is not numbered takes one frame. PNG and EXR frames are written
    /// atomically at once, to [`numbered_path`] or `path`; GIF frames are tone-mapped, and once
    /// there is one per thread they are quantised in parallel and appended to the temporary file.
    /// A frame that is rejected leaves the sink as it was; after a GIF fails to encode or write a
    /// frame, every later call fails.
    pub fn push(&mut self, index: usize, frame: &HdrImage) -> Result<(), OutputError> {
        if let Kind::GifFailed = self.kind {
            return Err(self.gif_failed());
        }
        if let Some(previous) = self.last {
            let follows = match self.kind {
                Kind::Files => self.numbered && index > previous,
                _ => previous.checked_add(1) == Some(index),
            };
            if !follows {
                return Err(OutputError::FrameOrder {
                    path: self.path.clone(),
                    frame: index,
                    previous,
                });
            }
        }
        let size = (frame.width, frame.height);
        self.check(index, frame, self.first.unwrap_or(size))?;
        if let Kind::Files = self.kind {
            let target = if self.numbered {
                numbered_path(&self.path, index)
            } else {
                self.path.clone()
            };
            let tmp = write_temp(&target, |w| {
                encode_file(&self.path, self.format, self.settings.exposure, frame, w)
            })?;
            persist(tmp, &target)?;
            self.files.push(target);
        } else {
            let pixels = tonemap::to_srgb8(frame, self.settings.exposure);
            let pushed = match &mut self.kind {
                Kind::Gif(gif) => gif.push(&self.path, pixels),
                // `check` has bounded the size by u16::MAX.
                _ => GifFile::create(&self.path, size.0 as u16, size.1 as u16, self.settings.fps)
                    .and_then(|mut gif| {
                        gif.push(&self.path, pixels)?;
                        self.kind = Kind::Gif(gif);
                        Ok(())
                    }),
            };
            if pushed.is_err() {
                // Dropping the GIF removes its temporary file.
                self.kind = Kind::GifFailed;
            }
            pushed?;
        }
        self.first.get_or_insert(size);
        self.last = Some(index);
        Ok(())
    }

    /// Finish writing: a GIF's last frames are encoded and its temporary file is moved over
    /// `path`. Fails with [`OutputError::NoFrames`] when nothing was pushed.
    pub fn finish(mut self) -> Result<Written, OutputError> {
        let gif_psnr = match self.kind {
            Kind::Files if !self.files.is_empty() => None,
            Kind::Files | Kind::GifPending => {
                return Err(OutputError::NoFrames { path: self.path });
            }
            Kind::Gif(gif) => {
                let psnr = gif.finish(&self.path)?;
                self.files.push(self.path);
                Some(psnr)
            }
            Kind::GifFailed => return Err(self.gif_failed()),
        };
        Ok(Written {
            files: self.files,
            gif_psnr,
        })
    }

    /// Frame `index` is non-empty, its buffer matches its size, and it fits the format and, in a
    /// GIF, the size `first` of the animation's first frame.
    fn check(&self, index: usize, f: &HdrImage, first: (usize, usize)) -> Result<(), OutputError> {
        let path = self.path.clone();
        if f.width == 0 || f.height == 0 {
            return Err(OutputError::EmptyFrame {
                path,
                frame: index,
                width: f.width,
                height: f.height,
            });
        }
        let Some(expected) = f.width.checked_mul(f.height) else {
            return Err(OutputError::ImpossibleSize { path, frame: index });
        };
        if expected != f.data.len() {
            return Err(OutputError::BadFrameData {
                path,
                frame: index,
                expected,
                actual: f.data.len(),
            });
        }
        let limit = match self.format {
            Format::Gif if (f.width, f.height) != first => {
                return Err(OutputError::MismatchedFrames {
                    path,
                    frame: index,
                    size: (f.width, f.height),
                    first,
                });
            }
            Format::Gif => u16::MAX as usize,
            Format::Png => u32::MAX as usize,
            Format::Exr => return Ok(()),
        };
        if f.width > limit || f.height > limit {
            return Err(OutputError::TooLarge {
                path,
                format: self.format,
                width: f.width,
                height: f.height,
                limit,
            });
        }
        Ok(())
    }

    fn gif_failed(&self) -> OutputError {
        OutputError::Encode {
            path: self.path.clone(),
            format: Format::Gif,
            message: "an earlier frame failed".to_string(),
        }
    }
}

/// Encode one PNG or EXR frame.
fn encode_file(
    path: &Path,
    format: Format,
    exposure: f64,
    f: &HdrImage,
    w: &mut BufWriter<&mut fs::File>,
) -> Result<(), OutputError> {
    let encoded = if format == Format::Png {
        let pixels = tonemap::to_srgb8(f, exposure);
        png::encode(w, &pixels, f.width as u32, f.height as u32).map_err(|e| e.to_string())
    } else {
        openexr::encode(w, f, exposure).map_err(|e| e.to_string())
    };
    encoded.map_err(|message| OutputError::Encode {
        path: path.to_path_buf(),
        format,
        message,
    })
}

/// A GIF being written to a temporary file beside the output. Frames wait, tone-mapped, until
/// there is one per thread, because quantising is the slow part and frames quantise in parallel.
pub(super) struct GifFile {
    // Declared before `temp`, so the file is closed before the temporary path removes it.
    writer: gif::Writer<BufWriter<fs::File>>,
    temp: TempPath,
    pub(super) pending: Vec<Vec<[u8; 3]>>,
    pub(super) batch: usize,
}

impl GifFile {
    fn create(path: &Path, width: u16, height: u16, fps: f64) -> Result<GifFile, OutputError> {
        let (file, temp) = NamedTempFile::new_in(dir_for_io(parent_dir(path)))
            .map_err(io_error(path))?
            .into_parts();
        let writer =
            gif::Writer::new(BufWriter::new(file), width, height, fps).map_err(gif_error(path))?;
        Ok(GifFile {
            writer,
            temp,
            pending: Vec::new(),
            batch: rayon::current_num_threads().max(1),
        })
    }

    fn push(&mut self, path: &Path, pixels: Vec<[u8; 3]>) -> Result<(), OutputError> {
        self.pending.push(pixels);
        if self.pending.len() >= self.batch {
            self.flush(path)?;
        }
        Ok(())
    }

    fn flush(&mut self, path: &Path) -> Result<(), OutputError> {
        self.writer
            .write_frames(&self.pending)
            .map_err(gif_error(path))?;
        self.pending.clear();
        Ok(())
    }

    /// Encode the waiting frames, end the file, flush it to disk and move it over `path`.
    /// Returns the mean PSNR of the frames.
    fn finish(mut self, path: &Path) -> Result<f64, OutputError> {
        self.flush(path)?;
        let (w, psnr) = self.writer.finish().map_err(gif_error(path))?;
        let file = w.into_inner().map_err(|e| io_error(path)(e.into_error()))?;
        file.sync_all().map_err(io_error(path))?;
        drop(file);
        persist(self.temp, path)?;
        Ok(psnr)
    }
}

/// A GIF encoder's error as an [`OutputError`] on `path`.
fn gif_error(path: &Path) -> impl Fn(::gif::EncodingError) -> OutputError + '_ {
    move |e| match e {
        ::gif::EncodingError::Io(source) => io_error(path)(source),
        e => OutputError::Encode {
            path: path.to_path_buf(),
            format: Format::Gif,
            message: e.to_string(),
        },
    }
}
