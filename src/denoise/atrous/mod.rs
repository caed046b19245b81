//! Edge-avoiding a-trous wavelet filter (Dammertz, Sewtz, Hanika, Lensch 2010), spatio-temporal.
//!
//! Each of `passes` passes (5 by default) convolves with the B3-spline kernel
//! `[1, 4, 6, 4, 1] / 16` in x and y (5x5 taps) with holes: tap spacing `2^i` on pass `i`
//! (1, 2, 4, 8, 16). Every tap `q` of pixel `p` is weighted by the kernel times
//! `exp(-sum of terms)`, one term per guide, each `|diff|^2 / sigma^2`:
//!
//! - **colour**: `|c_p - c_q|^2 / (s_i^2 (v_p + v_q))`, where `v` is a pixel's variance (the
//!   squared standard error of its mean, summed over the channels) and
//!   `s_i = sigma_color * sigma_color_decay^i` (default 4 and the paper's 1/2). `v_p + v_q` is the
//!   expected `|c_p - c_q|^2` of two noisy pixels of equal truth, so on the first pass a
//!   difference of a few standard errors hardly stops the filter (a 3-sigma difference keeps
//!   weight `exp(-9/16) = 0.57`) while a real edge of many standard errors does; the halving per
//!   pass follows the noise the earlier passes removed. `v` comes from the film's `std_error` of
//!   the original frame (not re-estimated between passes), averaged over the pixel's 5x5
//!   neighbourhood on the same surface: one pixel's estimate from a few samples is itself noisy
//!   and correlated with its value (a pixel that caught no light reports zero variance). A frame
//!   whose `std_error` is zero everywhere (a one-sample render) carries no noise information;
//!   its `v` is then the spread of each pixel's 3x3 neighbourhood on the same surface.
//! - **normal**: `|n_p - n_q|^2 / sigma_normal^2` on the 4D first-hit normal.
//! - **position**: `|x_p - x_q|^2 / (sigma_position^2 F^2)` on the 4D first-hit position, where
//!   `F` is the distance a tap at that offset would have on a flat surface:
//!   `F^2 = (dx f_x)^2 + (dy f_y)^2 (+ f_x f_y for a tap in another frame)`, with `f_x`, `f_y`
//!   the footprint (distance to the nearer horizontal / vertical neighbour on the same surface,
//!   averaged over `p` and `q`). This makes the weight independent of the scene's scale and of
//!   the hole spacing: on a surface every tap is about one `F` away, across a depth
//!   discontinuity many.
//! - **albedo**: `|a_p - a_q|^2 / sigma_albedo^2`.
//!
//! The centre tap always has weight one (times its kernel weight), and every weight is
//! symmetric: `w_pq = w_qp`. Normals and positions are compared by plain Euclidean
//! differences of 4-vectors, so nothing depends on the dimension. A pixel whose camera ray
//! missed (normal exactly zero) only mixes with other missed pixels, and then by colour and
//! albedo only. Any guide that is not finite makes the tap's weight zero.
//!
//! **Flux form** (`conserve`, on by default): instead of the normalised average
//! `sum_q w_pq c_q / W_p` (`W_p = sum_q w_pq`), each pass computes
//! `c_p + sum_q w_pq (c_q - c_p) / max(W_p, W_q)`. The coefficients are symmetric, so every
//! exchange moves as much from `p` to `q` as back and the sum of the demodulated image is kept
//! exactly (of the colour itself wherever the albedo is uniform; the albedo guide keeps exchanges
//! between different albedos small); they are
//! non-negative and sum to less than one, so the result is still a convex combination (no
//! overshoot). In flat regions `W_p = W_q` and it is the paper's filter. Why: on skewed Monte
//! Carlo noise the normalised update is biased dark, because a bright outlier has few similar
//! neighbours (a small `W`) and gives away a larger share of itself than its dark neighbours
//! take from it (measured: -1.8% at 8 samples per pixel with 10% of the samples at 10x the mean,
//! exactly 0 in flux form). It costs a second sweep per pass for the weight sums.
//!
//! **Demodulation**: the filter runs on `color / (albedo + 1e-3)` (per channel, albedo clamped
//! to >= 0) with `std_error` scaled alike, and multiplies back afterwards, so textures stay sharp:
//! only the (smooth) illumination is filtered.
//!
//! **Spatio-temporal**: a pass also takes the same 5x5 taps, centred on the same pixel, from the
//! previous and the next frame, with frame weights `[1, 2, 1] / 4` and the same edge-stopping
//! weights (against `p`'s guides). By default this happens on the first pass only
//! ([`Temporal::FirstPass`]); [`Temporal::AllPasses`] takes them on every pass, so the temporal
//! support grows by a frame per pass the way the spatial support grows (a binomial kernel over
//! +-5 frames after 5 passes), and [`Temporal::Off`] never. The default holds the fewest frames
//! while streaming (see `stream`): every pass that reaches into neighbours holds about five more
//! frames of state. Measured on `room` and `glass_box` (96x72, 9 frames, 4 spp, against 256 spp),
//! all passes against the first pass only: RMSE 0.0540 against 0.0549 and 0.0465 against 0.0463,
//! while the peak memory of 16 frames falls from 2.4x that of 4 frames to 1.14x. Because the
//! position guide is the 4D hit position, a moving object's pixels in a neighbouring frame lie far
//! from the background's (and vice versa) and are rejected: that is what prevents ghosting.
//! Consequently the temporal taps only help where consecutive frames hit the same point to
//! within about `sigma_position` footprints (static surfaces under a static camera, or finely
//! spaced slices); when the slice or camera moves further per frame they are rejected and the
//! filter falls back to the spatial one.
//!
//! **Missing data**: a non-finite colour never contributes. A non-finite pixel is filled from
//! the valid taps that pass the guide tests (colour term left out); if it has none, it is left
//! exactly as it was.
//!
//! The code: `options` (the settings and what they mean for each pass), `guides` (every
//! pixel's guides, prepared once and packed as `f32` planes), `kernel` (the vectorised tap
//! weights and the row sweeps of a pass) and here the driver that runs the passes; `reference`
//! (tests only) is the plain `f64` filter the optimised one is checked against.

