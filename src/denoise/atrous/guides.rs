//! Guide preparation: what the filter knows of every pixel besides its colour (demodulation
//! factor, normal, position, footprints, noise variance), computed once in `f64`
//! (`prepare`) and stored as `f32` planes (`pack`) for the vectorised taps.

use super::kernel::CUTOFF;
use super::{AtrousOptions, B3, offset, term};
use crate::denoise::consistent;
use crate::film::Film;
use glam::{DVec3, DVec4};
use rayon::prelude::*;

/// Added to the albedo before demodulating.
pub const ALBEDO_EPSILON: f64 = 1e-3;

// The `f32` planes of a frame's guides (see `Guides`).
/// The demodulation factor (3 planes).
pub(super) const ALBEDO: usize = 0;
/// The 4D normal (4 planes).
pub(super) const NORMAL: usize = 3;
/// The 4D position, rounded to `f32` (4 planes), and what the rounding left (4 planes).
pub(super) const POSITION: usize = 7;
pub(super) const POSITION_LO: usize = 11;
/// The footprints `f_x` and `f_y`.
pub(super) const FOOT_X: usize = 15;
pub(super) const FOOT_Y: usize = 16;
/// The variance of the demodulated colour.
pub(super) const VAR: usize = 17;
/// 1 where the camera ray missed, else 0.
pub(super) const MISSED: usize = 18;
pub(super) const PLANES: usize = 19;
/// The `f32` planes of a frame's colours: rounded (3) and what the rounding left (3).
pub(super) const COLOR_PLANES: usize = 6;
/// The `f64` planes of a frame's colours (red, green, blue).
pub(super) const CHANNELS: usize = 3;

/// A frame's guides, prepared once, as planes of `f32` stored row by row: row `y` is
/// `data[y * PLANES * s..][..PLANES * s]` and holds plane `g` (`ALBEDO`, ..., `MISSED`) at
/// `[g * s..g * s + w]`, where `s = stride(w)`. The colours are stored alike (`CHANNELS`
/// planes of `f64`, `COLOR_PLANES` of `f32`). A tap of a run of pixels of a row then reads a
/// contiguous run of every plane, which vectorises.
pub(super) struct Guides {
    pub(super) w: usize,
    pub(super) h: usize,
    /// The planes' stride.
    pub(super) s: usize,
    /// The demodulation factor of every pixel: albedo (clamped, finite) + `ALBEDO_EPSILON`.
    pub(super) albedo: Vec<DVec3>,
    pub(super) data: Vec<f32>,
}

