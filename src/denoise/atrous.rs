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
const CUTOFF: f32 = 40.0;
/// Passes beyond this are ignored (their hole spacing would exceed any image).
const MAX_PASSES: u32 = 24;
/// Pixels of a row filtered together: their guides and sums stay in the L1 cache while the
/// taps stream past.
const BLOCK: usize = 64;
/// The taps of a pixel: 5 x 5 in each of 3 frames.
const TAPS: usize = 75;
/// The lanes of the widest vectors the tap loops are compiled for (`f32` in AVX2).
const LANES: usize = 8;

// The `f32` planes of a frame's guides (see `Guides`).
/// The demodulation factor (3 planes).
const ALBEDO: usize = 0;
/// The 4D normal (4 planes).
const NORMAL: usize = 3;
/// The 4D position, rounded to `f32` (4 planes), and what the rounding left (4 planes).
const POSITION: usize = 7;
const POSITION_LO: usize = 11;
/// The footprints `f_x` and `f_y`.
const FOOT_X: usize = 15;
const FOOT_Y: usize = 16;
/// The variance of the demodulated colour.
const VAR: usize = 17;
/// 1 where the camera ray missed, else 0.
const MISSED: usize = 18;
const PLANES: usize = 19;
/// The `f32` planes of a frame's colours: rounded (3) and what the rounding left (3).
const COLOR_PLANES: usize = 6;
/// The `f64` planes of a frame's colours (red, green, blue).
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

/// A frame's guides, prepared once, as planes of `f32` stored row by row: row `y` is
/// `data[y * PLANES * s..][..PLANES * s]` and holds plane `g` (`ALBEDO`, ..., `MISSED`) at
/// `[g * s..g * s + w]`, where `s = stride(w)`. The colours are stored alike (`CHANNELS`
/// planes of `f64`, `COLOR_PLANES` of `f32`). A tap of a run of pixels of a row then reads a
/// contiguous run of every plane, which vectorises.
struct Guides {
    w: usize,
    h: usize,
    /// The planes' stride.
    s: usize,
    /// The demodulation factor of every pixel: albedo (clamped, finite) + `ALBEDO_EPSILON`.
    albedo: Vec<DVec3>,
    data: Vec<f32>,
}

impl Guides {
    fn row(&self, y: usize) -> &[f32] {
        &self.data[y * PLANES * self.s..(y + 1) * PLANES * self.s]
    }
}

/// The stride of the planes of a row of `w` pixels: at least `w`, and an odd number of cache
/// lines of `f32`, so that the planes of a row (and the rows) do not all fall into the same few
/// sets of the cache, as they would with a stride of a power of two.
fn stride(w: usize) -> usize {
    16 * (w.div_ceil(16) | 1)
}

/// Run `n` pixels of plane `g` of a row with stride `s`, from pixel `x`.
#[inline(always)]
fn plane<T>(row: &[T], s: usize, g: usize, x: usize, n: usize) -> &[T] {
    &row[g * s + x..g * s + x + n]
}

/// Pixel buffers of `w` by `h` pixels stored as `P` planes of stride `s` row by row (see
/// `Guides`), from `px(p)`, the planes' values at pixel `p`.
fn to_planes<T: Copy + Default, const P: usize>(
    (w, h, s): (usize, usize, usize),
    px: impl Fn(usize) -> [T; P],
) -> Vec<T> {
    let mut out = vec![T::default(); P * s * h];
    for (y, row) in out.chunks_mut(P * s).enumerate() {
        for x in 0..w {
            for (g, v) in px(y * w + x).into_iter().enumerate() {
                row[g * s + x] = v;
            }
        }
    }
    out
}

/// `v` as the `f32` nearest to it and the `f32` nearest to the rest: the difference of two
/// such pairs, `(hi_p - hi_q) + (lo_p - lo_q)`, is accurate to `f32`'s relative precision of
/// the difference itself, however much larger the values are.
#[inline]
fn split(v: f64) -> (f32, f32) {
    let hi = v as f32;
    (hi, (v - hi as f64) as f32)
}

