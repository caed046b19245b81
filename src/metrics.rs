//! Image error against a reference, for judging speed against accuracy: RMSE and mean
//! luminance bias on linear radiance (what the estimator computes), PSNR and SSIM on the
//! displayed image (exposure, filmic curve and sRGB encoding, in [0, 1]), which is what a
//! viewer judges.

use crate::math::color::{luminance, srgb_encode};
use crate::output::tonemap::filmic;
use glam::DVec3;

/// How far one image (or animation, frames laid end to end) is from a reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageError {
    /// Root mean square error of linear radiance over every channel.
    pub rmse: f64,
    /// Peak signal-to-noise ratio of the displayed images, in dB (peak 1).
    pub psnr: f64,
    /// Mean structural similarity of the displayed luminance (1 is identical).
    pub ssim: f64,
    /// Mean luminance relative to the reference's, minus 1.
    pub bias: f64,
}

/// Compare frames of equal size; `frames` and `reference` hold the same number of frames of
/// `width x height` linear RGB pixels each.
pub fn compare(
    frames: &[&[DVec3]],
    reference: &[&[DVec3]],
    width: usize,
    height: usize,
    exposure: f64,
) -> ImageError {
    assert_eq!(
        frames.len(),
        reference.len(),
        "as many frames as the reference"
    );
    let (mut sq, mut n, mut lum, mut lum_ref, mut disp_sq, mut ssim) = (0.0, 0, 0.0, 0.0, 0.0, 0.0);
    for (f, r) in frames.iter().zip(reference) {
        assert!(f.len() == width * height && r.len() == width * height);
        for (a, b) in f.iter().zip(r.iter()) {
            let d = *a - *b;
            sq += d.dot(d);
            n += 3;
            lum += luminance(*a);
            lum_ref += luminance(*b);
            let (da, db) = (display(*a, exposure), display(*b, exposure));
            disp_sq += (da - db).length_squared();
        }
        let la: Vec<f64> = f.iter().map(|c| luminance(display(*c, exposure))).collect();
        let lb: Vec<f64> = r.iter().map(|c| luminance(display(*c, exposure))).collect();
        ssim += mean_ssim(&la, &lb, width, height);
    }
    let n = n.max(1) as f64;
    let mse_display = disp_sq / n;
    ImageError {
        rmse: (sq / n).sqrt(),
        psnr: if mse_display > 0.0 {
            -10.0 * mse_display.log10()
        } else {
            f64::INFINITY
        },
        ssim: ssim / frames.len().max(1) as f64,
        bias: if lum_ref > 0.0 {
            lum / lum_ref - 1.0
        } else {
            0.0
        },
    }
}

/// A linear colour as displayed, each channel in [0, 1].
pub fn display(c: DVec3, exposure: f64) -> DVec3 {
    c.map(|x| srgb_encode(filmic((x * exposure) as f32)) as f64)
}

/// SSIM (Wang et al. 2004) with an 11x11 Gaussian window (sigma 1.5), averaged over every
/// pixel; the window is cut at the borders and renormalised.
fn mean_ssim(a: &[f64], b: &[f64], width: usize, height: usize) -> f64 {
    const C1: f64 = 0.01 * 0.01;
    const C2: f64 = 0.03 * 0.03;
    let kernel: Vec<f64> = (-5..=5_i32)
        .map(|i| (-(i * i) as f64 / (2.0 * 1.5 * 1.5)).exp())
        .collect();
    // Separable Gaussian blur, renormalised at the borders: rows, then columns.
    let blur = |img: &[f64]| -> Vec<f64> {
        let rows = blur_1d(img, &kernel, width, height, (1, width));
        blur_1d(&rows, &kernel, height, width, (width, 1))
    };
    let product = |p: &[f64], q: &[f64]| p.iter().zip(q).map(|(x, y)| x * y).collect::<Vec<_>>();
    let (ma, mb) = (blur(a), blur(b));
    let (saa, sbb, sab) = (
        blur(&product(a, a)),
        blur(&product(b, b)),
        blur(&product(a, b)),
    );
    let mut total = 0.0;
    for i in 0..a.len() {
        let (va, vb) = (saa[i] - ma[i] * ma[i], sbb[i] - mb[i] * mb[i]);
        let cov = sab[i] - ma[i] * mb[i];
        total += ((2.0 * ma[i] * mb[i] + C1) * (2.0 * cov + C2))
            / ((ma[i] * ma[i] + mb[i] * mb[i] + C1) * (va + vb + C2));
    }
    total / a.len().max(1) as f64
}

/// Convolve every line of an image with `kernel` (centred, renormalised where it leaves the
/// image). A line has `len` pixels `step.0` apart; `lines` lines start `step.1` apart.
fn blur_1d(
    img: &[f64],
    kernel: &[f64],
    len: usize,
    lines: usize,
    step: (usize, usize),
) -> Vec<f64> {
    let half = kernel.len() as i64 / 2;
    let mut out = vec![0.0; img.len()];
    for line in 0..lines {
        for i in 0..len {
            let (mut s, mut w) = (0.0, 0.0);
            for (k, kw) in kernel.iter().enumerate() {
                let j = i as i64 + k as i64 - half;
                if (0..len as i64).contains(&j) {
                    s += kw * img[line * step.1 + j as usize * step.0];
                    w += kw;
                }
            }
            out[line * step.1 + i * step.0] = s / w;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(w: usize, h: usize, f: impl Fn(usize, usize) -> f64) -> Vec<DVec3> {
        (0..w * h).map(|i| DVec3::splat(f(i % w, i / w))).collect()
    }

    #[test]
    fn identical_images_are_perfect() {
        let a = image(16, 12, |x, y| (x + y) as f64 / 28.0);
        let e = compare(&[&a], &[&a], 16, 12, 1.0);
        assert_eq!(e.rmse, 0.0);
        assert_eq!(e.psnr, f64::INFINITY);
        assert!((e.ssim - 1.0).abs() < 1e-12);
        assert_eq!(e.bias, 0.0);
    }

    #[test]
    fn errors_grow_with_noise_and_bias_has_a_sign() {
        let a = image(32, 24, |x, y| 0.2 + 0.5 * ((x * y) % 7) as f64 / 7.0);
        let noisy = |amp: f64| -> Vec<DVec3> {
            a.iter()
                .enumerate()
                .map(|(i, c)| *c + DVec3::splat(amp * if i % 2 == 0 { 1.0 } else { -1.0 }))
                .collect()
        };
        let (small, large) = (noisy(0.01), noisy(0.1));
        let es = compare(&[&small], &[&a], 32, 24, 1.0);
        let el = compare(&[&large], &[&a], 32, 24, 1.0);
        assert!((es.rmse - 0.01).abs() < 1e-12, "{}", es.rmse);
        assert!(el.rmse > es.rmse && el.psnr < es.psnr && el.ssim < es.ssim);
        let dark: Vec<DVec3> = a.iter().map(|c| *c * 0.9).collect();
        let e = compare(&[&dark], &[&a], 32, 24, 1.0);
        assert!((e.bias + 0.1).abs() < 1e-12, "{}", e.bias);
    }
}
