//! The library's error type: what can go wrong once a scene is loaded, from compiling it to
//! rendering it, writing the frames and running the speed/accuracy sweep. Each message reads as
//! a sentence after `error: `, which is how the command line prints it.

use crate::output::OutputError;
use std::path::PathBuf;

/// The library's `Result`.
pub type Result<T> = std::result::Result<T, Error>;

/// Everything the library's fallible operations report.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A scene did not compile: `scene` names it (a file, or what generated it) and
    /// `diagnostics` holds every diagnostic, rendered without colour.
    #[error("{scene} does not compile:\n{diagnostics}")]
    Compile { scene: String, diagnostics: String },

    /// The pool of worker threads could not be started.
    #[error("cannot start worker threads: {0}")]
    Threads(#[source] rayon::ThreadPoolBuildError),

    /// The render was cancelled before it finished.
    #[error("the render was cancelled")]
    Cancelled,

    /// What was asked for cannot be done (the message says why and what to do instead).
    #[error("{0}")]
    Usage(String),

    /// A render's hidden film directory could not be removed after its output was written.
    #[error("cannot remove the films in `{}` after writing the output: {source}", .path.display())]
    RemoveFilms {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },

    /// A film file could not be read or made.
    #[error(transparent)]
    Film(#[from] crate::film::file::FilmError),

    /// A film file's header is not what a film of this render holds.
    #[error("cannot use film `{}`: {message}", .path.display())]
    FilmHeader { path: PathBuf, message: String },

    /// A film was rendered from another scene or other settings.
    #[error(
        "film `{}` was rendered from another scene or other settings: it has `{theirs}` where this render has `{ours}`\n  hint: render into another --films directory, or delete this one to start afresh",
        .path.display()
    )]
    FilmMismatch {
        path: PathBuf,
        ours: String,
        theirs: String,
    },

    /// A film directory could not be listed.
    #[error("cannot read film directory `{}`: {source}", .path.display())]
    ReadFilms {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },

    /// There are no films to merge.
    #[error("no film files (frame_*.exr) in {}", .dirs.iter().map(|d| format!("`{}`", d.display())).collect::<Vec<_>>().join(", "))]
    NoFilms { dirs: Vec<PathBuf> },

    /// The same unit's film is in two of the directories merged.
    #[error("`{name}` is both in `{}` and in `{}`; merge each shard's films once", .first.display(), .second.display())]
    MergeDuplicate {
        name: String,
        first: PathBuf,
        second: PathBuf,
    },

    /// Shards are missing or unfinished.
    #[error("the shards are not complete:\n  {}", .problems.join("\n  "))]
    MergeIncomplete { problems: Vec<String> },

    /// Writing a file failed (frames, results or the plot).
    #[error(transparent)]
    Output(#[from] OutputError),

    /// A directory could not be created.
    #[error("cannot create directory `{}`: {source}", .path.display())]
    CreateDirectory {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },

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