/// A power of two near `1 / m` (one if `m` is not positive and finite): the guides are scaled
/// by it exactly, so that their `f32` squares neither overflow nor underflow.
fn scale_for(m: f64) -> f64 {
    if m > 0.0 && m.is_finite() {
        (-m.log2().round()).clamp(-1000.0, 1000.0).exp2()
    } else {
        1.0
    }
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

/// `term` in `f32`, branch-free so that the tap loops vectorise.
#[inline(always)]
fn term32(d2: f32, s2: f32) -> f32 {
    let t = d2 / s2;
    // A NaN `s2` makes `t` NaN, so `s2 <= 0.0` covers the rest.
    let t = if t.is_nan() | (s2 <= 0.0) {
        f32::INFINITY
    } else {
        t
    };
    if d2 <= 0.0 { 0.0 } else { t }
}

/// `term32(d2, s2)` for a fixed `s2`, by a multiplication instead of a division: by `1 / s2`,
/// or by infinity where `s2` is not positive.
#[derive(Clone, Copy)]
struct Term(f32);

impl Term {
    fn new(s2: f64) -> Term {
        Term(if s2 > 0.0 {
            (1.0 / s2) as f32
        } else {
            f32::INFINITY
        })
    }

    #[inline(always)]
    fn of(self, d2: f32) -> f32 {
        let t = d2 * self.0;
        let t = if t.is_nan() { f32::INFINITY } else { t };
        if d2 <= 0.0 { 0.0 } else { t }
    }
}

/// `exp(-t)` for `0 <= t <= CUTOFF`, branch-free so that the tap loops vectorise (the C
/// library's `exp` is a call): `2^k exp(r)` with `k` the integer nearest to `-t / ln 2` and
/// `exp(r)`, `|r| <= ln(2) / 2`, from its Taylor series to degree 7 (truncation below 6e-9
/// relative; the result is within about an `f32` rounding of the exact value).
#[inline(always)]
fn exp_neg(t: f32) -> f32 {
    /// 1.5 * 2^23: adding it rounds to an integer, which lands in the low mantissa bits.
    const SHIFT: f32 = 12_582_912.0;
    /// ln 2 in two parts (Cephes'): `k * LN2_HI` is exact for `|k| < 2^15`.
    const LN2_HI: f32 = 0.693_359_4;
    const LN2_LO: f32 = -2.121_944_4e-4;
    const INV_FACTORIAL: [f32; 8] = [
        1.0,
        1.0,
        1.0 / 2.0,
        1.0 / 6.0,
        1.0 / 24.0,
        1.0 / 120.0,
        1.0 / 720.0,
        1.0 / 5040.0,
    ];
    let x = -t;
    let kd = x * std::f32::consts::LOG2_E + SHIFT;
    let bits = kd.to_bits();
    let k = kd - SHIFT;
    let r = (x - k * LN2_HI) - k * LN2_LO;
    let mut p = INV_FACTORIAL[7];
    for c in INV_FACTORIAL[..7].iter().rev() {
        p = p * r + c;
    }
    // 2^k: the low bits of `bits` are `k` (two's complement), shifted into the exponent field.
    p * f32::from_bits(bits.wrapping_add(127) << 23)
}

/// Whether all three are finite (branch-free): `x - x` is zero for a finite `x` and NaN for an
/// infinite or NaN one, and the sum is zero only if all three are.
#[inline(always)]
#[allow(clippy::eq_op)]
fn finite3<
    T: std::ops::Sub<Output = T> + std::ops::Add<Output = T> + PartialEq + Default + Copy,
>(
    a: T,
    b: T,
    c: T,
) -> bool {
    (a - a) + (b - b) + (c - c) == T::default()
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
    let prepared: Vec<Option<Prepared>> = frames
        .par_iter()
        .map(|f| consistent(f).then(|| prepare(f, opts)))
        .collect();
    // Scales of the positions (and footprints) and of the colours (and standard errors).
    let largest =
        |f: &dyn Fn(&Prepared) -> f64| prepared.iter().flatten().map(f).fold(0.0, f64::max);
    let scale_x = scale_for(largest(&|p| {
        p.fx.iter().chain(&p.fy).copied().fold(0.0, f64::max)
    }));
    let scale_c = scale_for(largest(&|p| p.var.iter().copied().fold(0.0, f64::max)).sqrt());
    let guides: Vec<Option<Guides>> = frames
        .par_iter()
        .zip(prepared)
        .map(|(f, p)| p.map(|p| pack(f, p, scale_x, scale_c)))
        .collect();
    // Demodulated colours, as planes.
    let mut cur: Vec<Vec<f64>> = frames
        .par_iter()
        .zip(&guides)
        .map(|(f, g)| match g {
            Some(g) => to_planes((g.w, g.h, g.s), |p| (f.color[p] / g.albedo[p]).to_array()),
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
    let mut cur32: Vec<Vec<f32>> = guides
        .iter()
        .map(|g| {
            g.as_ref()
                .map_or(Vec::new(), |g| vec![0.0; COLOR_PLANES * g.s * g.h])
        })
        .collect();
    let mut stored: [Vec<f32>; 2] = [Vec::new(), Vec::new()];
    let mut sums: Vec<Vec<f64>> = guides
        .iter()
        .map(|g| g.as_ref().map_or(Vec::new(), |g| vec![0.0; g.s * g.h]))
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
        // The colours as `f32` pairs, scaled.
        for_rows(&guides, &mut cur32, COLOR_PLANES, |k, y, row| {
            let s = row.len() / COLOR_PLANES;
            let src = &cur[k][y * CHANNELS * s..(y + 1) * CHANNELS * s];
            for c in 0..CHANNELS {
                for x in 0..s {
                    (row[c * s + x], row[(CHANNELS + c) * s + x]) = split(src[c * s + x] * scale_c);
                }
            }
        });
        let sc = opts.sigma_color * opts.sigma_color_decay.powi(pass as i32);
        let step = Pass {
            guides: &guides,
            cur: &cur,
            cur32: &cur32,
            sources,
            step: 1 << pass,
            sc2: (sc * sc) as f32,
            sx2: (opts.sigma_position * opts.sigma_position) as f32,
            albedo: Term::new(opts.sigma_albedo * opts.sigma_albedo),
            normal: Term::new(opts.sigma_normal * opts.sigma_normal),
        };
        if opts.conserve {
            // Frame by frame, the weight sums one frame ahead of the update, which takes the
            // weights the sums left (`stored`: those of frames `k` and `k + 1`).
            let sums_of = |k: usize, sums: &mut [f64], stored: &mut Vec<f32>| {
                if let Some(g) = &guides[k]
                    && g.w > 0
                {
                    stored.resize(g.h * TAPS * g.w, 0.0);
                    sums.par_chunks_mut(g.s)
                        .zip(stored.par_chunks_mut(TAPS * g.w))
                        .enumerate()
                        .for_each(|(y, (row, st))| step.sums_row((k, y), row, st));
                }
            };
            for k in 0..frames.len() {
                if k == 0 {
                    sums_of(0, &mut sums[0], &mut stored[0]);
                }
                if k + 1 < frames.len() {
                    sums_of(k + 1, &mut sums[k + 1], &mut stored[(k + 1) % 2]);
                }
                if let Some(g) = &guides[k]
                    && g.w > 0
                {
                    let (sums, stored) = (&sums[..], &stored[k % 2]);
                    next[k]
                        .par_chunks_mut(CHANNELS * g.s)
                        .zip(stored.par_chunks(TAPS * g.w))
                        .enumerate()
                        .for_each(|(y, (row, st))| step.update_row((k, y), Some((sums, st)), row));
                }
            }
        } else {
            for_rows(&guides, &mut next, CHANNELS, |k, y, row| {
                step.update_row((k, y), None, row)
            });
        }
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
                        let row = &c[y * CHANNELS * g.s..];
                        let c = DVec3::new(row[x], row[g.s + x], row[2 * g.s + x]);
                        let v = c * g.albedo[p];
                        if v.is_finite() { v } else { *orig }
                    })
                    .collect(),
            )
        })
        .collect()
}

