//! Turning rendered linear-HDR frames into files: an animated GIF, numbered PNGs or numbered
//! OpenEXRs, chosen by the output path's extension.
//!
//! Every file is written atomically: into a temporary file in the same directory, which is
//! renamed over the destination only once it is complete.

mod gif;
mod openexr;
#[cfg(unix)]
mod permissions;
pub(crate) mod png;
pub mod tonemap;

use std::ffi::OsString;
use std::fmt;
use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use tempfile::{NamedTempFile, TempPath};

/// One linear-HDR frame, row-major from the top-left pixel, RGB radiance.
#[derive(Clone, Debug, PartialEq)]
pub struct HdrImage {
    pub width: usize,
    pub height: usize,
    pub data: Vec<[f32; 3]>,
}

impl HdrImage {
    /// A black image.
    ///
    /// # Panics
    /// If `width * height` overflows `usize`.
    pub fn new(width: usize, height: usize) -> Self {
        let n = width
            .checked_mul(height)
            .expect("image size overflows usize");
        HdrImage {
            width,
            height,
            data: vec![[0.0; 3]; n],
        }
    }

    /// An image whose pixel `(x, y)` is `f(x, y)`.
    pub fn from_fn(
        width: usize,
        height: usize,
        mut f: impl FnMut(usize, usize) -> [f32; 3],
    ) -> Self {
        let mut img = HdrImage::new(width, height);
        for y in 0..height {
            for x in 0..width {
                img.data[y * width + x] = f(x, y);
            }
        }
        img
    }
}

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
            _ => Err(OutputError::UnknownFormat {
                path: path.to_path_buf(),
                extension: ext,
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
#[derive(Debug)]
pub enum OutputError {
    /// The extension is missing or not one of .gif, .png, .exr.
    UnknownFormat {
        path: PathBuf,
        extension: Option<String>,
    },
    /// The directory the file would go in does not exist.
    MissingDirectory { path: PathBuf, dir: PathBuf },
    /// The "directory" the file would go in is not a directory.
    NotADirectory { path: PathBuf, dir: PathBuf },
    /// A file cannot be created in the directory.
    DirectoryNotWritable {
        path: PathBuf,
        dir: PathBuf,
        source: io::Error,
    },
    /// The output path is an existing directory.
    IsDirectory { path: PathBuf },
    /// The output path is the scene file being rendered.
    IsInput { path: PathBuf },
    /// No frames were given.
    NoFrames { path: PathBuf },
    /// A frame has a zero width or height.
    EmptyFrame {
        path: PathBuf,
        frame: usize,
        width: usize,
        height: usize,
    },
    /// A frame's pixel buffer does not hold `width * height` pixels.
    BadFrameData {
        path: PathBuf,
        frame: usize,
        expected: Option<usize>,
        actual: usize,
    },
    /// The frames of an animation differ in size.
    MismatchedFrames {
        path: PathBuf,
        frame: usize,
        size: (usize, usize),
        first: (usize, usize),
    },
    /// The frame is larger than the format can store.
    TooLarge {
        path: PathBuf,
        format: Format,
        width: usize,
        height: usize,
        limit: usize,
    },
    /// Exposure or fps is not a usable number.
    InvalidSetting {
        path: PathBuf,
        name: &'static str,
        value: f64,
    },
    /// Reading or writing failed.
    Io { path: PathBuf, source: io::Error },
    /// The encoder failed.
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

impl fmt::Display for OutputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use OutputError::*;
        match self {
            UnknownFormat {
                extension: Some(ext),
                ..
            } => write!(
                f,
                "unknown output format `.{ext}` (expected .gif, .png or .exr)"
            ),
            UnknownFormat {
                path,
                extension: None,
            } => write!(
                f,
                "output file `{}` has no extension (expected .gif, .png or .exr)",
                path.display()
            ),
            MissingDirectory { path, dir } => write!(
                f,
                "cannot write `{}`: directory `{}` does not exist",
                path.display(),
                show_dir(dir)
            ),
            NotADirectory { path, dir } => write!(
                f,
                "cannot write `{}`: `{}` is not a directory",
                path.display(),
                show_dir(dir)
            ),
            DirectoryNotWritable { path, dir, source } => write!(
                f,
                "cannot write `{}`: directory `{}` is not writable ({source})",
                path.display(),
                show_dir(dir)
            ),
            IsDirectory { path } => {
                write!(f, "cannot write `{}`: it is a directory", path.display())
            }
            IsInput { path } => write!(
                f,
                "`{}` is the scene file; refusing to overwrite it",
                path.display()
            ),
            NoFrames { path } => {
                write!(f, "cannot write `{}`: there are no frames", path.display())
            }
            EmptyFrame {
                path,
                frame,
                width,
                height,
            } => write!(
                f,
                "cannot write `{}`: frame {frame} is empty ({width}x{height})",
                path.display()
            ),
            BadFrameData {
                path,
                frame,
                expected,
                actual,
            } => match expected {
                Some(n) => write!(
                    f,
                    "cannot write `{}`: frame {frame} has {actual} pixels, expected {n}",
                    path.display()
                ),
                None => write!(
                    f,
                    "cannot write `{}`: frame {frame} is impossibly large",
                    path.display()
                ),
            },
            MismatchedFrames {
                path,
                frame,
                size,
                first,
            } => write!(
                f,
                "cannot write `{}`: frame {frame} is {}x{} but frame 0 is {}x{}",
                path.display(),
                size.0,
                size.1,
                first.0,
                first.1
            ),
            TooLarge {
                path,
                format,
                width,
                height,
                limit,
            } => write!(
                f,
                "cannot write `{}`: {width}x{height} is too large for {format} (at most {limit} per side)",
                path.display()
            ),
            InvalidSetting { path, name, value } => write!(
                f,
                "cannot write `{}`: invalid {name} {value}",
                path.display()
            ),
            Io { path, source } => write!(f, "cannot write `{}`: {source}", path.display()),
            Encode {
                path,
                format,
                message,
            } => write!(
                f,
                "cannot write `{}`: {format} encoding failed: {message}",
                path.display()
            ),
        }
    }
}

impl std::error::Error for OutputError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            OutputError::DirectoryNotWritable { source, .. } | OutputError::Io { source, .. } => {
                Some(source)
            }
            _ => None,
        }
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

