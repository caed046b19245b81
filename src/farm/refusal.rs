//! Why a long render refuses to start, before it writes anything: in the library's terms (the
//! scene's settings and the job's fields). The command line adds which of its flags change
//! each (`render_command.rs`).

use std::path::PathBuf;

/// A render refused before any work.
#[derive(Debug, thiserror::Error)]
pub enum Refusal {
    /// One frame was asked for that the animation does not have.
    #[error(
        "frame {frame} is not in the animation: it has {} (0..{frames}); set the scene's `frames` to render more",
        count(*frames)
    )]
    FrameOutside {
        /// The frame asked for.
        frame: u32,
        /// The animation's frame count.
        frames: u32,
    },
    /// A range of frames was asked for that reaches past the animation, or is empty.
    #[error(
        "frames {asked} are not all in the animation: it has {} (0..{frames}); set the scene's `frames` to render more",
        count(*frames)
    )]
    FramesOutside {
        /// The range as it was asked for.
        asked: String,
        /// The animation's frame count.
        frames: u32,
    },
    /// A shard that is no part of a render.
    #[error("shard {k}/{n} is not a part of a render: a render splits into n shards 0..n")]
    Shard {
        /// The shard's index.
        k: u32,
        /// The number of shards.
        n: u32,
    },
    /// Fewer frames than shards, under a time budget or a noise threshold: shards would split
    /// frames by samples, which those decide per pixel.
    #[error(
        "{frames} frame{} cannot be split {n} ways by samples under a time budget or a noise threshold, which decide per pixel how many samples to take; render at least {n} frames, or a fixed spp",
        if *frames == 1 { "" } else { "s" }
    )]
    ProgressiveShards {
        /// Frames of the render.
        frames: usize,
        /// The number of shards.
        n: u32,
    },
    /// The film directory holds the work of another scene or other settings.
    #[error(
        "{} holds the films of another scene or other settings: they have `{theirs}` where this render has `{ours}` (in {file}); render with the same settings to resume or reuse them, or restart the render to discard them{}",
        .dir.display(),
        if *hidden { " (or move the folder aside to keep it)" } else { " (or render into another film directory)" }
    )]
    ForeignFilms {
        /// The film directory.
        dir: PathBuf,
        /// The film file that differs.
        file: String,
        /// What differs, as this render has it.
        ours: String,
        /// What differs, as the films were rendered with it.
        theirs: String,
        /// Whether the directory is the hidden one beside the output.
        hidden: bool,
    },
    /// The frames in flight (and the finishing) need more memory than is available.
    #[error(
        "a {width} x {height} render needs about {needed} of memory ({per_pixel:.2} KB a pixel), but {available} {}; make the image smaller{}",
        if *known { "is available" } else { "is the most assumed when the memory available is unknown" },
        if *many_frames { ", or hold fewer frames at once (fewer worker threads, or fewer frames)" } else { "" }
    )]
    Memory {
        /// Image width in pixels.
        width: u32,
        /// Image height in pixels.
        height: u32,
        /// The memory needed, in words.
        needed: String,
        /// The memory available, in words.
        available: String,
        /// Whether the memory available is known (or assumed).
        known: bool,
        /// Kilobytes a pixel.
        per_pixel: f64,
        /// Whether more than one frame would be held at once.
        many_frames: bool,
    },
}

/// `n frames`.
fn count(n: u32) -> String {
    format!("{n} frame{}", if n == 1 { "" } else { "s" })
}