/// Run `f(k, y, row)` in parallel over every row of every frame with guides, `row` being row `y`
/// of `out[k]`, stored as `planes` planes of the frame's stride.
fn for_rows<T: Send>(
    guides: &[Option<Guides>],
    out: &mut [Vec<T>],
    planes: usize,
    f: impl Fn(usize, usize, &mut [T]) + Sync,
) {
    let mut rows = Vec::new();
    for (k, (g, o)) in guides.iter().zip(out.iter_mut()).enumerate() {
        if let Some(g) = g
            && g.w > 0
        {
            rows.extend(
                o.chunks_mut(planes * g.s)
                    .enumerate()
                    .map(|(y, r)| (k, y, r)),
            );
        }
    }
    rows.into_par_iter().for_each(|(k, y, r)| f(k, y, r));
}

/// A frame's guides in `f64`, before they are scaled and stored as planes.
struct Prepared {
    /// The demodulation factor.
    albedo: Vec<DVec3>,
    missed: Vec<bool>,
    /// Footprint: distance to the nearer neighbour on the same surface, horizontally / vertically.
    fx: Vec<f64>,
    fy: Vec<f64>,
    /// Variance of the demodulated colour, summed over the channels.
    var: Vec<f64>,
}

/// The guides as planes (see `Guides`), positions and footprints multiplied by `scale_x`,
/// variances by `scale_c^2` (powers of two: exact). A missed pixel's position and footprints
/// are stored as zero, so that two missed pixels (whose normals are zero too) have neither a
/// normal nor a position term.
fn pack(film: &Film, p: Prepared, scale_x: f64, scale_c: f64) -> Guides {
    let (w, h) = (film.width, film.height);
    let s = stride(w);
    let data = to_planes((w, h, s), |i| {
        let (a, n) = (p.albedo[i], film.normal[i]);
        let x = if p.missed[i] {
            DVec4::ZERO
        } else {
            film.position[i] * scale_x
        };
        let (x0, y0, z0, w0) = (split(x.x), split(x.y), split(x.z), split(x.w));
        let foot = |f: f64| {
            if p.missed[i] {
                0.0
            } else {
                (f * scale_x) as f32
            }
        };
        [
            a.x as f32,
            a.y as f32,
            a.z as f32,
            n.x as f32,
            n.y as f32,
            n.z as f32,
            n.w as f32,
            x0.0,
            y0.0,
            z0.0,
            w0.0,
            x0.1,
            y0.1,
            z0.1,
            w0.1,
            foot(p.fx[i]),
            foot(p.fy[i]),
            (p.var[i] * scale_c * scale_c) as f32,
            if p.missed[i] { 1.0 } else { 0.0 },
        ]
    });
    Guides {
        w,
        h,
        s,
        albedo: p.albedo,
        data,
    }
}

