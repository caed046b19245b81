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
//! weights (against `p`'s guides). By default this happens on every pass, so the temporal support
//! grows by a frame per pass (a binomial kernel over +-5 frames after 5 passes) the way the
//! spatial support grows; [`Temporal::FirstPass`] and [`Temporal::Off`] restrict it. Because the
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

use super::{Film, compatible, consistent};
use glam::{DVec3, DVec4};
use rayon::prelude::*;

/// The B3-spline kernel, 1D.
const B3: [f64; 5] = [1.0 / 16.0, 4.0 / 16.0, 6.0 / 16.0, 4.0 / 16.0, 1.0 / 16.0];
/// Weights of the previous, the same and the next frame.
const FRAME_WEIGHTS: [f64; 3] = [0.25, 0.5, 0.25];
/// Added to the albedo before demodulating.
pub const ALBEDO_EPSILON: f64 = 1e-3;
/// A tap whose exponent exceeds this is dropped (weight below 1e-17 of its kernel weight).
const CUTOFF: f64 = 40.0;
/// Passes beyond this are ignored (their hole spacing would exceed any image).
const MAX_PASSES: u32 = 24;

/// Which passes also take taps from the neighbouring frames.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Temporal {
    /// Spatial only: every frame is filtered on its own.
    Off,
    /// Neighbouring frames on the first pass only (temporal support +-1 frame).
    FirstPass,
    /// Neighbouring frames on every pass (temporal support grows by one frame per pass).
    #[default]
    AllPasses,
}

/// Settings of the a-trous filter. Every sigma may be `f64::INFINITY` to switch its guide off.
#[derive(Clone, Debug, PartialEq)]
pub struct AtrousOptions {
    /// Number of passes; pass `i` has hole spacing `2^i` (5 passes: 1 .. 16, a 61x61 support).
    pub passes: u32,
    /// Colour sigma on the first pass, in standard errors of the two pixels' difference;
    /// multiplied by `sigma_color_decay` every pass.
    pub sigma_color: f64,
    /// Factor of the colour sigma from one pass to the next (the paper's 1/2).
    pub sigma_color_decay: f64,
    /// Sigma of the 4D normal difference.
    pub sigma_normal: f64,
    /// Sigma of the 4D position difference, in pixel footprints at the tap's offset.
    pub sigma_position: f64,
    /// Sigma of the albedo difference.
    pub sigma_albedo: f64,
    /// Which passes reach into the neighbouring frames.
    pub temporal: Temporal,
    /// Update in flux form, which keeps the image's sum (see the module notes).
    pub conserve: bool,
}

impl Default for AtrousOptions {
    fn default() -> AtrousOptions {
        AtrousOptions {
            passes: 5,
            sigma_color: 4.0,
            sigma_color_decay: 0.5,
            sigma_normal: 0.3,
            sigma_position: 2.0,
            sigma_albedo: 0.25,
            temporal: Temporal::AllPasses,
            conserve: true,
        }
    }
}

/// The per-frame guides, prepared once.
struct Guides<'a> {
    film: &'a Film,
    /// The demodulation factor: albedo (clamped, finite) + `ALBEDO_EPSILON`.
    albedo: Vec<DVec3>,
    /// Variance of the demodulated colour, summed over the channels.
    var: Vec<f64>,
    missed: Vec<bool>,
    /// Footprint: distance to the nearer neighbour on the same surface, horizontally / vertically.
    fx: Vec<f64>,
    fy: Vec<f64>,
}

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

fn is_missed(n: DVec4) -> bool {
    n.length_squared() == 0.0
}

/// Filter every frame's colour in place.
pub fn atrous(frames: &mut [Film], opts: &AtrousOptions) {
    let out = filtered(frames, opts);
    for (f, c) in frames.iter_mut().zip(out) {
        if let Some(c) = c {
            f.color = c;
        }
    }
}

