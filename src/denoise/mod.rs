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

pub use atrous::{AtrousOptions, Scales, Temporal};

/// The denoiser a render uses: the language's `denoise` setting, the CLI's `--denoise` and
/// the bench's families all name this one enum. Film headers store it by [`Denoise::name`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Denoise {
    /// Leave every colour bit-identical.
    None,
    /// Median over 3x3 pixels times 3 frames, per channel (biased dark on skewed noise).
    Median,
    /// Edge-avoiding spatio-temporal a-trous wavelet filter, guided by albedo, 4D normal and
    /// 4D position, with colour weights relative to each pixel's standard error.
    Atrous,
}

impl Denoise {
    pub const ALL: [Denoise; 3] = [Denoise::None, Denoise::Median, Denoise::Atrous];

    /// The name in scenes and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Denoise::None => "none",
            Denoise::Median => "median",
            Denoise::Atrous => "atrous",
        }
    }
}

/// Denoise every frame's `color` in place; `opts` is used by [`Denoise::Atrous`] only.
pub fn denoise(frames: &mut [Film], filter: Denoise, opts: &AtrousOptions) {
    match filter {
        Denoise::None => {}
        Denoise::Median => median::median(frames),
        Denoise::Atrous => atrous::atrous(frames, opts),
    }
}

/// A denoiser over a stream of frames pushed in order: it holds only the frames the next
/// output depends on, so memory does not grow with the length of the animation, and its
/// output is the same as [`denoise`]'s on all the frames at once.
pub struct Denoiser {
    kind: Kind,
    frames: usize,
    pushed: usize,
    /// The next frame to hand out.
    out: usize,
}

enum Kind {
    None,
    /// The frames not yet handed out and the one before them, unfiltered.
    Median(std::collections::VecDeque<Film>),
    Atrous(Box<atrous::Stream>),
}

impl Denoiser {
    /// A denoiser for `frames` frames. `scales` are the a-trous scales of all of them
    /// ([`Scales::of`] of every frame, combined with [`Scales::max`]); the other filters
    /// ignore them (see [`Denoiser::needs_scales`]).
    pub fn new(filter: Denoise, frames: usize, opts: &AtrousOptions, scales: Scales) -> Self {
        let kind = match filter {
            Denoise::None => Kind::None,
            Denoise::Median => Kind::Median(Default::default()),
            Denoise::Atrous => Kind::Atrous(Box::new(atrous::Stream::new(frames, opts, scales))),
        };
        Denoiser {
            kind,
            frames,
            pushed: 0,
            out: 0,
        }
    }

    /// Whether `filter` needs the scales of all frames before the first is pushed.
    pub fn needs_scales(filter: Denoise) -> bool {
        filter == Denoise::Atrous
    }

    /// Take the next frame; returns the frames now finished, in order.
    pub fn push(&mut self, film: Film) -> Vec<Film> {
        self.pushed += 1;
        let last = self.pushed == self.frames;
        match &mut self.kind {
            Kind::None => vec![film],
            Kind::Atrous(s) => s.push(film).into_iter().map(|f| f.film).collect(),
            Kind::Median(held) => {
                held.push_back(film);
                // `held` is frames `first..pushed`: the next to hand out and the one before
                // it; a frame is done once the one after it is in, or at the end.
                let mut done = vec![];
                while self.out < self.pushed && (self.out + 1 < self.pushed || last) {
                    let first = self.pushed - held.len();
                    let (centre, n) = (self.out - first, held.len());
                    let window = &held.make_contiguous()[..(centre + 2).min(n)];
                    let mut f = window[centre].clone();
                    if let Some(c) = median::median_at(window, centre) {
                        f.color = c;
                    }
                    done.push(f);
                    self.out += 1;
                    if self.out - first > 1 {
                        held.pop_front();
                    }
                }
                done
            }
        }
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

/// Whether frames `a` and `b` may exchange pixels (both consistent, same size); the streaming
/// filters judge it from the sizes they keep.
#[cfg(test)]
pub(crate) fn compatible(a: &Film, b: &Film) -> bool {
    consistent(a) && consistent(b) && a.width == b.width && a.height == b.height
}