fn prepare(film: &Film, opts: &AtrousOptions) -> Prepared {
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
    Prepared {
        albedo,
        missed,
        fx,
        fy,
        var,
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
struct Pass<'a> {
    guides: &'a [Option<Guides>],
    /// The demodulated colours of every frame, as planes (see `Guides`).
    cur: &'a [Vec<f64>],
    /// The same as `f32` pairs (see `split`), scaled like the variances.
    cur32: &'a [Vec<f32>],
    /// For every frame, the frames its taps read (itself included), with their frame weights.
    sources: Vec<Vec<(usize, f64)>>,
    step: usize,
    sc2: f32,
    sx2: f32,
    albedo: Term,
    normal: Term,
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
    base: f32,
    /// The tap's offset in pixels.
    ox: f32,
    oy: f32,
    /// Whether the tap lies in another frame.
    other: bool,
    sc2: f32,
    sx2: f32,
    albedo: Term,
    normal: Term,
}

/// Runs of `n` pixels of every plane of a row (guides and colours), from pixel `x`.
struct Run<'a> {
    a: [&'a [f32]; 3],
    n: [&'a [f32]; 4],
    x: [&'a [f32]; 4],
    x_lo: [&'a [f32]; 4],
    fx: &'a [f32],
    fy: &'a [f32],
    var: &'a [f32],
    missed: &'a [f32],
    c: [&'a [f32]; 3],
    c_lo: [&'a [f32]; 3],
}

impl<'a> Run<'a> {
    #[inline(always)]
    fn new(guides: &'a [f32], colors: &'a [f32], s: usize, x: usize, n: usize) -> Run<'a> {
        let g = |g| plane(guides, s, g, x, n);
        let c = |c| plane(colors, s, c, x, n);
        Run {
            a: [g(ALBEDO), g(ALBEDO + 1), g(ALBEDO + 2)],
            n: [g(NORMAL), g(NORMAL + 1), g(NORMAL + 2), g(NORMAL + 3)],
            x: [
                g(POSITION),
                g(POSITION + 1),
                g(POSITION + 2),
                g(POSITION + 3),
            ],
            x_lo: [
                g(POSITION_LO),
                g(POSITION_LO + 1),
                g(POSITION_LO + 2),
                g(POSITION_LO + 3),
            ],
            fx: g(FOOT_X),
            fy: g(FOOT_Y),
            var: g(VAR),
            missed: g(MISSED),
            c: [c(0), c(1), c(2)],
            c_lo: [c(CHANNELS), c(CHANNELS + 1), c(CHANNELS + 2)],
        }
    }

    /// Pixels `a..a + m` of the runs.
    #[inline(always)]
    fn slice(&self, a: usize, m: usize) -> Run<'a> {
        let r = |s: &'a [f32]| &s[a..a + m];
        Run {
            a: self.a.map(r),
            n: self.n.map(r),
            x: self.x.map(r),
            x_lo: self.x_lo.map(r),
            fx: r(self.fx),
            fy: r(self.fy),
            var: r(self.var),
            missed: r(self.missed),
            c: self.c.map(r),
            c_lo: self.c_lo.map(r),
        }
    }
}

/// The weights `out[i]` of one tap (see the module notes) of the pixels `p` (runs of their
/// guides and colours) whose tap pixels are `q`: zero where the tap's colour is not finite, the
/// pixels do not agree on having missed or the exponent exceeds `CUTOFF`.
#[inline(always)]
fn tap_weights(out: &mut [f32], p: &Run, q: &Run, tap: &Tap) {
    let n = out.len();
    // Whole vectors of `LANES`, and the rest as one more vector that overlaps the last (its
    // lanes come out the same twice) instead of a slow scalar remainder.
    let whole = n - n % LANES;
    let spans = if whole == n || n < LANES {
        [(0, n), (0, 0)]
    } else {
        [(0, whole), (n - LANES, LANES)]
    };
    let mut t = [0.0; BLOCK];
    for (a, m) in spans {
        exponents(&mut t[a..a + m], &p.slice(a, m), &q.slice(a, m), tap);
    }
    // The exponentials in a loop of their own: a short body, so that many lanes are in flight.
    for (a, m) in spans {
        for (o, t) in out[a..a + m].iter_mut().zip(&t[a..a + m]) {
            let e = exp_neg(if *t < CUTOFF { *t } else { CUTOFF });
            *o = if *t <= CUTOFF { tap.base * e } else { 0.0 };
        }
    }
}

/// The exponents `out[i]` of the weights of `tap_weights`, infinite where the weight is zero
/// whatever the exponent. Branch-free, so it vectorises.
#[inline(always)]
fn exponents(out: &mut [f32], p: &Run, q: &Run, tap: &Tap) {
    let n = out.len();
    let [pa0, pa1, pa2] = p.a.map(|s| &s[..n]);
    let [qa0, qa1, qa2] = q.a.map(|s| &s[..n]);
    let [pn0, pn1, pn2, pn3] = p.n.map(|s| &s[..n]);
    let [qn0, qn1, qn2, qn3] = q.n.map(|s| &s[..n]);
    let [px0, px1, px2, px3] = p.x.map(|s| &s[..n]);
    let [qx0, qx1, qx2, qx3] = q.x.map(|s| &s[..n]);
    let [pl0, pl1, pl2, pl3] = p.x_lo.map(|s| &s[..n]);
    let [ql0, ql1, ql2, ql3] = q.x_lo.map(|s| &s[..n]);
    let [pc0, pc1, pc2] = p.c.map(|s| &s[..n]);
    let [qc0, qc1, qc2] = q.c.map(|s| &s[..n]);
    let [pd0, pd1, pd2] = p.c_lo.map(|s| &s[..n]);
    let [qd0, qd1, qd2] = q.c_lo.map(|s| &s[..n]);
    let (pfx, pfy, pv, pm) = (&p.fx[..n], &p.fy[..n], &p.var[..n], &p.missed[..n]);
    let (qfx, qfy, qv, qm) = (&q.fx[..n], &q.fy[..n], &q.var[..n], &q.missed[..n]);
    for i in 0..n {
        let (d0, d1, d2) = (pa0[i] - qa0[i], pa1[i] - qa1[i], pa2[i] - qa2[i]);
        let ta = tap.albedo.of(d0 * d0 + d1 * d1 + d2 * d2);
        let (d0, d1, d2, d3) = (
            pn0[i] - qn0[i],
            pn1[i] - qn1[i],
            pn2[i] - qn2[i],
            pn3[i] - qn3[i],
        );
        let tn = tap.normal.of(d0 * d0 + d1 * d1 + d2 * d2 + d3 * d3);
        // The footprint of the pair (the mean of both), so the weight is symmetric.
        let fx = 0.5 * (pfx[i] + qfx[i]);
        let fy = 0.5 * (pfy[i] + qfy[i]);
        let f2 = (tap.ox * fx) * (tap.ox * fx) + (tap.oy * fy) * (tap.oy * fy);
        let f2 = f2 + if tap.other { fx * fy } else { 0.0 };
        let (d0, d1, d2, d3) = (
            (px0[i] - qx0[i]) + (pl0[i] - ql0[i]),
            (px1[i] - qx1[i]) + (pl1[i] - ql1[i]),
            (px2[i] - qx2[i]) + (pl2[i] - ql2[i]),
            (px3[i] - qx3[i]) + (pl3[i] - ql3[i]),
        );
        let tx = term32(d0 * d0 + d1 * d1 + d2 * d2 + d3 * d3, tap.sx2 * f2);
        let (d0, d1, d2) = (
            (qc0[i] - pc0[i]) + (qd0[i] - pd0[i]),
            (qc1[i] - pc1[i]) + (qd1[i] - pd1[i]),
            (qc2[i] - pc2[i]) + (qd2[i] - pd2[i]),
        );
        let tc = term32(d0 * d0 + d1 * d1 + d2 * d2, tap.sc2 * (pv[i] + qv[i]));
        // Two missed pixels have zero normals and positions: `tn = tx = 0`. A centre without a
        // valid colour is weighed without the colour term.
        let t = ta + tn + tx;
        let t = t + if finite3(pc0[i], pc1[i], pc2[i]) {
            tc
        } else {
            0.0
        };
        let keep = finite3(qc0[i], qc1[i], qc2[i]) & (pm[i] == qm[i]);
        out[i] = if keep { t } else { f32::INFINITY };
    }
}

impl Pass<'_> {
    /// Call `sink.tap(run, weights)` for every tap of the pixels `x0..x0 + len` (at most
    /// `BLOCK`) of row `y` of frame `k`, in the order previous / same / next frame, then rows,
    /// then columns: `weights[i]` is the weight of pixel `x0 + run.lo + i`'s tap (zero where it
    /// does not count), the centre included (weight = kernel weight where the colour is valid).
    /// Weights are symmetric: the tap `q` of `p` has `p` as a tap with the same weight. A centre
    /// whose own colour is not valid gets weights without the colour term.
    ///
    /// With `Weights::Store`, the weights are also stored in the row's `TAPS` rows of weights
    /// (tap `slot(..)` at `[slot * w..(slot + 1) * w]`); with `Weights::Load` they are taken from
    /// there instead of computed.
    #[inline(always)]
    fn block_taps(
        &self,
        (k, y): (usize, usize),
        (x0, len): (usize, usize),
        weights: &mut Weights,
        sink: &mut impl Sink,
    ) {
        let Some(g) = &self.guides[k] else {
            return;
        };
        let (w, h, s) = (g.w, g.h, g.s);
        let colors = |k: usize, y: usize| {
            (
                &self.cur32[k][y * COLOR_PLANES * s..(y + 1) * COLOR_PLANES * s],
                &self.cur[k][y * CHANNELS * s..(y + 1) * CHANNELS * s],
            )
        };
        let (p, (pc, pc64)) = (g.row(y), colors(k, y));
        // The block's own guides and colours, copied to planes of stride `BLOCK`: the same for
        // every tap, and then addressed from one base.
        let mut own = [0.0; (PLANES + COLOR_PLANES) * BLOCK];
        if !matches!(weights, Weights::Load(_)) {
            for g in 0..PLANES {
                own[g * BLOCK..g * BLOCK + len].copy_from_slice(plane(p, s, g, x0, len));
            }
            for c in 0..COLOR_PLANES {
                own[(PLANES + c) * BLOCK..(PLANES + c) * BLOCK + len]
                    .copy_from_slice(plane(pc, s, c, x0, len));
            }
        }
        let (own, own_colors) = own.split_at(PLANES * BLOCK);
        let mut buf = [0.0; BLOCK];
        let step = self.step as isize;
        for &(kq, frame_weight) in &self.sources[k] {
            let other = kq != k;
            let frame_slot = (kq + 1 - k) * B3.len() * B3.len();
            let Some(src) = &self.guides[kq] else {
                continue;
            };
            for (j, ky) in B3.iter().enumerate() {
                let dy = j as isize - 2;
                let Some(qy) = offset(y, dy, self.step, h) else {
                    continue;
                };
                let (q, (qc, _)) = (src.row(qy), colors(kq, qy));
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
                    let slot = (frame_slot + j * B3.len() + i) * w + lo as usize;
                    if let Weights::Load(stored) = weights {
                        sink.tap(run, &stored[slot..slot + run.n]);
                        continue;
                    }
                    let out = &mut buf[..run.n];
                    let base = (frame_weight * kx * ky) as f32;
                    if !other && ox == 0 && dy == 0 {
                        for (o, x) in out.iter_mut().zip(x0..) {
                            let ok = finite3(pc64[x], pc64[s + x], pc64[2 * s + x]);
                            *o = if ok { base } else { 0.0 };
                        }
                    } else {
                        let tap = Tap {
                            base,
                            ox: ox as f32,
                            oy: (dy * step) as f32,
                            other,
                            sc2: self.sc2,
                            sx2: self.sx2,
                            albedo: self.albedo,
                            normal: self.normal,
                        };
                        let (pr, qr) = (
                            Run::new(own, own_colors, BLOCK, run.lo, run.n),
                            Run::new(q, qc, s, run.qx, run.n),
                        );
                        tap_weights(out, &pr, &qr, &tap);
                    }
                    if let Weights::Store(stored) = weights {
                        stored[slot..slot + run.n].copy_from_slice(out);
                    }
                    sink.tap(run, out);
                }
            }
        }
    }

    /// Row `y` of the weight sums of frame `k`'s pixels, and the row's weights (see
    /// `block_taps`).
    fn sums_row(&self, (k, y): (usize, usize), out: &mut [f64], stored: &mut [f32]) {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, just detected.
            unsafe { self.sums_row_avx2((k, y), out, stored) };
            return;
        }
        self.sums_row_any((k, y), out, stored);
    }

    /// The same compiled with AVX2 (8 lanes instead of SSE2's 4; no fused multiply-adds, so
    /// the results are the same bits).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn sums_row_avx2(&self, (k, y): (usize, usize), out: &mut [f64], stored: &mut [f32]) {
        self.sums_row_any((k, y), out, stored);
    }

    #[inline(always)]
    fn sums_row_any(&self, (k, y): (usize, usize), out: &mut [f64], stored: &mut [f32]) {
        let Some(g) = &self.guides[k] else {
            return;
        };
        let mut weights = Weights::Store(stored);
        for (b, out) in out[..g.w].chunks_mut(BLOCK).enumerate() {
            let mut sums = Sums([0.0; BLOCK]);
            self.block_taps((k, y), (b * BLOCK, out.len()), &mut weights, &mut sums);
            out.copy_from_slice(&sums.0[..out.len()]);
        }
    }

    /// Row `y` of the demodulated colours of frame `k` after this pass (as planes). With `sums`
    /// (the weight sums of every pixel) the update is in flux form,
    /// `c_p + sum_q w_pq (c_q - c_p) / max(W_p, W_q)`, which moves as much colour from `p` to
    /// `q` as from `q` to `p` and so keeps the sum of the image; without, the usual normalised
    /// average `sum_q w_pq c_q / W_p`. A pixel whose colour is not valid takes the normalised
    /// average in either case.
    ///
    /// The weights are computed, or with `sums` taken from `stored`, where `sums_row` left them.
    fn update_row(&self, (k, y): (usize, usize), sums: Option<Flux>, out: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, just detected.
            unsafe { self.update_row_avx2((k, y), sums, out) };
            return;
        }
        self.update_row_any((k, y), sums, out);
    }

    /// The same compiled with AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn update_row_avx2(&self, (k, y): (usize, usize), sums: Option<Flux>, out: &mut [f64]) {
        self.update_row_any((k, y), sums, out);
    }

    #[inline(always)]
    fn update_row_any(&self, (k, y): (usize, usize), flux: Option<Flux>, out: &mut [f64]) {
        let sums = flux.map(|f| f.0);
        let mut weights = match flux {
            Some((_, stored)) => Weights::Load(stored),
            None => Weights::Compute,
        };
        let Some(g) = &self.guides[k] else {
            return;
        };
        let (w, s) = (g.w, g.s);
        let cur = &self.cur[k][y * CHANNELS * s..(y + 1) * CHANNELS * s];
        for x0 in (0..w).step_by(BLOCK) {
            let len = BLOCK.min(w - x0);
            let cp = [0, 1, 2].map(|c| &cur[c * s + x0..c * s + x0 + len]);
            let mut valid = [false; BLOCK];
            for (i, v) in valid[..len].iter_mut().enumerate() {
                *v = finite3(cp[0][i], cp[1][i], cp[2][i]);
            }
            let mut acc = Update {
                cur: self.cur,
                s,
                cp,
                flux: sums.map(|sums| (sums, &sums[k][y * s + x0..y * s + x0 + len])),
                // The normalised average is needed for every pixel without `sums`, else only
                // for those without a valid colour.
                average: sums.is_none() || valid[..len].contains(&false),
                delta: [[0.0; BLOCK]; CHANNELS],
                sum: [[0.0; BLOCK]; CHANNELS],
                wsum: [0.0; BLOCK],
            };
            self.block_taps((k, y), (x0, len), &mut weights, &mut acc);
            for (i, valid) in valid[..len].iter().enumerate() {
                let c = [cp[0][i], cp[1][i], cp[2][i]];
                let v = if sums.is_some() && *valid {
                    [
                        c[0] + acc.delta[0][i],
                        c[1] + acc.delta[1][i],
                        c[2] + acc.delta[2][i],
                    ]
                } else if acc.wsum[i] > 0.0 {
                    [
                        acc.sum[0][i] / acc.wsum[i],
                        acc.sum[1][i] / acc.wsum[i],
                        acc.sum[2][i] / acc.wsum[i],
                    ]
                } else {
                    c
                };
                let v = if finite3(v[0], v[1], v[2]) { v } else { c };
                for (ch, v) in v.iter().enumerate() {
                    out[ch * s + x0 + i] = *v;
                }
            }
        }
    }
}

