//! Linear HDR radiance to 8-bit sRGB.

use super::HdrImage;
use crate::math::color::srgb_encode;

/// The filmic tone curve: the ACES fitted curve of Narkowicz (2015),
///
/// ```text
/// f(x) = x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14)
/// ```
///
/// clamped to `[0, 1]`. It is strictly increasing on `x >= 0`, with `f(0) = 0`, and reaches 1 at
/// about `x = 7.24`, so highlights roll off smoothly instead of clipping. NaN and negative inputs
/// give 0, `+inf` gives 1.
pub fn filmic(x: f32) -> f32 {
    if x.is_nan() || x <= 0.0 {
        return 0.0;
    }
    // The curve passes 1 near 7.24; cutting off early also keeps `x * x` from overflowing.
    if x >= 8.0 {
        return 1.0;
    }
    let y = (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14);
    y.clamp(0.0, 1.0)
}

/// One linear channel value (already scaled by the exposure) to an 8-bit sRGB code value.
pub fn channel_to_srgb8(linear: f32) -> u8 {
    // `as u8` saturates, and both functions above already map into [0, 1].
    (srgb_encode(filmic(linear)) * 255.0).round() as u8
}

/// Tone-map a frame for display: multiply by `exposure`, apply [`filmic`] per channel, then
/// [`srgb_encode`], rounding to 8 bits. NaN and negative values map to 0, `+inf` to 255.
pub fn to_srgb8(img: &HdrImage, exposure: f64) -> Vec<[u8; 3]> {
    let exposure = exposure as f32;
    img.data
        .iter()
        .map(|p| p.map(|c| channel_to_srgb8(c * exposure)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn filmic_is_monotone_from_zero_to_one() {
        assert_eq!(filmic(0.0), 0.0);
        assert_eq!(filmic(-1.0), 0.0);
        assert_eq!(filmic(f32::NAN), 0.0);
        assert_eq!(filmic(f32::INFINITY), 1.0);
        assert!(filmic(100.0) > 0.999);
        assert!(filmic(1e30) > 0.999);
        let mut prev = 0.0;
        for i in 1..=20_000 {
            let y = filmic(i as f32 * 0.001);
            assert!(y >= prev, "not monotone at {}", i as f32 * 0.001);
            assert!((0.0..=1.0).contains(&y));
            prev = y;
        }
        // Strictly increasing below the clamp point, and continuous across the cutoff.
        assert!(filmic(1.0) < filmic(2.0));
        assert_eq!(filmic(7.9), 1.0);
    }

    #[test]
    fn srgb_encode_matches_known_values() {
        assert_eq!(srgb_encode(0.0), 0.0);
        assert_eq!(srgb_encode(1.0), 1.0);
        // Both pieces agree at the boundary.
        let b = 0.003_130_8_f32;
        let lin = 12.92 * b;
        let pow = 1.055 * b.powf(1.0 / 2.4) - 0.055;
        assert!((lin - pow).abs() < 1e-5);
        assert!((srgb_encode(b) - 0.040_45).abs() < 1e-4);
        assert!((srgb_encode(0.5) - 0.735_36).abs() < 1e-4);
        assert!((srgb_encode(0.001) - 0.012_92).abs() < 1e-7);
        assert!((srgb_encode(0.18) - 0.461_35).abs() < 1e-4);
    }

    #[test]
    fn to_srgb8_handles_special_values() {
        let img = HdrImage {
            width: 5,
            height: 1,
            data: vec![
                [f32::NAN, -1.0, f32::INFINITY],
                [0.0, 0.0, 0.0],
                [f32::NEG_INFINITY, 1e30, f32::MAX],
                [0.18, 0.18, 0.18],
                [1e-9, 1e-9, 1e-9],
            ],
        };
        let out = to_srgb8(&img, 1.0);
        assert_eq!(out[0], [0, 0, 255]);
        assert_eq!(out[1], [0, 0, 0]);
        assert_eq!(out[2], [0, 255, 255]);
        assert!(out[3][0] > 0 && out[3][0] < 255);
        assert_eq!(out[4], [0, 0, 0]);
        // Exposure scales before the curve.
        let brighter = to_srgb8(&img, 4.0);
        assert!(brighter[3][0] > out[3][0]);
    }
}