mod guides;
mod kernel;
mod options;
#[cfg(test)]
mod reference;
mod stream;

pub use guides::ALBEDO_EPSILON;
pub use guides::Scales;
pub use options::{AtrousOptions, Temporal};
pub use stream::{Filtered, Stream};

use super::Film;
use glam::DVec3;
use rayon::prelude::*;

/// The B3-spline kernel, 1D.
const B3: [f64; 5] = [1.0 / 16.0, 4.0 / 16.0, 6.0 / 16.0, 4.0 / 16.0, 1.0 / 16.0];
/// Weights of the previous, the same and the next frame.
const FRAME_WEIGHTS: [f64; 3] = [0.25, 0.5, 0.25];

/// The ratio `d2 / s2` as an exponent term: zero for no difference, infinite (weight zero) when
/// the sigma is zero or anything is not a number.
#[inline]
fn term(d2: f64, s2: f64) -> f64 {
    if d2 <= 0.0 {
        0.0
    } else if s2 > 0.0 {
        let t = d2 / s2;
        if t.is_nan() { f64::INFINITY } else { t }
    } else {
        f64::INFINITY
    }
}

/// `base + d * step` if it lies in `0..len`.
#[inline]
fn offset(base: usize, d: isize, step: usize, len: usize) -> Option<usize> {
    let q = base as isize + d * step as isize;
    (q >= 0 && (q as usize) < len).then_some(q as usize)
}

/// Filter every frame's colour in place.
pub fn atrous(frames: &mut [Film], opts: &AtrousOptions) {
    let scales = scales_of(frames, opts);
    let mut stream = Stream::new(frames.len(), opts, scales);
    let mut k = 0;
    for i in 0..frames.len() {
        for out in stream.push(std::mem::replace(&mut frames[i], Film::new(0, 0))) {
            frames[k] = out.film;
            k += 1;
        }
    }
}

/// The filtered colour of every frame, without changing the films (`None` for a film whose
/// buffers disagree with its size).
pub fn filtered(frames: &[Film], opts: &AtrousOptions) -> Vec<Option<Vec<DVec3>>> {
    let mut stream = Stream::new(frames.len(), opts, scales_of(frames, opts));
    (frames.iter())
        .flat_map(|f| stream.push(f.clone()))
        .map(|out| out.filtered.then_some(out.film.color))
        .collect()
}

/// The scales of all `frames` together.
fn scales_of(frames: &[Film], opts: &AtrousOptions) -> Scales {
    (frames.par_iter())
        .map(|f| Scales::of(f, opts))
        .reduce(Scales::default, Scales::max)
}

/// A film's colours from its filtered demodulated ones (`demodulated(p)` of pixel `p`): times
/// the demodulation factor, or the film's own colour where that is not finite. The reference
/// filter ends the same way.
fn remodulated(film: &Film, albedo: &[DVec3], demodulated: impl Fn(usize) -> DVec3) -> Vec<DVec3> {
    film.color
        .iter()
        .zip(albedo)
        .enumerate()
        .map(|(p, (orig, a))| {
            let v = demodulated(p) * *a;
            if v.is_finite() { v } else { *orig }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec4;

    #[test]
    fn kernels_are_normalised() {
        assert!((B3.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        assert!((FRAME_WEIGHTS.iter().sum::<f64>() - 1.0).abs() < 1e-15);
    }

    #[test]
    fn term_conventions() {
        assert_eq!(term(0.0, 0.0), 0.0);
        assert_eq!(term(1.0, 0.0), f64::INFINITY);
        assert_eq!(term(f64::NAN, 1.0), f64::INFINITY);
        assert_eq!(term(1.0, f64::INFINITY), 0.0);
        assert_eq!(term(f64::INFINITY, f64::INFINITY), f64::INFINITY);
        assert_eq!(term(2.0, 4.0), 0.5);
    }

    #[test]
    fn offsets_stay_inside() {
        assert_eq!(offset(0, -1, 1, 4), None);
        assert_eq!(offset(3, 1, 1, 4), None);
        assert_eq!(offset(2, 2, 8, 100), Some(18));
    }

    #[test]
    fn constant_image_stays_constant() {
        let mut f = Film::new(9, 7);
        for i in 0..63 {
            f.color[i] = DVec3::new(0.25, 0.5, 0.75);
            f.std_error[i] = DVec3::splat(0.1);
            f.albedo[i] = DVec3::splat(0.5);
            f.normal[i] = DVec4::new(0.0, 0.0, -1.0, 0.0);
            f.position[i] = DVec4::new((i % 9) as f64, (i / 9) as f64, 3.0, 0.0);
        }
        let before = f.color.clone();
        let mut frames = [f.clone(), f.clone(), f];
        atrous(&mut frames, &AtrousOptions::default());
        for fr in &frames {
            for (a, b) in fr.color.iter().zip(&before) {
                assert!((*a - *b).abs().max_element() < 1e-12);
            }
        }
    }
}
