//! Turning rendered linear-HDR frames into files: an animated GIF, numbered PNGs or numbered
//! OpenEXRs, chosen by the output path's extension.
//!
//! Frames are written as they come through a [`Sink`]. Every file is written atomically: into a
//! temporary file in the same directory, which is renamed over the destination only once it is
//! complete, with the mode a file created in place would have.

mod gif;
mod openexr;
#[cfg(unix)]
mod permissions;
pub(crate) mod png;
pub mod tonemap;

use std::ffi::{OsStr, OsString};
use std::fmt;
use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use tempfile::{NamedTempFile, TempPath};

pub use crate::image::HdrImage;

/// The output format, chosen from the file extension (`.gif`, `.png`, `.exr`; case-insensitive).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Format {
    Gif,
    Png,
    Exr,
}

impl Format {
    pub fn from_path(path: &Path) -> Result<Format, OutputError> {
        let ext = path.extension().map(|e| e.to_string_lossy().into_owned());
        match ext.as_deref().map(str::to_ascii_lowercase).as_deref() {
            Some("gif") => Ok(Format::Gif),
            Some("png") => Ok(Format::Png),
            Some("exr") => Ok(Format::Exr),
            _ => Err(match ext {
                Some(extension) => OutputError::UnknownFormat {
                    path: path.to_path_buf(),
                    extension,
                },
                None => OutputError::NoExtension {
                    path: path.to_path_buf(),
                },
            }),
        }
    }

    /// The usual extension, without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Gif => "gif",
            Format::Png => "png",
            Format::Exr => "exr",
        }
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Format::Gif => "GIF",
            Format::Png => "PNG",
            Format::Exr => "OpenEXR",
        })
    }
}

/// How frames are turned into files.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OutputSettings {
    /// Linear scale applied to the radiance before tone mapping (GIF, PNG) or before storing
    /// (EXR, which is otherwise left linear).
    pub exposure: f64,
    /// Frames per second of an animated GIF.
    pub fps: f64,
}

impl Default for OutputSettings {
    fn default() -> Self {
        OutputSettings {
            exposure: 1.0,
            fps: 24.0,
        }
    }
}

/// What was written, for the summary the CLI prints.
#[derive(Clone, Debug, PartialEq)]
pub struct Written {
    pub files: Vec<PathBuf>,
    /// GIF only: PSNR (dB) of the quantised, dithered GIF frames against the 8-bit tone-mapped
    /// frames (mean over frames; frames kept exactly count as infinite and are left out of the
    /// mean unless all are).
    pub gif_psnr: Option<f64>,
}

/// Why output could not be written.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The extension is not one of .gif, .png, .exr.
    #[error("unknown output format `.{extension}` (expected .gif, .png or .exr)")]
    UnknownFormat { path: PathBuf, extension: String },
    /// The path has no extension.
    #[error("output file `{}` has no extension (expected .gif, .png or .exr)", .path.display())]
    NoExtension { path: PathBuf },
    /// The directory the file would go in does not exist.
    #[error("cannot write `{}`: directory `{}` does not exist", .path.display(), show_dir(.dir))]
    MissingDirectory { path: PathBuf, dir: PathBuf },
    /// The "directory" the file would go in is not a directory.
    #[error("cannot write `{}`: `{}` is not a directory", .path.display(), show_dir(.dir))]
    NotADirectory { path: PathBuf, dir: PathBuf },
    /// A file cannot be created in the directory.
    #[error(
        "cannot write `{}`: directory `{}` is not writable ({source})",
        .path.display(),
        show_dir(.dir)
    )]
    DirectoryNotWritable {
        path: PathBuf,
        dir: PathBuf,
        source: io::Error,
    },
    /// The output path is an existing directory.
    #[error("cannot write `{}`: it is a directory", .path.display())]
    IsDirectory { path: PathBuf },
    /// The output path is the scene file being rendered.
    #[error("`{}` is the scene file; refusing to overwrite it", .path.display())]
    IsInput { path: PathBuf },
    /// No frames were given.
    #[error("cannot write `{}`: there are no frames", .path.display())]
    NoFrames { path: PathBuf },
    /// A frame has a zero width or height.
    #[error("cannot write `{}`: frame {frame} is empty ({width}x{height})", .path.display())]
    EmptyFrame {
        path: PathBuf,
        frame: usize,
        width: usize,
        height: usize,
    },
    /// A frame's pixel buffer does not hold `width * height` pixels.
    #[error(
        "cannot write `{}`: frame {frame} has {actual} pixels, expected {expected}",
        .path.display()
    )]
    BadFrameData {
        path: PathBuf,
        frame: usize,
        expected: usize,
        actual: usize,
    },
    /// A frame's `width * height` overflows `usize`.
    #[error("cannot write `{}`: frame {frame} is impossibly large", .path.display())]
    ImpossibleSize { path: PathBuf, frame: usize },
    /// The frames of an animation differ in size.
    #[error(
        "cannot write `{}`: frame {frame} is {}x{} but frame 0 is {}x{}",
        .path.display(),
        .size.0,
        .size.1,
        .first.0,
        .first.1
    )]
    MismatchedFrames {
        path: PathBuf,
        frame: usize,
        size: (usize, usize),
        first: (usize, usize),
    },
    /// The frame is larger than the format can store.
    #[error(
        "cannot write `{}`: {width}x{height} is too large for {format} (at most {limit} per side)",
        .path.display()
    )]
    TooLarge {
        path: PathBuf,
        format: Format,
        width: usize,
        height: usize,
        limit: usize,
    },
    /// Exposure or fps is not a usable number.
    #[error("cannot write `{}`: invalid {name} {value}", .path.display())]
    InvalidSetting {
        path: PathBuf,
        name: &'static str,
        value: f64,
    },
    /// A frame was pushed out of order: not after the one before, not straight after it in a
    /// GIF, or a second one into a single file.
    #[error("cannot write `{}`: frame {frame} cannot follow frame {previous}", .path.display())]
    FrameOrder {
        path: PathBuf,
        frame: usize,
        previous: usize,
    },
    /// Reading or writing failed.
    #[error("cannot write `{}`: {source}", .path.display())]
    Io { path: PathBuf, source: io::Error },
    /// The encoder failed.
    #[error("cannot write `{}`: {format} encoding failed: {message}", .path.display())]
    Encode {
        path: PathBuf,
        format: Format,
        message: String,
    },
}