/// The filtered colour of every frame, without changing the films (`None` for a film whose
/// buffers disagree with its size).
pub fn filtered(frames: &[Film], opts: &AtrousOptions) -> Vec<Option<Vec<DVec3>>> {
    let guides: Vec<Option<Guides>> = frames
        .par_iter()
        .map(|f| consistent(f).then(|| prepare(f, opts)))
        .collect();
    // Demodulated colours.
    let mut cur: Vec<Vec<DVec3>> = guides
        .iter()
        .map(|g| match g {
            Some(g) => g
                .film
                .color
                .iter()
                .zip(&g.albedo)
                .map(|(c, a)| *c / *a)
                .collect(),
            None => Vec::new(),
        })
        .collect();
    for pass in 0..opts.passes.min(MAX_PASSES) {
        let temporal = match opts.temporal {
            Temporal::Off => false,
            Temporal::FirstPass => pass == 0,
            Temporal::AllPasses => true,
        };
        let sc = opts.sigma_color * opts.sigma_color_decay.powi(pass as i32);
        let step = Pass {
            guides: &guides,
            cur: &cur,
            temporal,
            step: 1 << pass,
            sc2: sc * sc,
            sn2: opts.sigma_normal * opts.sigma_normal,
            sx2: opts.sigma_position * opts.sigma_position,
            sa2: opts.sigma_albedo * opts.sigma_albedo,
        };
        let sums = opts.conserve.then(|| step.weight_sums());
        let next: Vec<Vec<DVec3>> = (0..frames.len())
            .map(|k| step.frame(k, sums.as_deref()))
            .collect();
        cur = next;
    }
    guides
        .iter()
        .zip(cur)
        .map(|(g, c)| {
            let g = g.as_ref()?;
            Some(
                g.film
                    .color
                    .iter()
                    .zip(c)
                    .zip(&g.albedo)
                    .map(|((orig, c), a)| {
                        let v = c * *a;
                        if v.is_finite() { v } else { *orig }
                    })
                    .collect(),
            )
        })
        .collect()
}

fn prepare<'a>(film: &'a Film, opts: &AtrousOptions) -> Guides<'a> {
    let (w, h) = (film.width, film.height);
    let albedo: Vec<DVec3> = film
        .albedo
        .iter()
        .map(|a| {
            let a = DVec3::new(
                if a.x.is_finite() { a.x.max(0.0) } else { 0.0 },
                if a.y.is_finite() { a.y.max(0.0) } else { 0.0 },
                if a.z.is_finite() { a.z.max(0.0) } else { 0.0 },
            );
            a + DVec3::splat(ALBEDO_EPSILON)
        })
        .collect();
    let missed: Vec<bool> = film.normal.iter().map(|n| is_missed(*n)).collect();
    // Footprints.
    let near = |p: usize, q: Option<usize>| -> Option<f64> {
        let q = q?;
        if missed[p] || missed[q] {
            return None;
        }
        let d = film.position[p].distance(film.position[q]);
        d.is_finite().then_some(d)
    };
    let min_opt = |a: Option<f64>, b: Option<f64>| match (a, b) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    };
    let mut fx = vec![0.0; w * h];
    let mut fy = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            let p = y * w + x;
            let l = (x > 0).then(|| p - 1);
            let r = (x + 1 < w).then(|| p + 1);
            let u = (y > 0).then(|| p - w);
            let d = (y + 1 < h).then(|| p + w);
            let hx = min_opt(near(p, l), near(p, r));
            let hy = min_opt(near(p, u), near(p, d));
            fx[p] = hx.or(hy).unwrap_or(0.0);
            fy[p] = hy.or(hx).unwrap_or(0.0);
        }
    }
    let sanitize = |s: f64| if s.is_finite() { s.abs() } else { 0.0 };
    let no_noise_info = film
        .std_error
        .iter()
        .all(|s| sanitize(s.x) + sanitize(s.y) + sanitize(s.z) == 0.0);
    let var: Vec<f64> = if no_noise_info {
        spatial_variance(film, &albedo, &missed, &fx, &fy, opts)
    } else {
        film.std_error
            .iter()
            .zip(&albedo)
            .map(|(s, a)| {
                let s = DVec3::new(sanitize(s.x), sanitize(s.y), sanitize(s.z)) / *a;
                let v = s.length_squared();
                if v.is_finite() { v } else { 0.0 }
            })
            .collect()
    };
    let var = smooth_variance(film, &var, &missed, &fx, &fy, opts);
    Guides {
        film,
        albedo,
        var,
        missed,
        fx,
        fy,
    }
}

/// The variance averaged over the pixel's 5x5 neighbourhood on the same surface (B3 weights
/// times the normal and position guides). A pixel's own standard error, estimated from its few
/// samples, is itself very noisy and correlated with its value (a 16-sample pixel that caught
/// no light reports zero variance); weights built from it would treat dark and bright pixels
/// differently and shift the mean.
fn smooth_variance(
    film: &Film,
    var: &[f64],
    missed: &[bool],
    fx: &[f64],
    fy: &[f64],
    opts: &AtrousOptions,
) -> Vec<f64> {
    let (w, h) = (film.width, film.height);
    let sn2 = opts.sigma_normal * opts.sigma_normal;
    let sx2 = opts.sigma_position * opts.sigma_position;
    let mut out = var.to_vec();
    if w == 0 {
        return out;
    }
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, v) in row.iter_mut().enumerate() {
            let p = y * w + x;
            let (mut sum, mut wsum) = (0.0, 0.0);
            for (j, ky) in B3.iter().enumerate() {
                let dy = j as isize - 2;
                let Some(qy) = offset(y, dy, 1, h) else {
                    continue;
                };
                for (i, kx) in B3.iter().enumerate() {
                    let dx = i as isize - 2;
                    let Some(qx) = offset(x, dx, 1, w) else {
                        continue;
                    };
                    let q = qy * w + qx;
                    if missed[q] != missed[p] {
                        continue;
                    }
                    let mut t = 0.0;
                    if !missed[p] {
                        let f2 = (dx as f64 * fx[p]).powi(2) + (dy as f64 * fy[p]).powi(2);
                        t = term(film.normal[p].distance_squared(film.normal[q]), sn2)
                            + term(
                                film.position[p].distance_squared(film.position[q]),
                                sx2 * f2,
                            );
                    }
                    let wq = kx * ky * (-t).exp();
                    if wq > 0.0 {
                        sum += wq * var[q];
                        wsum += wq;
                    }
                }
            }
            if wsum > 0.0 && (sum / wsum).is_finite() {
                *v = sum / wsum;
            }
        }
    });
    out
}

