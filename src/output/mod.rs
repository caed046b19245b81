//! Turning rendered linear-HDR frames into files: an animated GIF, numbered PNGs or numbered
//! OpenEXRs, chosen by the output path's extension.
//!
//! Frames are written as they come through a [`Sink`]. Every file is written atomically: into a
//! temporary file in the same directory, which is renamed over the destination only once it is
//! complete, with the mode a file created in place would have.
//!
//! `sink` encodes frames (through `gif`, `png`, `openexr` and [`tonemap`]) and hands the bytes
//! to `files`, which writes them; both report an [`OutputError`].

mod error;
mod files;
mod gif;
mod openexr;
#[cfg(unix)]
mod permissions;
pub(crate) mod png;
mod sink;
pub mod tonemap;

pub use crate::image::HdrImage;
pub use error::OutputError;
pub use files::{check_writable, numbered_path, stale_frames, write_atomic, write_derived};
pub use sink::{Sink, Written, write};

use std::fmt;
use std::path::Path;

/// The output format, chosen from the file extension (`.gif`, `.png`, `.exr`; case-insensitive).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Format {
    /// One animated, looping GIF of all frames, tone-mapped, quantised and dithered to 256 colours.
    Gif,
    /// Tone-mapped 8-bit frames, numbered when there are several.
    Png,
    /// Linear 32-bit float RGB frames, numbered when there are several.
    Exr,
}

impl Format {
    /// The format `path`'s extension names; fails with [`OutputError::UnknownFormat`] or
    /// [`OutputError::NoExtension`].
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

#[cfg(test)]
mod tests;
