//! The a-trous filter written plainly, in `f64`, one pixel and one tap at a time: the
//! reference the optimised filter (`f32` guide planes, blocked rows, vectorised taps) is
//! checked against. It shares the guide preparation, the passes' settings and the final
//! remodulation with the filter, so what it checks is the passes.

use super::super::{Film, compatible, consistent};
use super::guides::{Prepared, prepare};
use super::{
    AtrousOptions, B3, FRAME_WEIGHTS, Temporal, filtered as optimised, offset, remodulated, term,
};
use glam::{DVec3, DVec4};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;

/// The exponent beyond which a tap is dropped (the optimised filter's `CUTOFF`).
const CUTOFF: f64 = super::kernel::CUTOFF as f64;

/// A frame's prepared guides and its film.
struct Guides<'f> {
    film: &'f Film,
    g: Prepared,
}

/// The filtered colour of every frame, without changing the films (`None` for a film whose
/// buffers disagree with its size).
fn filtered(frames: &[Film], opts: &AtrousOptions) -> Vec<Option<Vec<DVec3>>> {
    let guides: Vec<Option<Guides>> = frames
        .par_iter()
        .map(|f| {
            consistent(f).then(|| Guides {
                film: f,
                g: prepare(f, opts),
            })
        })
        .collect();
    // Demodulated colours.
    let mut cur: Vec<Vec<DVec3>> = guides
        .iter()
        .map(|g| match g {
            Some(g) => g
                .film
                .color
                .iter()
                .zip(&g.g.albedo)
                .map(|(c, a)| *c / *a)
                .collect(),
            None => Vec::new(),
        })
        .collect();
    for pass in opts.pass_range() {
        let temporal = opts.temporal.reaches(pass);
        let sc = opts.sigma_color_at(pass);
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
            Some(remodulated(g.film, &g.g.albedo, |p| c[p]))
        })
        .collect()
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
            g.g.albedo[p],
            g.g.var[p],
            g.g.missed[p],
        );
        let (fxp, fyp) = (g.g.fx[p], g.g.fy[p]);
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
                    if src.g.missed[q] != missed {
                        continue;
                    }
                    // Cheapest terms first; a tap is dropped once its weight is negligible.
                    let mut t = term(ap.distance_squared(src.g.albedo[q]), self.sa2);
                    if !missed {
                        t += term(np.distance_squared(src.film.normal[q]), self.sn2);
                        if t > CUTOFF {
                            continue;
                        }
                        // The footprint of the pair (the mean of both), so the weight is symmetric.
                        let fx = 0.5 * (fxp + src.g.fx[q]);
                        let fy = 0.5 * (fyp + src.g.fy[q]);
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
                        t += term((cq - cp).length_squared(), self.sc2 * (vp + src.g.var[q]));
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

/// A standard normal deviate (Box-Muller).
fn gaussian(rng: &mut Pcg64) -> f64 {
    let u: f64 = 1.0 - rng.random::<f64>();
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * rng.random::<f64>()).cos()
}

/// A `w` x `h` animation of `n` frames: a sky in the top eighth (missed rays), two planes meeting
/// at a crease and a sphere in front of them moving two pixels per frame, Gaussian noise of
/// standard error 0.08 on every hit pixel.
fn animation(w: usize, h: usize, n: usize, rng: &mut Pcg64) -> Vec<Film> {
    let f = 1.0 / h as f64;
    let sigma = 0.08;
    (0..n)
        .map(|k| {
            let mut film = Film::new(w, h);
            let (cx, cy, r) = (
                0.3 * w as f64 + 2.0 * k as f64,
                0.6 * h as f64,
                0.2 * h as f64,
            );
            for y in 0..h {
                for x in 0..w {
                    let p = y * w + x;
                    let (xf, yf) = (x as f64 * f, y as f64 * f);
                    if y < h / 8 {
                        film.color[p] = DVec3::new(0.2, 0.3, 0.5);
                        continue;
                    }
                    let (dx, dy) = (x as f64 - cx, y as f64 - cy);
                    let (albedo, irradiance, normal, pos);
                    if dx * dx + dy * dy < r * r {
                        let nz = (1.0 - (dx * dx + dy * dy) / (r * r)).sqrt();
                        normal = DVec4::new(dx / r, dy / r, -nz, 0.0);
                        pos = DVec4::new(xf, yf, 3.0 - nz * r * f, 0.25);
                        albedo = DVec3::splat(0.9);
                        irradiance = 0.2 + 0.8 * nz;
                    } else if x < w / 2 {
                        normal = DVec4::new(0.0, 0.0, -1.0, 0.0);
                        pos = DVec4::new(xf, yf, 5.0, 0.25);
                        albedo = DVec3::new(0.8, 0.6, 0.4);
                        irradiance = 1.0;
                    } else {
                        normal = DVec4::new(-1.0, 0.0, -1.0, 0.0).normalize();
                        pos = DVec4::new(xf, yf, 5.0 + (x - w / 2) as f64 * f, 0.25);
                        albedo = DVec3::new(0.3, 0.5, 0.7);
                        irradiance = 0.5;
                    }
                    film.color[p] = albedo * irradiance
                        + sigma * DVec3::new(gaussian(rng), gaussian(rng), gaussian(rng));
                    film.std_error[p] = DVec3::splat(sigma);
                    film.albedo[p] = albedo;
                    film.normal[p] = normal;
                    film.position[p] = pos;
                    film.depth[p] = pos.z;
                }
            }
            film
        })
        .collect()
}

