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
/// Pixels of a row filtered together: their guides and sums stay in the L1 cache while the
/// taps stream past.
const BLOCK: usize = 64;

// The planes of a frame's guides (see `Guides`).
/// The demodulation factor (3 planes).
const ALBEDO: usize = 0;
/// The 4D normal (4 planes).
const NORMAL: usize = 3;
/// The 4D position (4 planes).
const POSITION: usize = 7;
/// The footprints `f_x` and `f_y`.
const FOOT_X: usize = 11;
const FOOT_Y: usize = 12;
/// The variance of the demodulated colour.
const VAR: usize = 13;
/// 1 where the camera ray missed, else 0.
const MISSED: usize = 14;
const PLANES: usize = 15;
/// The planes of a colour buffer (red, green, blue).
const CHANNELS: usize = 3;

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

/// A frame's guides, prepared once, as planes of `f64` stored row by row: row `y` is
/// `data[y * PLANES * w..][..PLANES * w]` and holds plane `g` (`ALBEDO`, ..., `MISSED`) at
/// `[g * w..(g + 1) * w]`. The colours are stored alike (`CHANNELS` planes). A tap of a run of
/// pixels of a row then reads a contiguous run of every plane, which vectorises.
struct Guides {
    w: usize,
    h: usize,
    data: Vec<f64>,
}

impl Guides {
    fn row(&self, y: usize) -> &[f64] {
        &self.data[y * PLANES * self.w..(y + 1) * PLANES * self.w]
    }

    /// The demodulation factor of pixel `p`.
    fn albedo(&self, p: usize) -> DVec3 {
        let (x, y) = (p % self.w, p / self.w);
        let row = self.row(y);
        DVec3::from_array(std::array::from_fn(|c| row[(ALBEDO + c) * self.w + x]))
    }
}

/// Run `n` pixels of plane `g` of a row of width `w`, from pixel `x`.
#[inline(always)]
fn plane(row: &[f64], w: usize, g: usize, x: usize, n: usize) -> &[f64] {
    &row[g * w + x..g * w + x + n]
}

/// Pixel buffers stored as planes row by row (see `Guides`), from pixels.
fn to_planes<const P: usize>(w: usize, px: impl Iterator<Item = [f64; P]>) -> Vec<f64> {
    let mut out = Vec::new();
    let mut row = Vec::with_capacity(w);
    let mut flush = |row: &mut Vec<[f64; P]>| {
        for g in 0..P {
            out.extend(row.iter().map(|v| v[g]));
        }
        row.clear();
    };
    for v in px {
        row.push(v);
        if row.len() == w {
            flush(&mut row);
        }
    }
    flush(&mut row);
    out
}

/// The ratio `d2 / s2` as an exponent term: zero for no difference, infinite (weight zero) when
/// the sigma is zero or anything is not a number. Branch-free, so that the tap loops vectorise.
#[inline(always)]
fn term(d2: f64, s2: f64) -> f64 {
    let t = d2 / s2;
    let t = if t.is_nan() || !(s2 > 0.0) {
        f64::INFINITY
    } else {
        t
    };
    if d2 <= 0.0 { 0.0 } else { t }
}

/// `exp(-t)` for `0 <= t <= CUTOFF`, branch-free so that the tap loops vectorise (the C
/// library's `exp` is a call): `2^k exp(r)` with `k` the integer nearest to `-t / ln 2` and
/// `exp(r)`, `|r| <= ln(2) / 2`, from its Taylor series to degree 13 (truncation below 2e-16
/// relative; the result is within a few units in the last place of the exact value).
#[inline(always)]
fn exp_neg(t: f64) -> f64 {
    /// 1.5 * 2^52: adding it rounds to an integer, which lands in the low mantissa bits.
    const SHIFT: f64 = 6_755_399_441_055_744.0;
    /// ln 2 in two parts (fdlibm's): `k * LN2_HI` is exact for `|k| < 2^20`.
    const LN2_HI: f64 = 6.931_471_803_691_238_164_9e-1;
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    const INV_FACTORIAL: [f64; 14] = {
        let mut c = [1.0; 14];
        let mut i = 1;
        while i < 14 {
            c[i] = c[i - 1] / i as f64;
            i += 1;
        }
        c
    };
    let x = -t;
    let kd = x * std::f64::consts::LOG2_E + SHIFT;
    let bits = kd.to_bits();
    let k = kd - SHIFT;
    let r = (x - k * LN2_HI) - k * LN2_LO;
    let mut p = INV_FACTORIAL[13];
    for c in INV_FACTORIAL[..13].iter().rev() {
        p = p * r + c;
    }
    // 2^k: the low bits of `bits` are `k` (two's complement), shifted into the exponent field.
    p * f64::from_bits(bits.wrapping_add(1023) << 52)
}