/// A pixel's noise variance from its 3x3 neighbourhood on the same surface (pixels that pass the
/// normal and position tests with weight >= 1/2), for films without a standard error.
fn spatial_variance(
    film: &Film,
    albedo: &[DVec3],
    missed: &[bool],
    fx: &[f64],
    fy: &[f64],
    opts: &AtrousOptions,
) -> Vec<f64> {
    let (w, h) = (film.width, film.height);
    let sn2 = opts.sigma_normal * opts.sigma_normal;
    let sx2 = opts.sigma_position * opts.sigma_position;
    let mut var = vec![0.0; w * h];
    if w == 0 {
        return var;
    }
    var.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, v) in row.iter_mut().enumerate() {
            let p = y * w + x;
            let mut vals = [DVec3::ZERO; 9];
            let mut n = 0;
            for qy in y.saturating_sub(1)..=(y + 1).min(h - 1) {
                for qx in x.saturating_sub(1)..=(x + 1).min(w - 1) {
                    let q = qy * w + qx;
                    let c = film.color[q] / albedo[q];
                    if !c.is_finite() || missed[p] != missed[q] {
                        continue;
                    }
                    if !missed[p] {
                        let (dx, dy) = (qx as f64 - x as f64, qy as f64 - y as f64);
                        let f2 = (dx * fx[p]).powi(2) + (dy * fy[p]).powi(2);
                        let t = term(film.normal[p].distance_squared(film.normal[q]), sn2)
                            + term(
                                film.position[p].distance_squared(film.position[q]),
                                sx2 * f2,
                            );
                        if t > std::f64::consts::LN_2 {
                            continue;
                        }
                    }
                    vals[n] = c;
                    n += 1;
                }
            }
            if n >= 2 {
                let mean = vals[..n].iter().sum::<DVec3>() / n as f64;
                let ss: f64 = vals[..n].iter().map(|c| (*c - mean).length_squared()).sum();
                let s = ss / (n - 1) as f64;
                *v = if s.is_finite() { s } else { 0.0 };
            }
        }
    });
    var
}

/// What one pass needs: the guides, the current demodulated colours and the pass's sigmas.
struct Pass<'a, 'f> {
    guides: &'a [Option<Guides<'f>>],
    cur: &'a [Vec<DVec3>],
    temporal: bool,
    step: usize,
    sc2: f64,
    sn2: f64,
    sx2: f64,
    sa2: f64,
}