/// Frames are non-empty and their buffers match their sizes.
fn validate(
    path: &Path,
    frames: &[HdrImage],
    settings: &OutputSettings,
) -> Result<(), OutputError> {
    if frames.is_empty() {
        return Err(OutputError::NoFrames {
            path: path.to_path_buf(),
        });
    }
    for (i, f) in frames.iter().enumerate() {
        if f.width == 0 || f.height == 0 {
            return Err(OutputError::EmptyFrame {
                path: path.to_path_buf(),
                frame: i,
                width: f.width,
                height: f.height,
            });
        }
        let expected = f.width.checked_mul(f.height);
        if expected != Some(f.data.len()) {
            return Err(OutputError::BadFrameData {
                path: path.to_path_buf(),
                frame: i,
                expected,
                actual: f.data.len(),
            });
        }
    }
    if !settings.exposure.is_finite() || settings.exposure < 0.0 {
        return Err(OutputError::InvalidSetting {
            path: path.to_path_buf(),
            name: "exposure",
            value: settings.exposure,
        });
    }
    Ok(())
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

/// Encode every frame into its own temporary file (in parallel), then move them all into place,
/// so an encoding failure leaves no partial sequence behind.
fn write_numbered(
    path: &Path,
    count: usize,
    encode: impl Fn(usize, &mut BufWriter<&mut fs::File>) -> Result<(), OutputError> + Sync,
) -> Result<Vec<PathBuf>, OutputError> {
    let targets: Vec<PathBuf> = if count == 1 {
        vec![path.to_path_buf()]
    } else {
        (0..count).map(|i| numbered_path(path, i)).collect()
    };
    let temps: Vec<TempPath> = targets
        .par_iter()
        .enumerate()
        .map(|(i, target)| write_temp(target, |w| encode(i, w)))
        .collect::<Result<_, _>>()?;
    for (tmp, target) in temps.into_iter().zip(&targets) {
        persist(tmp, target)?;
    }
    Ok(targets)
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
/// way, multiplied by the exposure but not tone-mapped.
pub fn write(
    path: &Path,
    frames: &[HdrImage],
    settings: &OutputSettings,
) -> Result<Written, OutputError> {
    let format = Format::from_path(path)?;
    validate(path, frames, settings)?;
    if path.is_dir() {
        return Err(OutputError::IsDirectory {
            path: path.to_path_buf(),
        });
    }
    check_directory(path)?;
    match format {
        Format::Gif => write_gif(path, frames, settings),
        Format::Png | Format::Exr => {
            if format == Format::Png {
                let limit = u32::MAX as usize;
                for f in frames {
                    if f.width > limit || f.height > limit {
                        return Err(too_large(path, format, f, limit));
                    }
                }
            }
            let files = write_numbered(path, frames.len(), |i, w| {
                let f = &frames[i];
                let encoded = if format == Format::Png {
                    let pixels = tonemap::to_srgb8(f, settings.exposure);
                    png::encode(w, &pixels, f.width as u32, f.height as u32)
                        .map_err(|e| e.to_string())
                } else {
                    openexr::encode(w, f, settings.exposure).map_err(|e| e.to_string())
                };
                encoded.map_err(|message| OutputError::Encode {
                    path: path.to_path_buf(),
                    format,
                    message,
                })
            })?;
            Ok(Written {
                files,
                gif_psnr: None,
            })
        }
    }
}

fn too_large(path: &Path, format: Format, f: &HdrImage, limit: usize) -> OutputError {
    OutputError::TooLarge {
        path: path.to_path_buf(),
        format,
        width: f.width,
        height: f.height,
        limit,
    }
}

fn write_gif(
    path: &Path,
    frames: &[HdrImage],
    settings: &OutputSettings,
) -> Result<Written, OutputError> {
    if !settings.fps.is_finite() || settings.fps <= 0.0 {
        return Err(OutputError::InvalidSetting {
            path: path.to_path_buf(),
            name: "fps",
            value: settings.fps,
        });
    }
    let first = &frames[0];
    for (i, f) in frames.iter().enumerate() {
        if (f.width, f.height) != (first.width, first.height) {
            return Err(OutputError::MismatchedFrames {
                path: path.to_path_buf(),
                frame: i,
                size: (f.width, f.height),
                first: (first.width, first.height),
            });
        }
    }
    let limit = u16::MAX as usize;
    if first.width > limit || first.height > limit {
        return Err(too_large(path, Format::Gif, first, limit));
    }
    let pixels: Vec<Vec<[u8; 3]>> = frames
        .par_iter()
        .map(|f| tonemap::to_srgb8(f, settings.exposure))
        .collect();
    let mut psnr = 0.0;
    let tmp = write_temp(path, |w| {
        psnr = gif::encode(
            w,
            &pixels,
            first.width as u16,
            first.height as u16,
            settings.fps,
        )
        .map_err(|e| match e {
            ::gif::EncodingError::Io(source) => io_error(path)(source),
            e => OutputError::Encode {
                path: path.to_path_buf(),
                format: Format::Gif,
                message: e.to_string(),
            },
        })?;
        Ok(())
    })?;
    persist(tmp, path)?;
    Ok(Written {
        files: vec![path.to_path_buf()],
        gif_psnr: Some(psnr),
    })
}

#[cfg(test)]
mod tests;
