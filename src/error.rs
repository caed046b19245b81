//! The library's error type: what can go wrong once a scene is loaded, from compiling it to
//! rendering it and writing the frames; the output's and the sweep's own errors are wrapped
//! whole. Each message reads as a sentence after `error: `, which is how the command line
//! prints it.

pub use crate::sweep::SweepError;

use crate::output::OutputError;
use std::path::PathBuf;

/// The library's `Result`.
pub type Result<T> = std::result::Result<T, Error>;

/// Everything the library's fallible operations report.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A scene did not compile: `scene` names it (a file, or what generated it),
    /// `diagnostics` holds every diagnostic and `sources` the files they point into. The
    /// message renders them without colour; a caller may render them otherwise.
    #[error(
        "{scene} does not compile:\n{}",
        crate::diagnostic::render_all(.diagnostics, .sources, false)
    )]
    Compile {
        /// The scene's name: its root file, or what generated it.
        scene: String,
        /// Every diagnostic, warnings included.
        diagnostics: Vec<crate::diagnostic::Diagnostic>,
        /// The files the diagnostics' spans point into.
        sources: crate::source::SourceMap,
    },

    /// The pool of worker threads could not be started.
    #[error("cannot start worker threads: {0}")]
    Threads(#[source] rayon::ThreadPoolBuildError),

    /// The render was cancelled before it finished.
    #[error("the render was cancelled")]
    Cancelled,

    /// What was asked for cannot be done (the message says why and what to do instead).
    #[error("{0}")]
    Usage(String),

    /// A long render refused to start (nothing was written).
    #[error(transparent)]
    Refused(#[from] crate::farm::refusal::Refusal),

    /// A render's hidden film directory could not be removed after its output was written.
    #[error("cannot remove the films in `{}` after writing the output: {source}", .path.display())]
    RemoveFilms {
        /// The film directory.
        path: PathBuf,
        /// Why removing it failed.
        #[source]
        source: std::io::Error,
    },

    /// A film file could not be read or made.
    #[error(transparent)]
    Film(#[from] crate::film::file::FilmError),

    /// A film file's header is not what a film of this render holds.
    #[error("cannot use film `{}`: {message}", .path.display())]
    FilmHeader {
        /// The film file.
        path: PathBuf,
        /// Why: an unreadable header, another format version, or a size or frame that disagrees
        /// with the file.
        message: String,
    },

    /// A film was rendered from another scene or other settings.
    #[error(
        "film `{}` was rendered from another scene or other settings: it has `{theirs}` where this render has `{ours}`\n  hint: render into another film directory, or delete this one to start afresh",
        .path.display()
    )]
    FilmMismatch {
        /// The film file.
        path: PathBuf,
        /// What differs, as this render has it.
        ours: String,
        /// What differs, as the film was rendered with it.
        theirs: String,
    },

    /// A film directory could not be listed.
    #[error("cannot read film directory `{}`: {source}", .path.display())]
    ReadFilms {
        /// The directory.
        path: PathBuf,
        /// Why listing it failed.
        #[source]
        source: std::io::Error,
    },

    /// There are no films to merge.
    #[error("no film files (frame_*.exr) in {}", .dirs.iter().map(|d| format!("`{}`", d.display())).collect::<Vec<_>>().join(", "))]
    NoFilms {
        /// The directories searched.
        dirs: Vec<PathBuf>,
    },

    /// The same unit's film is in two of the directories merged.
    #[error("`{name}` is both in `{}` and in `{}`; merge each shard's films once", .first.display(), .second.display())]
    MergeDuplicate {
        /// The film's file name, e.g. `frame_0003.exr`.
        name: String,
        /// The first directory that holds it.
        first: PathBuf,
        /// The second directory that holds it.
        second: PathBuf,
    },

    /// Shards are missing or unfinished.
    #[error("the shards are not complete:\n  {}", .problems.join("\n  "))]
    MergeIncomplete {
        /// One line per missing or partial unit or shard.
        problems: Vec<String>,
    },

    /// Writing a file failed (frames, films, results or the plot).
    #[error(transparent)]
    Output(#[from] OutputError),

    /// A directory could not be created.
    #[error("cannot create directory `{}`: {source}", .path.display())]
    CreateDirectory {
        /// The directory.
        path: PathBuf,
        /// Why creating it failed.
        #[source]
        source: std::io::Error,
    },

    /// The speed/accuracy sweep failed (its reference, its results or its plot).
    #[error(transparent)]
    Sweep(#[from] SweepError),
}