/// The optimised filter agrees with the reference to 1e-6 relative (it rounds the guides and
/// the weights to `f32`; colours and sums stay `f64`) on every option and on broken input:
/// non-finite colours and guides, films without noise estimates, and films of mismatched
/// sizes or inconsistent buffers.
#[test]
fn optimised_matches_reference() {
    let mut rng = Pcg64::seed_from_u64(12);
    let mut frames = animation(61, 47, 4, &mut rng);
    frames[1].color[100] = DVec3::splat(f64::NAN);
    frames[1].color[300] = DVec3::new(f64::INFINITY, 0.0, 1.0);
    frames[2].normal[500] = DVec4::splat(f64::NAN);
    frames[2].position[700] = DVec4::splat(f64::INFINITY);
    frames[0].albedo[800] = DVec3::splat(f64::NAN);
    frames[3].std_error[900] = DVec3::splat(f64::NAN);
    let mut noiseless = animation(61, 47, 2, &mut rng);
    for f in &mut noiseless {
        f.std_error.iter_mut().for_each(|s| *s = DVec3::ZERO);
    }
    let mut odd = vec![Film::new(5, 3), Film::new(5, 3), Film::new(4, 4)];
    odd[2].normal.clear();
    for f in &mut odd {
        for c in &mut f.color {
            *c = DVec3::splat(rng.random::<f64>());
        }
    }
    let big = animation(256, 192, 3, &mut rng);
    let no_guides = AtrousOptions {
        sigma_normal: f64::INFINITY,
        sigma_position: f64::INFINITY,
        sigma_albedo: f64::INFINITY,
        ..AtrousOptions::default()
    };
    let degenerate = AtrousOptions {
        sigma_color: 0.0,
        sigma_normal: f64::NAN,
        sigma_position: -1.0,
        passes: 7,
        ..AtrousOptions::default()
    };
    let mut worst = 0.0f64;
    let mut compared = 0usize;
    for set in [&frames, &noiseless, &odd, &big] {
        for conserve in [true, false] {
            for temporal in [Temporal::AllPasses, Temporal::FirstPass, Temporal::Off] {
                for opts in [
                    AtrousOptions::default(),
                    no_guides.clone(),
                    degenerate.clone(),
                ] {
                    let opts = AtrousOptions {
                        conserve,
                        temporal,
                        ..opts
                    };
                    let new = optimised(set, &opts);
                    let old = filtered(set, &opts);
                    assert_eq!(new.len(), old.len());
                    for (a, b) in new.iter().zip(&old) {
                        assert_eq!(a.is_some(), b.is_some());
                        let (Some(a), Some(b)) = (a, b) else { continue };
                        for (a, b) in a.iter().zip(b) {
                            for (a, b) in a.to_array().into_iter().zip(b.to_array()) {
                                compared += 1;
                                if a.is_nan() || b.is_nan() {
                                    assert!(a.is_nan() && b.is_nan(), "{a} vs {b}");
                                } else if a != b {
                                    worst = worst.max((a - b).abs() / b.abs().max(1e-3));
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    assert!(compared > 1_000_000, "{compared}");
    assert!(worst < 1e-6, "worst relative difference {worst:e}");
}

/// `cargo test --release --lib -- --ignored --nocapture reference_speed`: both filters on a
/// 256x192 animation of 21 frames, default options.
#[test]
#[ignore = "timing"]
fn reference_speed() {
    let mut rng = Pcg64::seed_from_u64(11);
    let frames = animation(256, 192, 21, &mut rng);
    let opts = AtrousOptions::default();
    for _ in 0..2 {
        let t = std::time::Instant::now();
        optimised(&frames, &opts);
        let fast = t.elapsed();
        let t = std::time::Instant::now();
        filtered(&frames, &opts);
        let plain = t.elapsed();
        println!(
            "256x192x21 a-trous: optimised {fast:?}, reference {plain:?}, ratio {:.2}",
            plain.as_secs_f64() / fast.as_secs_f64()
        );
    }
}