/// Whether all three are finite (branch-free).
#[inline(always)]
fn finite3(a: f64, b: f64, c: f64) -> bool {
    (a - a) + (b - b) + (c - c) == 0.0
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
    // Demodulated colours, as planes.
    let mut cur: Vec<Vec<f64>> = frames
        .par_iter()
        .zip(&guides)
        .map(|(f, g)| match g {
            Some(g) => to_planes(
                g.w,
                f.color
                    .iter()
                    .enumerate()
                    .map(|(p, c)| (*c / g.albedo(p)).to_array()),
            ),
            None => Vec::new(),
        })
        .collect();
    // Whether each frame may take taps from the previous and from the next one.
    let neighbours: Vec<[bool; 2]> = (0..frames.len())
        .map(|k| {
            let ok = |kq: Option<usize>| match kq {
                Some(kq) if kq < frames.len() => {
                    guides[k].is_some()
                        && guides[kq].is_some()
                        && compatible(&frames[k], &frames[kq])
                }
                _ => false,
            };
            [ok(k.checked_sub(1)), ok(Some(k + 1))]
        })
        .collect();
    let mut next = cur.clone();
    let mut sums: Vec<Vec<f64>> = guides
        .iter()
        .map(|g| g.as_ref().map_or(Vec::new(), |g| vec![0.0; g.w * g.h]))
        .collect();
    for pass in 0..opts.passes.min(MAX_PASSES) {
        let temporal = match opts.temporal {
            Temporal::Off => false,
            Temporal::FirstPass => pass == 0,
            Temporal::AllPasses => true,
        };
        let sources = neighbours
            .iter()
            .enumerate()
            .map(|(k, [prev, next])| {
                let mut s = Vec::with_capacity(3);
                if temporal && *prev {
                    s.push((k - 1, FRAME_WEIGHTS[0]));
                }
                s.push((k, FRAME_WEIGHTS[1]));
                if temporal && *next {
                    s.push((k + 1, FRAME_WEIGHTS[2]));
                }
                s
            })
            .collect();
        let sc = opts.sigma_color * opts.sigma_color_decay.powi(pass as i32);
        let step = Pass {
            guides: &guides,
            cur: &cur,
            sources,
            step: 1 << pass,
            sc2: sc * sc,
            sn2: opts.sigma_normal * opts.sigma_normal,
            sx2: opts.sigma_position * opts.sigma_position,
            sa2: opts.sigma_albedo * opts.sigma_albedo,
        };
        if opts.conserve {
            for_rows(&guides, &mut sums, 1, |k, y, row| step.sums_row(k, y, row));
        }
        let sums = opts.conserve.then_some(&sums[..]);
        for_rows(&guides, &mut next, CHANNELS, |k, y, row| {
            step.update_row(k, y, sums, row)
        });
        std::mem::swap(&mut cur, &mut next);
    }
    frames
        .par_iter()
        .zip(&guides)
        .zip(&cur)
        .map(|((f, g), c)| {
            let g = g.as_ref()?;
            Some(
                f.color
                    .iter()
                    .enumerate()
                    .map(|(p, orig)| {
                        let (x, y) = (p % g.w, p / g.w);
                        let row = &c[y * CHANNELS * g.w..];
                        let c = DVec3::from_array(std::array::from_fn(|ch| row[ch * g.w + x]));
                        let v = c * g.albedo(p);
                        if v.is_finite() { v } else { *orig }
                    })
                    .collect(),
            )
        })
        .collect()
}