/// `dir` for display: the empty parent of a bare file name is the current directory.
fn show_dir(dir: &Path) -> String {
    if dir.as_os_str().is_empty() {
        ".".to_string()
    } else {
        dir.display().to_string()
    }
}

/// The directory `path` goes in (`""` for a bare file name, meaning the current directory).
fn parent_dir(path: &Path) -> &Path {
    path.parent().unwrap_or(Path::new(""))
}

/// `dir` as something to open: the current directory when empty.
fn dir_for_io(dir: &Path) -> &Path {
    if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    }
}

/// The directory exists, is a directory, and a file can be created there (the probe file is
/// removed again at once).
fn check_directory(path: &Path) -> Result<(), OutputError> {
    let dir = parent_dir(path);
    match fs::metadata(dir_for_io(dir)) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => {
            return Err(OutputError::NotADirectory {
                path: path.to_path_buf(),
                dir: dir.to_path_buf(),
            });
        }
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            return Err(OutputError::MissingDirectory {
                path: path.to_path_buf(),
                dir: dir.to_path_buf(),
            });
        }
        Err(e) => {
            return Err(OutputError::DirectoryNotWritable {
                path: path.to_path_buf(),
                dir: dir.to_path_buf(),
                source: e,
            });
        }
    }
    NamedTempFile::new_in(dir_for_io(dir))
        .map(drop)
        .map_err(|source| OutputError::DirectoryNotWritable {
            path: path.to_path_buf(),
            dir: dir.to_path_buf(),
            source,
        })
}

/// Whether `a` and `b` name the same file. Existing paths are compared canonicalised; a path
/// that does not exist yet is compared by its canonical directory and file name.
fn same_file(a: &Path, b: &Path) -> bool {
    fn canonical(p: &Path) -> Option<PathBuf> {
        if let Ok(c) = fs::canonicalize(p) {
            return Some(c);
        }
        let dir = fs::canonicalize(dir_for_io(parent_dir(p))).ok()?;
        Some(dir.join(p.file_name()?))
    }
    match (canonical(a), canonical(b)) {
        (Some(a), Some(b)) => a == b,
        _ => a == b,
    }
}

/// Check before rendering that `path` can be written: it is not the scene file `input`, not a
/// directory, its extension is known, and its directory exists and is writable. Creates nothing
/// that remains.
pub fn check_writable(path: &Path, input: &Path) -> Result<Format, OutputError> {
    if same_file(path, input) {
        return Err(OutputError::IsInput {
            path: path.to_path_buf(),
        });
    }
    if path.is_dir() || path.file_name().is_none() {
        return Err(OutputError::IsDirectory {
            path: path.to_path_buf(),
        });
    }
    let format = Format::from_path(path)?;
    check_directory(path)?;
    Ok(format)
}