impl Guides {
    pub(super) fn row(&self, y: usize) -> &[f32] {
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
pub(super) fn plane<T>(row: &[T], s: usize, g: usize, x: usize, n: usize) -> &[T] {
    &row[g * s + x..g * s + x + n]
}

/// Pixel buffers of `w` by `h` pixels stored as `P` planes of stride `s` row by row (see
/// `Guides`), from `px(p)`, the planes' values at pixel `p`.
pub(super) fn to_planes<T: Copy + Default, const P: usize>(
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
pub(super) fn split(v: f64) -> (f32, f32) {
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

fn is_missed(n: DVec4) -> bool {
    n.length_squared() == 0.0
}

/// The largest footprint and colour variance of a set of frames, which set the scales the
/// guides are stored at (powers of two, so that the filter's result does not depend on them
/// unless `f32` would overflow or underflow). The variance is each pixel's own, before it is
/// smoothed: smoothing averages, so its largest value bounds the smoothed ones, and the scales
/// pass need not smooth. Neighbouring frames' guides are compared, so every frame of an
/// animation is stored at the same scales: a streaming filter learns them in a pass over the
/// frames before filtering.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Scales {
    footprint: f64,
    variance: f64,
}

impl Scales {
    /// The scales of one frame (zero for a film whose buffers disagree with its size).
    pub fn of(film: &Film, opts: &AtrousOptions) -> Scales {
        if consistent(film) {
            Scales::of_prepared(&unsmoothed(film, opts))
        } else {
            Scales::default()
        }
    }

    fn of_prepared(p: &Prepared) -> Scales {
        Scales {
            footprint: p.fx.iter().chain(&p.fy).copied().fold(0.0, f64::max),
            variance: p.var.iter().copied().fold(0.0, f64::max),
        }
    }

    /// Whether both are finite numbers (what a film's header can hold: JSON has no infinity).
    pub fn is_finite(self) -> bool {
        self.footprint.is_finite() && self.variance.is_finite()
    }

    /// The scales of two sets of frames together.
    pub fn max(self, o: Scales) -> Scales {
        Scales {
            footprint: self.footprint.max(o.footprint),
            variance: self.variance.max(o.variance),
        }
    }

    /// The factors positions (and footprints) and colours are stored at: powers of two, so
    /// that scaling is exact.
    pub(super) fn factors(self) -> (f64, f64) {
        (scale_for(self.footprint), scale_for(self.variance.sqrt()))
    }
}

/// A frame's guides at the scales of its animation, or `None` for a film whose buffers
/// disagree with its size.
pub(super) fn of_frame(film: &Film, opts: &AtrousOptions, scales: Scales) -> Option<Guides> {
    let (scale_x, scale_c) = scales.factors();
    consistent(film).then(|| pack(film, prepare(film, opts), scale_x, scale_c))
}

/// A frame's guides in `f64`, before they are scaled and stored as planes.
pub(super) struct Prepared {
    /// The demodulation factor.
    pub(super) albedo: Vec<DVec3>,
    pub(super) missed: Vec<bool>,
    /// Footprint: distance to the nearer neighbour on the same surface, horizontally / vertically.
    pub(super) fx: Vec<f64>,
    pub(super) fy: Vec<f64>,
    /// Variance of the demodulated colour, summed over the channels.
    pub(super) var: Vec<f64>,
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

pub(super) fn prepare(film: &Film, opts: &AtrousOptions) -> Prepared {
    let p = unsmoothed(film, opts);
    let var = smooth_variance(&p.surface(film, opts), &p.var);
    Prepared { var, ..p }
}

/// The guides with each pixel's own variance, not yet smoothed (see `smooth_variance`).
fn unsmoothed(film: &Film, opts: &AtrousOptions) -> Prepared {
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
    let mut p = Prepared {
        albedo,
        missed,
        fx,
        fy,
        var: Vec::new(),
    };
    p.var = if no_noise_info {
        spatial_variance(&p.surface(film, opts), &p.albedo)
    } else {
        (film.std_error.iter().zip(&p.albedo))
            .map(|(s, a)| {
                let s = DVec3::new(sanitize(s.x), sanitize(s.y), sanitize(s.z)) / *a;
                let v = s.length_squared();
                if v.is_finite() { v } else { 0.0 }
            })
            .collect()
    };
    p
}

impl Prepared {
    /// What the variance estimates weigh neighbours by.
    fn surface<'a>(&'a self, film: &'a Film, opts: &AtrousOptions) -> Surface<'a> {
        Surface {
            film,
            missed: &self.missed,
            fx: &self.fx,
            fy: &self.fy,
            sn2: opts.sigma_normal * opts.sigma_normal,
            sx2: opts.sigma_position * opts.sigma_position,
        }
    }
}

/// What tells whether two pixels of a frame lie on the same surface, for the variance
/// estimates: their normals and positions, as the filter's guides weigh them.
struct Surface<'a> {
    film: &'a Film,
    missed: &'a [bool],
    fx: &'a [f64],
    fy: &'a [f64],
    /// The squared sigmas of the normal and of the position.
    sn2: f64,
    sx2: f64,
}

impl Surface<'_> {
    /// The normal and position terms of the weight of pixel `q`, `(dx, dy)` pixels from `p`:
    /// zero where both rays missed, `None` where only one did.
    fn exponent(&self, p: usize, q: usize, (dx, dy): (f64, f64)) -> Option<f64> {
        if self.missed[p] != self.missed[q] {
            return None;
        }
        if self.missed[p] {
            return Some(0.0);
        }
        let (n, x) = (&self.film.normal, &self.film.position);
        let f2 = (dx * self.fx[p]).powi(2) + (dy * self.fy[p]).powi(2);
        Some(
            term(n[p].distance_squared(n[q]), self.sn2)
                + term(x[p].distance_squared(x[q]), self.sx2 * f2),
        )
    }
}

/// The variance averaged over the pixel's 5x5 neighbourhood on the same surface (B3 weights
/// times the normal and position guides). A pixel's own standard error, estimated from its few
/// samples, is itself very noisy and correlated with its value (a 16-sample pixel that caught
/// no light reports zero variance); weights built from it would treat dark and bright pixels
/// differently and shift the mean.
fn smooth_variance(surface: &Surface, var: &[f64]) -> Vec<f64> {
    let (w, h) = (surface.film.width, surface.film.height);
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
                    let Some(t) = surface.exponent(p, q, (dx as f64, dy as f64)) else {
                        continue;
                    };
                    // Without the C library's `exp` where it is known: the centre and taps
                    // where both rays missed (0), and taps across an edge (dropped, as the
                    // filter's are: weights below 4e-18 of the centre's).
                    let e = match t {
                        0.0 => 1.0,
                        t if t > CUTOFF as f64 => continue,
                        t => (-t).exp(),
                    };
                    let wq = kx * ky * e;
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
fn spatial_variance(surface: &Surface, albedo: &[DVec3]) -> Vec<f64> {
    let film = surface.film;
    let (w, h) = (film.width, film.height);
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
                    if !c.is_finite() {
                        continue;
                    }
                    let d = (qx as f64 - x as f64, qy as f64 - y as f64);
                    let Some(t) = surface.exponent(p, q, d) else {
                        continue;
                    };
                    if t > std::f64::consts::LN_2 {
                        continue;
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

#[cfg(test)]
mod tests {
    use super::Scales;
    use rand::{Rng, SeedableRng};

    /// Film headers carry a frame's scales as JSON (`FilmMeta::scales`), and finishing must
    /// read back the very numbers (serde_json's `float_roundtrip`: without it, 29% of random
    /// numbers came back a unit in the last place off).
    #[test]
    fn scales_survive_json_bit_for_bit() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(11);
        for _ in 0..20_000 {
            // Positive and finite: the sign bit and the top exponent bit clear.
            let mut number = || f64::from_bits(rng.random::<u64>() >> 2);
            let s = Scales {
                footprint: number(),
                variance: number(),
            };
            let text = serde_json::to_string(&s).expect("scales serialise");
            let back: Scales = serde_json::from_str(&text).expect("scales parse");
            assert_eq!(
                (back.footprint.to_bits(), back.variance.to_bits()),
                (s.footprint.to_bits(), s.variance.to_bits()),
                "{text}"
            );
        }
    }
}