/// The flux form's weight sums of every frame, and the weights of the row being updated.
type Flux<'a> = (&'a [Vec<f64>], &'a [f32]);

/// Where `Pass::block_taps` takes the weights from.
enum Weights<'a> {
    Compute,
    /// Compute them and store them here.
    Store(&'a mut [f32]),
    /// Take them from here.
    Load(&'a [f32]),
}

/// What takes the weights of a block's taps (see `Pass::block_taps`).
trait Sink {
    fn tap(&mut self, run: TapRun, weights: &[f32]);
}

/// The weight sums of a block's pixels.
struct Sums([f64; BLOCK]);

impl Sink for Sums {
    #[inline(always)]
    fn tap(&mut self, run: TapRun, weights: &[f32]) {
        for (a, wq) in self.0[run.lo..run.lo + run.n].iter_mut().zip(weights) {
            *a += *wq as f64;
        }
    }
}

/// The sums of the update of a block's pixels.
struct Update<'a> {
    /// The demodulated colours of every frame.
    cur: &'a [Vec<f64>],
    /// The frames' plane stride.
    s: usize,
    /// The block's colours (per channel).
    cp: [&'a [f64]; CHANNELS],
    /// For the flux form: the weight sums of every frame, and of the block's pixels.
    flux: Option<(&'a [Vec<f64>], &'a [f64])>,
    /// Whether to sum the normalised average too.
    average: bool,
    /// The flux form's `sum_q w_pq (c_q - c_p) / max(W_p, W_q)`.
    delta: [[f64; BLOCK]; CHANNELS],
    /// The normalised average's `sum_q w_pq c_q` and `W_p`.
    sum: [[f64; BLOCK]; CHANNELS],
    wsum: [f64; BLOCK],
}

impl Sink for Update<'_> {
    #[inline(always)]
    fn tap(&mut self, run: TapRun, weights: &[f32]) {
        let (lo, n, s) = (run.lo, run.n, self.s);
        let wts = &weights[..n];
        let src = &self.cur[run.kq][run.qy * CHANNELS * s..(run.qy + 1) * CHANNELS * s];
        let [cq0, cq1, cq2] = [0, 1, 2].map(|c| plane(src, s, c, run.qx, n));
        if let Some((sums, wp)) = self.flux {
            let wp = &wp[lo..lo + n];
            let wq = &sums[run.kq][run.qy * s + run.qx..run.qy * s + run.qx + n];
            let [d0, d1, d2] = &mut self.delta;
            let (d0, d1, d2) = (
                &mut d0[lo..lo + n],
                &mut d1[lo..lo + n],
                &mut d2[lo..lo + n],
            );
            let [cp0, cp1, cp2] = self.cp.map(|c| &c[lo..lo + n]);
            for i in 0..n {
                let wt = wts[i] as f64;
                let m = if wp[i] > wq[i] { wp[i] } else { wq[i] };
                let f = wt / m;
                let ok = (wt > 0.0) & (m > 0.0);
                d0[i] = if ok {
                    d0[i] + f * (cq0[i] - cp0[i])
                } else {
                    d0[i]
                };
                d1[i] = if ok {
                    d1[i] + f * (cq1[i] - cp1[i])
                } else {
                    d1[i]
                };
                d2[i] = if ok {
                    d2[i] + f * (cq2[i] - cp2[i])
                } else {
                    d2[i]
                };
            }
        }
        if self.average {
            let [s0, s1, s2] = &mut self.sum;
            let (s0, s1, s2) = (
                &mut s0[lo..lo + n],
                &mut s1[lo..lo + n],
                &mut s2[lo..lo + n],
            );
            let ws = &mut self.wsum[lo..lo + n];
            for i in 0..n {
                let wt = wts[i] as f64;
                let ok = wt > 0.0;
                s0[i] = if ok { s0[i] + wt * cq0[i] } else { s0[i] };
                s1[i] = if ok { s1[i] + wt * cq1[i] } else { s1[i] };
                s2[i] = if ok { s2[i] + wt * cq2[i] } else { s2[i] };
                ws[i] += wt;
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
mod reference;

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