/// Run `f(k, y, row)` in parallel over every row of every frame with guides, `row` being row `y`
/// of `out[k]`, stored as `planes` planes of the frame's width.
fn for_rows(
    guides: &[Option<Guides>],
    out: &mut [Vec<f64>],
    planes: usize,
    f: impl Fn(usize, usize, &mut [f64]) + Sync,
) {
    let mut rows = Vec::new();
    for (k, (g, o)) in guides.iter().zip(out.iter_mut()).enumerate() {
        if let Some(g) = g
            && g.w > 0
        {
            rows.extend(
                o.chunks_mut(planes * g.w)
                    .enumerate()
                    .map(|(y, r)| (k, y, r)),
            );
        }
    }
    rows.into_par_iter().for_each(|(k, y, r)| f(k, y, r));
}

fn prepare(film: &Film, opts: &AtrousOptions) -> Guides {
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
    let data = to_planes(
        w,
        (0..w * h).map(|p| {
            let (a, n, x) = (albedo[p], film.normal[p], film.position[p]);
            [
                a.x,
                a.y,
                a.z,
                n.x,
                n.y,
                n.z,
                n.w,
                x.x,
                x.y,
                x.z,
                x.w,
                fx[p],
                fy[p],
                var[p],
                if missed[p] { 1.0 } else { 0.0 },
            ]
        }),
    );
    Guides { w, h, data }
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
struct Pass<'a> {
    guides: &'a [Option<Guides>],
    /// The demodulated colours of every frame, as planes (see `Guides`).
    cur: &'a [Vec<f64>],
    /// For every frame, the frames its taps read (itself included), with their frame weights.
    sources: Vec<Vec<(usize, f64)>>,
    step: usize,
    sc2: f64,
    sn2: f64,
    sx2: f64,
    sa2: f64,
}

/// A run of pixels of a block and where one tap of theirs lies: pixels `lo..lo + n` of the
/// block have their tap at pixels `qx..qx + n` of row `qy` of frame `kq`.
#[derive(Clone, Copy)]
struct TapRun {
    lo: usize,
    n: usize,
    kq: usize,
    qy: usize,
    qx: usize,
}

/// What weighs one tap of a run of pixels, besides the guides.
struct Tap {
    /// Frame weight times kernel weight.
    base: f64,
    /// The tap's offset in pixels.
    ox: f64,
    oy: f64,
    /// Whether the tap lies in another frame.
    other: bool,
    sc2: f64,
    sn2: f64,
    sx2: f64,
    sa2: f64,
}