impl Pass<'_, '_> {
    /// Call `f(weight, frame, pixel)` for every tap of pixel `(x, y)` of frame `k` with a valid
    /// colour and a non-zero weight, the centre included (weight = kernel weight). Weights are
    /// symmetric: the tap `q` of `p` has `p` as a tap with the same weight. A centre whose own
    /// colour is not valid gets weights without the colour term.
    #[inline]
    fn taps(&self, k: usize, x: usize, y: usize, mut f: impl FnMut(f64, usize, usize)) {
        let Some(g) = &self.guides[k] else {
            return;
        };
        let film = g.film;
        let (w, h) = (film.width, film.height);
        let p = y * w + x;
        let cp = self.cur[k][p];
        let valid = cp.is_finite();
        let (np, xp, ap, vp, missed) = (
            film.normal[p],
            film.position[p],
            g.albedo[p],
            g.var[p],
            g.missed[p],
        );
        let (fxp, fyp) = (g.fx[p], g.fy[p]);
        let frames = [
            (k.wrapping_sub(1), FRAME_WEIGHTS[0]),
            (k, FRAME_WEIGHTS[1]),
            (k + 1, FRAME_WEIGHTS[2]),
        ];
        for (kq, frame_weight) in frames {
            let other = kq != k;
            if other && !self.temporal {
                continue;
            }
            let Some(Some(src)) = self.guides.get(kq) else {
                continue;
            };
            if other && !compatible(film, src.film) {
                continue;
            }
            let colors = &self.cur[kq];
            for (j, ky) in B3.iter().enumerate() {
                let dy = j as isize - 2;
                let Some(qy) = offset(y, dy, self.step, h) else {
                    continue;
                };
                for (i, kx) in B3.iter().enumerate() {
                    let dx = i as isize - 2;
                    let Some(qx) = offset(x, dx, self.step, w) else {
                        continue;
                    };
                    let q = qy * w + qx;
                    let cq = colors[q];
                    if !cq.is_finite() {
                        continue;
                    }
                    let base = frame_weight * kx * ky;
                    if !other && dx == 0 && dy == 0 {
                        f(base, kq, q);
                        continue;
                    }
                    if src.missed[q] != missed {
                        continue;
                    }
                    // Cheapest terms first; a tap is dropped once its weight is negligible.
                    let mut t = term(ap.distance_squared(src.albedo[q]), self.sa2);
                    if !missed {
                        t += term(np.distance_squared(src.film.normal[q]), self.sn2);
                        if t > CUTOFF {
                            continue;
                        }
                        // The footprint of the pair (the mean of both), so the weight is symmetric.
                        let fx = 0.5 * (fxp + src.fx[q]);
                        let fy = 0.5 * (fyp + src.fy[q]);
                        let (ox, oy) = (
                            (dx * self.step as isize) as f64,
                            (dy * self.step as isize) as f64,
                        );
                        let mut f2 = (ox * fx).powi(2) + (oy * fy).powi(2);
                        if other {
                            f2 += fx * fy;
                        }
                        t += term(xp.distance_squared(src.film.position[q]), self.sx2 * f2);
                    }
                    if valid && t <= CUTOFF {
                        t += term((cq - cp).length_squared(), self.sc2 * (vp + src.var[q]));
                    }
                    if t > CUTOFF {
                        continue;
                    }
                    let weight = base * (-t).exp();
                    if weight > 0.0 {
                        f(weight, kq, q);
                    }
                }
            }
        }
    }

    /// The sum of the tap weights of every pixel of every frame.
    fn weight_sums(&self) -> Vec<Vec<f64>> {
        (0..self.guides.len())
            .map(|k| {
                let Some(g) = &self.guides[k] else {
                    return Vec::new();
                };
                let w = g.film.width;
                let mut sums = vec![0.0; self.cur[k].len()];
                if w > 0 {
                    sums.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
                        for (x, s) in row.iter_mut().enumerate() {
                            self.taps(k, x, y, |wq, _, _| *s += wq);
                        }
                    });
                }
                sums
            })
            .collect()
    }

    /// The demodulated colours of frame `k` after this pass. With `sums` (the weight sums of
    /// every pixel) the update is in flux form, `c_p + sum_q w_pq (c_q - c_p) / max(W_p, W_q)`,
    /// which moves as much colour from `p` to `q` as from `q` to `p` and so keeps the sum of
    /// the image; without, the usual normalised average `sum_q w_pq c_q / W_p`.
    fn frame(&self, k: usize, sums: Option<&[Vec<f64>]>) -> Vec<DVec3> {
        let mut out = self.cur[k].clone();
        let Some(g) = &self.guides[k] else {
            return out;
        };
        let w = g.film.width;
        if w == 0 {
            return out;
        }
        out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, px) in row.iter_mut().enumerate() {
                let p = y * w + x;
                let cp = self.cur[k][p];
                let v = match sums {
                    Some(sums) if cp.is_finite() => {
                        let wp = sums[k][p];
                        let mut delta = DVec3::ZERO;
                        self.taps(k, x, y, |wq, kq, q| {
                            let m = wp.max(sums[kq][q]);
                            if m > 0.0 {
                                delta += (wq / m) * (self.cur[kq][q] - cp);
                            }
                        });
                        cp + delta
                    }
                    _ => {
                        let (mut sum, mut wsum) = (DVec3::ZERO, 0.0);
                        self.taps(k, x, y, |wq, kq, q| {
                            sum += wq * self.cur[kq][q];
                            wsum += wq;
                        });
                        if wsum > 0.0 { sum / wsum } else { cp }
                    }
                };
                if v.is_finite() {
                    *px = v;
                }
            }
        });
        out
    }
}

/// `base + d * step` if it lies in `0..len`.
#[inline]
fn offset(base: usize, d: isize, step: usize, len: usize) -> Option<usize> {
    let q = base as isize + d * step as isize;
    (q >= 0 && (q as usize) < len).then_some(q as usize)
}

#[cfg(test)]
mod tests {
    use super::*;

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
