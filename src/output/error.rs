//! Why output could not be written: one error type, each message a sentence after `error: `.

use super::Format;
use std::io;
use std::path::{Path, PathBuf};

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