/// Runs of `n` pixels of every plane of a row (guides and colours), from pixel `x`.
struct Run<'a> {
    a: [&'a [f64]; 3],
    n: [&'a [f64]; 4],
    x: [&'a [f64]; 4],
    fx: &'a [f64],
    fy: &'a [f64],
    var: &'a [f64],
    missed: &'a [f64],
    c: [&'a [f64]; 3],
}

impl<'a> Run<'a> {
    #[inline(always)]
    fn new(guides: &'a [f64], colors: &'a [f64], w: usize, x: usize, n: usize) -> Run<'a> {
        let g = |g| plane(guides, w, g, x, n);
        let c = |c| plane(colors, w, c, x, n);
        Run {
            a: [g(ALBEDO), g(ALBEDO + 1), g(ALBEDO + 2)],
            n: [g(NORMAL), g(NORMAL + 1), g(NORMAL + 2), g(NORMAL + 3)],
            x: [
                g(POSITION),
                g(POSITION + 1),
                g(POSITION + 2),
                g(POSITION + 3),
            ],
            fx: g(FOOT_X),
            fy: g(FOOT_Y),
            var: g(VAR),
            missed: g(MISSED),
            c: [c(0), c(1), c(2)],
        }
    }
}

/// The weights `out[i]` of one tap (see the module notes) of the pixels `p` (runs of their
/// guides and colours) whose tap pixels are `q`: zero where the tap's colour is not finite, the
/// pixels do not agree on having missed or the exponent exceeds `CUTOFF`. Branch-free, so it
/// vectorises.
#[inline(always)]
fn tap_weights(out: &mut [f64], p: &Run, q: &Run, tap: &Tap) {
    let n = out.len();
    let [pa0, pa1, pa2] = p.a.map(|s| &s[..n]);
    let [qa0, qa1, qa2] = q.a.map(|s| &s[..n]);
    let [pn0, pn1, pn2, pn3] = p.n.map(|s| &s[..n]);
    let [qn0, qn1, qn2, qn3] = q.n.map(|s| &s[..n]);
    let [px0, px1, px2, px3] = p.x.map(|s| &s[..n]);
    let [qx0, qx1, qx2, qx3] = q.x.map(|s| &s[..n]);
    let [pc0, pc1, pc2] = p.c.map(|s| &s[..n]);
    let [qc0, qc1, qc2] = q.c.map(|s| &s[..n]);
    let (pfx, pfy, pv, pm) = (&p.fx[..n], &p.fy[..n], &p.var[..n], &p.missed[..n]);
    let (qfx, qfy, qv, qm) = (&q.fx[..n], &q.fy[..n], &q.var[..n], &q.missed[..n]);
    for i in 0..n {
        let (d0, d1, d2) = (pa0[i] - qa0[i], pa1[i] - qa1[i], pa2[i] - qa2[i]);
        let ta = term(d0 * d0 + d1 * d1 + d2 * d2, tap.sa2);
        let (d0, d1, d2, d3) = (
            pn0[i] - qn0[i],
            pn1[i] - qn1[i],
            pn2[i] - qn2[i],
            pn3[i] - qn3[i],
        );
        let tn = term(d0 * d0 + d1 * d1 + d2 * d2 + d3 * d3, tap.sn2);
        // The footprint of the pair (the mean of both), so the weight is symmetric.
        let fx = 0.5 * (pfx[i] + qfx[i]);
        let fy = 0.5 * (pfy[i] + qfy[i]);
        let f2 = (tap.ox * fx) * (tap.ox * fx) + (tap.oy * fy) * (tap.oy * fy);
        let f2 = if tap.other { f2 + fx * fy } else { f2 };
        let (d0, d1, d2, d3) = (
            px0[i] - qx0[i],
            px1[i] - qx1[i],
            px2[i] - qx2[i],
            px3[i] - qx3[i],
        );
        let tx = term(d0 * d0 + d1 * d1 + d2 * d2 + d3 * d3, tap.sx2 * f2);
        let t = if pm[i] != 0.0 { ta } else { ta + tn + tx };
        let (d0, d1, d2) = (qc0[i] - pc0[i], qc1[i] - pc1[i], qc2[i] - pc2[i]);
        let tc = term(d0 * d0 + d1 * d1 + d2 * d2, tap.sc2 * (pv[i] + qv[i]));
        // A centre without a valid colour is weighed without the colour term.
        let t = if finite3(pc0[i], pc1[i], pc2[i]) {
            t + tc
        } else {
            t
        };
        let e = exp_neg(if t < CUTOFF { t } else { CUTOFF });
        let keep = finite3(qc0[i], qc1[i], qc2[i]) && pm[i] == qm[i] && t <= CUTOFF;
        out[i] = if keep { tap.base * e } else { 0.0 };
    }
}

impl Pass<'_> {
    /// Call `f(run, weights)` for every tap of the pixels `x0..x0 + len` (at most `BLOCK`) of
    /// row `y` of frame `k`, which has guides, in the order previous / same / next frame, then
    /// rows, then columns: `weights[i]` is the weight of pixel `x0 + run.lo + i`'s tap (zero
    /// where it does not count), the centre included (weight = kernel weight where the
    /// colour is valid). Weights are symmetric: the tap `q` of `p` has `p` as a tap with the
    /// same weight. A centre whose own colour is not valid gets weights without the colour term.
    #[inline(always)]
    fn block_taps(
        &self,
        k: usize,
        y: usize,
        (x0, len): (usize, usize),
        mut f: impl FnMut(TapRun, &[f64]),
    ) {
        let Some(g) = &self.guides[k] else {
            return;
        };
        let (w, h) = (g.w, g.h);
        let p = (
            g.row(y),
            &self.cur[k][y * CHANNELS * w..(y + 1) * CHANNELS * w],
        );
        let mut buf = [0.0; BLOCK];
        let step = self.step as isize;
        for &(kq, frame_weight) in &self.sources[k] {
            let other = kq != k;
            let Some(src) = &self.guides[kq] else {
                continue;
            };
            for (j, ky) in B3.iter().enumerate() {
                let dy = j as isize - 2;
                let Some(qy) = offset(y, dy, self.step, h) else {
                    continue;
                };
                let q = (
                    src.row(qy),
                    &self.cur[kq][qy * CHANNELS * w..(qy + 1) * CHANNELS * w],
                );
                for (i, kx) in B3.iter().enumerate() {
                    let ox = (i as isize - 2) * step;
                    // The pixels of the block whose tap lies inside the row.
                    let lo = (x0 as isize).max(-ox);
                    let hi = ((x0 + len) as isize).min(w as isize - ox);
                    if lo >= hi {
                        continue;
                    }
                    let run = TapRun {
                        lo: lo as usize - x0,
                        n: (hi - lo) as usize,
                        kq,
                        qy,
                        qx: (lo + ox) as usize,
                    };
                    let out = &mut buf[..run.n];
                    let base = frame_weight * kx * ky;
                    if !other && ox == 0 && dy == 0 {
                        for (o, c) in out.iter_mut().zip(0..run.n) {
                            let x = x0 + c;
                            let ok = finite3(p.1[x], p.1[w + x], p.1[2 * w + x]);
                            *o = if ok { base } else { 0.0 };
                        }
                    } else {
                        let tap = Tap {
                            base,
                            ox: ox as f64,
                            oy: (dy * step) as f64,
                            other,
                            sc2: self.sc2,
                            sn2: self.sn2,
                            sx2: self.sx2,
                            sa2: self.sa2,
                        };
                        let n = run.n;
                        let (pr, qr) = (
                            Run::new(p.0, p.1, w, lo as usize, n),
                            Run::new(q.0, q.1, w, run.qx, n),
                        );
                        tap_weights(out, &pr, &qr, &tap);
                    }
                    f(run, out);
                }
            }
        }
    }

    /// Row `y` of the weight sums of frame `k`'s pixels.
    fn sums_row(&self, k: usize, y: usize, out: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, just detected.
            unsafe { self.sums_row_avx2(k, y, out) };
            return;
        }
        self.sums_row_any(k, y, out);
    }

    /// The same compiled with AVX2 (4 lanes instead of SSE2's 2; no fused multiply-adds, so
    /// the results are the same bits).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn sums_row_avx2(&self, k: usize, y: usize, out: &mut [f64]) {
        self.sums_row_any(k, y, out);
    }

    #[inline(always)]
    fn sums_row_any(&self, k: usize, y: usize, out: &mut [f64]) {
        for (b, out) in out.chunks_mut(BLOCK).enumerate() {
            let mut acc = [0.0; BLOCK];
            self.block_taps(k, y, (b * BLOCK, out.len()), |run, wts| {
                for (a, wq) in acc[run.lo..run.lo + run.n].iter_mut().zip(wts) {
                    *a += wq;
                }
            });
            out.copy_from_slice(&acc[..out.len()]);
        }
    }

    /// Row `y` of the demodulated colours of frame `k` after this pass (as planes). With `sums`
    /// (the weight sums of every pixel) the update is in flux form,
    /// `c_p + sum_q w_pq (c_q - c_p) / max(W_p, W_q)`, which moves as much colour from `p` to
    /// `q` as from `q` to `p` and so keeps the sum of the image; without, the usual normalised
    /// average `sum_q w_pq c_q / W_p`. A pixel whose colour is not valid takes the normalised
    /// average in either case.
    fn update_row(&self, k: usize, y: usize, sums: Option<&[Vec<f64>]>, out: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, just detected.
            unsafe { self.update_row_avx2(k, y, sums, out) };
            return;
        }
        self.update_row_any(k, y, sums, out);
    }

    /// The same compiled with AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn update_row_avx2(&self, k: usize, y: usize, sums: Option<&[Vec<f64>]>, out: &mut [f64]) {
        self.update_row_any(k, y, sums, out);
    }

    #[inline(always)]
    fn update_row_any(&self, k: usize, y: usize, sums: Option<&[Vec<f64>]>, out: &mut [f64]) {
        let Some(g) = &self.guides[k] else {
            return;
        };
        let w = g.w;
        let cur = &self.cur[k][y * CHANNELS * w..(y + 1) * CHANNELS * w];
        for x0 in (0..w).step_by(BLOCK) {
            let len = BLOCK.min(w - x0);
            let cp = [0, 1, 2].map(|c| &cur[c * w + x0..c * w + x0 + len]);
            let valid: [bool; BLOCK] =
                std::array::from_fn(|i| i < len && finite3(cp[0][i], cp[1][i], cp[2][i]));
            // The normalised average is needed for every pixel without `sums`, else only for
            // those without a valid colour.
            let average = sums.is_none() || valid[..len].contains(&false);
            let mut delta = [[0.0; BLOCK]; CHANNELS];
            let mut sum = [[0.0; BLOCK]; CHANNELS];
            let mut wsum = [0.0; BLOCK];
            self.block_taps(k, y, (x0, len), |run, wts| {
                let (lo, n) = (run.lo, run.n);
                let src = &self.cur[run.kq][run.qy * CHANNELS * w..];
                let cq = [0, 1, 2].map(|c| &src[c * w + run.qx..c * w + run.qx + n]);
                if let Some(sums) = sums {
                    let wp = &sums[k][y * w + x0 + lo..][..n];
                    let wq = &sums[run.kq][run.qy * w + run.qx..][..n];
                    for c in 0..CHANNELS {
                        let (d, cp) = (&mut delta[c][lo..lo + n], &cp[c][lo..lo + n]);
                        for i in 0..n {
                            let m = if wp[i] > wq[i] { wp[i] } else { wq[i] };
                            let s = wts[i] / m;
                            let ok = wts[i] > 0.0 && m > 0.0;
                            d[i] = if ok {
                                d[i] + s * (cq[c][i] - cp[i])
                            } else {
                                d[i]
                            };
                        }
                    }
                }
                if average {
                    for c in 0..CHANNELS {
                        let s = &mut sum[c][lo..lo + n];
                        for i in 0..n {
                            s[i] = if wts[i] > 0.0 {
                                s[i] + wts[i] * cq[c][i]
                            } else {
                                s[i]
                            };
                        }
                    }
                    for (s, wq) in wsum[lo..lo + n].iter_mut().zip(wts) {
                        *s += wq;
                    }
                }
            });
            for i in 0..len {
                let c = [0, 1, 2].map(|c| cp[c][i]);
                let v = if sums.is_some() && valid[i] {
                    [0, 1, 2].map(|ch| c[ch] + delta[ch][i])
                } else if wsum[i] > 0.0 {
                    [0, 1, 2].map(|ch| sum[ch][i] / wsum[i])
                } else {
                    c
                };
                let v = if finite3(v[0], v[1], v[2]) { v } else { c };
                for (ch, v) in v.iter().enumerate() {
                    out[ch * w + x0 + i] = *v;
                }
            }
        }
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
