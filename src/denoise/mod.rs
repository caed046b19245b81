//! Denoising of rendered frames: the seed's median filter and an edge-avoiding, spatio-temporal
//! a-trous wavelet filter (Dammertz et al. 2010), both working on whole animations so that
//! neighbouring frames (neighbouring 3D slices or times) can help each other.
//!
//! Only each film's `color` is changed; the other buffers (`std_error`, `albedo`, `normal`,
//! `position`, `depth`) are guides and stay untouched. Non-finite colours are missing data: they
//! never contribute to another pixel, and a non-finite pixel is filled from its valid neighbours
//! when it has any, else left as it was. A film whose buffers disagree with its `width * height`
//! is left alone and is nobody's temporal neighbour; neither filter panics on any input.
//!
//! See `docs/physics.md`, "Denoising": the median is biased dark on skewed Monte Carlo noise and
//! erodes thin features, so it is kept as an option and as a firefly detector; a-trous is the
//! filter to use.

pub mod atrous;
pub mod median;

use crate::film::Film;
use crate::scene::Denoise;

pub use atrous::{AtrousOptions, Temporal};

/// Denoise every frame's `color` in place; `opts` is used by [`Denoise::Atrous`] only.
pub fn denoise(frames: &mut [Film], filter: Denoise, opts: &AtrousOptions) {
    match filter {
        Denoise::None => {}
        Denoise::Median => median::median(frames),
        Denoise::Atrous => atrous::atrous(frames, opts),
    }
}

/// Whether a film's buffers all hold `width * height` pixels (the filters skip films that don't).
pub(crate) fn consistent(f: &Film) -> bool {
    match f.width.checked_mul(f.height) {
        Some(n) => {
            f.color.len() == n
                && f.std_error.len() == n
                && f.albedo.len() == n
                && f.normal.len() == n
                && f.position.len() == n
        }
        None => false,
    }
}

/// Whether frames `a` and `b` may exchange pixels (both consistent, same size).
pub(crate) fn compatible(a: &Film, b: &Film) -> bool {
    consistent(a) && consistent(b) && a.width == b.width && a.height == b.height
}