/// The file frame `index` of a numbered sequence goes to: `stem_0000.ext` beside `path`.
pub fn numbered_path(path: &Path, index: usize) -> PathBuf {
    let mut name = OsString::from(path.file_stem().unwrap_or_default());
    name.push(format!("_{index:04}"));
    if let Some(ext) = path.extension() {
        name.push(".");
        name.push(ext);
    }
    path.with_file_name(name)
}

/// Create a temporary file beside `path`, fill it with `fill`, and flush it to disk. The file
/// is deleted again if anything fails, or when the returned path is dropped unpersisted.
fn write_temp(
    path: &Path,
    fill: impl FnOnce(&mut BufWriter<&mut fs::File>) -> Result<(), OutputError>,
) -> Result<TempPath, OutputError> {
    let io_err = io_error(path);
    let mut tmp = NamedTempFile::new_in(dir_for_io(parent_dir(path))).map_err(io_err)?;
    {
        let mut w = BufWriter::new(tmp.as_file_mut());
        fill(&mut w)?;
        w.flush().map_err(io_err)?;
    }
    tmp.as_file().sync_all().map_err(io_err)?;
    Ok(tmp.into_temp_path())
}

/// Move a finished temporary file to `target`, with the mode a file created or overwritten in
/// place would have.
fn persist(tmp: TempPath, target: &Path) -> Result<(), OutputError> {
    #[cfg(unix)]
    fs::set_permissions(&tmp, permissions::for_target(target)).map_err(io_error(target))?;
    tmp.persist(target).map_err(|e| io_error(target)(e.error))
}

/// Write `bytes` to `path` atomically: into a temporary file beside it, flushed to disk, then
/// renamed over `path`.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    let tmp = write_temp(path, |w| w.write_all(bytes).map_err(io_error(path)))?;
    persist(tmp, path)
}

/// [`write_atomic`] for a file made from the scene `input` (such as its compiled IR), refusing
/// to overwrite the scene itself.
pub fn write_derived(path: &Path, input: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    if same_file(path, input) {
        return Err(OutputError::IsInput {
            path: path.to_path_buf(),
        });
    }
    check_directory(path)?;
    write_atomic(path, bytes)
}

/// [`OutputError::Io`] on `path`.
fn io_error(path: &Path) -> impl Fn(io::Error) -> OutputError + Copy + '_ {
    move |source| OutputError::Io {
        path: path.to_path_buf(),
        source,
    }
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
    kind: Kind,
}

enum Kind {
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
struct GifFile {
    // Declared before `temp`, so the file is closed before the temporary path removes it.
    writer: gif::Writer<BufWriter<fs::File>>,
    temp: TempPath,
    pending: Vec<Vec<[u8; 3]>>,
    batch: usize,
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

/// Numbered frames of `path` from an earlier run that `written` does not list: the files beside
/// `path` named `stem_NNNN.ext` (four or more digits; the extension in any case), spelt as
/// [`numbered_path`] spells them, sorted. Empty when the directory cannot be read.
pub fn stale_frames(path: &Path, written: &[PathBuf]) -> Vec<PathBuf> {
    let Some(stem) = path.file_stem() else {
        return Vec::new();
    };
    let Ok(entries) = fs::read_dir(dir_for_io(parent_dir(path))) else {
        return Vec::new();
    };
    let mut stale: Vec<PathBuf> = entries
        .filter_map(Result::ok)
        .map(|e| e.file_name())
        .filter(|name| is_numbered_name(name, stem, path.extension()))
        .map(|name| path.with_file_name(name))
        .filter(|p| p.is_file() && !written.contains(p))
        .collect();
    stale.sort();
    stale
}

/// Whether `name` is `stem_NNNN.ext` (or `stem_NNNN` without an extension), with four or more
/// digits and `ext` in any case.
fn is_numbered_name(name: &OsStr, stem: &OsStr, ext: Option<&OsStr>) -> bool {
    let Some(rest) = name
        .as_encoded_bytes()
        .strip_prefix(stem.as_encoded_bytes())
        .and_then(|r| r.strip_prefix(b"_"))
    else {
        return false;
    };
    let digits = rest.iter().take_while(|b| b.is_ascii_digit()).count();
    let rest = &rest[digits..];
    digits >= 4
        && match ext {
            Some(ext) => rest
                .strip_prefix(b".")
                .is_some_and(|e| e.eq_ignore_ascii_case(ext.as_encoded_bytes())),
            None => rest.is_empty(),
        }
}

#[cfg(test)]
mod tests;
