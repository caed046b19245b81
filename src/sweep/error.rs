//! What can go wrong in the speed/accuracy sweep: its reference, the directory its results go
//! in, and the plot.

use std::path::PathBuf;

/// Why the sweep could not run or write its results.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// The directory results were to be written into is something else.
    #[error("cannot write results into `{}`: it is not a directory", .path.display())]
    NotADirectory { path: PathBuf },

    /// No file can be created in the directory results were to be written into.
    #[error(
        "cannot write results into `{}`: directory is not writable ({source})",
        .path.display()
    )]
    DirectoryNotWritable {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },

    /// The sweep has no configuration to measure.
    #[error("nothing to measure: the sample-count list is empty")]
    NothingToMeasure,

    /// The reference file named does not exist (nor do numbered frames beside it).
    #[error("reference `{}` does not exist", .path.display())]
    ReferenceMissing { path: PathBuf },

    /// One of the numbered frames of the reference does not exist.
    #[error("reference frame `{}` does not exist", .path.display())]
    ReferenceFrameMissing { path: PathBuf },

    /// The reference is one file, but the sweep renders several frames.
    #[error(
        "reference `{}` is one frame but the sweep renders {frames} (give --frames 1, or numbered frames like `{}`)",
        .path.display(),
        .numbered.display()
    )]
    ReferenceOneFrame {
        path: PathBuf,
        frames: usize,
        /// The first numbered frame's file name, as an example.
        numbered: PathBuf,
    },

    /// A reference frame is not a readable OpenEXR.
    #[error("cannot read reference `{}`: {source}", .path.display())]
    ReferenceUnreadable {
        path: PathBuf,
        #[source]
        source: exr::error::Error,
    },

    /// A reference frame's size is not the sweep's.
    #[error(
        "reference `{}` is {}x{} but the sweep renders {}x{} (give --size {}x{})",
        .path.display(),
        .size.0,
        .size.1,
        .expected.0,
        .expected.1,
        .size.0,
        .size.1
    )]
    ReferenceSize {
        path: PathBuf,
        size: (usize, usize),
        expected: (usize, usize),
    },

    /// A reference frame holds NaN or infinite pixels.
    #[error("reference `{}` holds NaN or infinite pixels", .path.display())]
    ReferenceNotFinite { path: PathBuf },

    /// A configuration renders another size or frame count than the reference holds.
    #[error(
        "the reference is {}x{} with {} frames but `{config}` renders {}x{} with {}",
        .reference.0,
        .reference.1,
        .reference.2,
        .renders.0,
        .renders.1,
        .renders.2
    )]
    ReferenceMismatch {
        /// The reference's width, height and frame count.
        reference: (usize, usize, usize),
        /// The configuration's label.
        config: String,
        /// The configuration's width, height and frame count.
        renders: (u32, u32, u32),
    },

    /// No font for the plot's text was found.
    #[error("no usable font was found (looked for {})", .looked_for.join(", "))]
    NoFont { looked_for: &'static [&'static str] },

    /// Drawing the plot failed.
    #[error("cannot draw the plot: {0}")]
    Plot(#[source] Box<dyn std::error::Error + Send + Sync>),

    /// Encoding the plot as PNG failed.
    #[error("cannot encode the plot as PNG: {0}")]
    PlotEncoding(#[source] image::ImageError),
}
