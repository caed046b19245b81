//! Why output could not be written: one error type, each message a sentence after `error: `.

use super::Format;
use std::io;
use std::path::{Path, PathBuf};

/// Why output could not be written.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The extension is not one of .gif, .png, .exr.
    #[error("unknown output format `.{extension}` (expected .gif, .png or .exr)")]
    UnknownFormat {
        /// The output path.
        path: PathBuf,
        /// The extension given, without the dot.
        extension: String,
    },
    /// The path has no extension.
    #[error("output file `{}` has no extension (expected .gif, .png or .exr)", .path.display())]
    NoExtension {
        /// The output path.
        path: PathBuf,
    },
    /// The directory the file would go in does not exist.
    #[error("cannot write `{}`: directory `{}` does not exist", .path.display(), show_dir(.dir))]
    MissingDirectory {
        /// The file that was being written.
        path: PathBuf,
        /// The directory, as taken from the path (empty for a bare file name).
        dir: PathBuf,
    },
    /// The "directory" the file would go in is not a directory.
    #[error("cannot write `{}`: `{}` is not a directory", .path.display(), show_dir(.dir))]
    NotADirectory {
        /// The file that was being written.
        path: PathBuf,
        /// The directory, as taken from the path (empty for a bare file name).
        dir: PathBuf,
    },
    /// A file cannot be created in the directory.
    #[error(
        "cannot write `{}`: directory `{}` is not writable ({source})",
        .path.display(),
        show_dir(.dir)
    )]
    DirectoryNotWritable {
        /// The file that was being written.
        path: PathBuf,
        /// The directory, as taken from the path (empty for a bare file name).
        dir: PathBuf,
        /// The operating system's error.
        source: io::Error,
    },
    /// The output path is an existing directory.
    #[error("cannot write `{}`: it is a directory", .path.display())]
    IsDirectory {
        /// The output path.
        path: PathBuf,
    },
    /// The output path is the scene file being rendered.
    #[error("`{}` is the scene file; refusing to overwrite it", .path.display())]
    IsInput {
        /// The output path, the same file as the scene.
        path: PathBuf,
    },
    /// No frames were given.
    #[error("cannot write `{}`: there are no frames", .path.display())]
    NoFrames {
        /// The file that was being written.
        path: PathBuf,
    },
    /// A frame has a zero width or height.
    #[error("cannot write `{}`: frame {frame} is empty ({width}x{height})", .path.display())]
    EmptyFrame {
        /// The file that was being written.
        path: PathBuf,
        /// The frame's index among those written (0-based).
        frame: usize,
        /// Width in pixels.
        width: usize,
        /// Height in pixels.
        height: usize,
    },
    /// A frame's pixel buffer does not hold `width * height` pixels.
    #[error(
        "cannot write `{}`: frame {frame} has {actual} pixels, expected {expected}",
        .path.display()
    )]
    BadFrameData {
        /// The file that was being written.
        path: PathBuf,
        /// The frame's index among those written (0-based).
        frame: usize,
        /// `width * height`.
        expected: usize,
        /// Pixels the buffer holds.
        actual: usize,
    },
    /// A frame's `width * height` overflows `usize`.
    #[error("cannot write `{}`: frame {frame} is impossibly large", .path.display())]
    ImpossibleSize {
        /// The file that was being written.
        path: PathBuf,
        /// The frame's index among those written (0-based).
        frame: usize,
    },
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
        /// The file that was being written.
        path: PathBuf,
        /// The frame's index among those written (0-based).
        frame: usize,
        /// This frame's width and height.
        size: (usize, usize),
        /// The first frame's width and height.
        first: (usize, usize),
    },
    /// The frame is larger than the format can store.
    #[error(
        "cannot write `{}`: {width}x{height} is too large for {format} (at most {limit} per side)",
        .path.display()
    )]
    TooLarge {
        /// The file that was being written.
        path: PathBuf,
        /// The format being encoded.
        format: Format,
        /// Width in pixels.
        width: usize,
        /// Height in pixels.
        height: usize,
        /// The format's largest side, in pixels.
        limit: usize,
    },
    /// Exposure or fps is not a usable number.
    #[error("cannot write `{}`: invalid {name} {value}", .path.display())]
    InvalidSetting {
        /// The file that was being written.
        path: PathBuf,
        /// Which setting: `exposure` or `fps`.
        name: &'static str,
        /// The value given: negative or not finite (or, for `fps`, zero).
        value: f64,
    },
    /// A frame was pushed out of order: not after the one before, not straight after it in a
    /// GIF, or a second one into a single file.
    #[error("cannot write `{}`: frame {frame} cannot follow frame {previous}", .path.display())]
    FrameOrder {
        /// The file that was being written.
        path: PathBuf,
        /// The frame pushed.
        frame: usize,
        /// The frame pushed before it.
        previous: usize,
    },
    /// Reading or writing failed.
    #[error("cannot write `{}`: {source}", .path.display())]
    Io {
        /// The file that was being written.
        path: PathBuf,
        /// The operating system's error.
        source: io::Error,
    },
    /// The encoder failed.
    #[error("cannot write `{}`: {format} encoding failed: {message}", .path.display())]
    Encode {
        /// The file that was being written.
        path: PathBuf,
        /// The format being encoded.
        format: Format,
        /// The encoder's reason.
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
