//! Colour curves: the sRGB transfer function both ways, HSV, and luminance.

use super::kernel::floor_mod;
use glam::DVec3;

/// Rec. 709 luminance of linear RGB.
pub fn luminance(c: DVec3) -> f64 {
    c.dot(DVec3::new(0.2126, 0.7152, 0.0722))
}

/// Decode an sRGB channel in `[0, 1]` to linear light (`#rrggbb` colours are sRGB; the
/// renderer works in linear light).
pub fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// The exact sRGB transfer function (IEC 61966-2-1): `12.92 x` up to `x = 0.0031308`, then
/// `1.055 x^(1/2.4) - 0.055`. The input is clamped to `[0, 1]` first; NaN gives 0.
pub fn srgb_encode(linear: f32) -> f32 {
    if linear.is_nan() || linear <= 0.0 {
        return 0.0;
    }
    if linear >= 1.0 {
        return 1.0;
    }
    if linear <= 0.003_130_8 {
        12.92 * linear
    } else {
        1.055 * linear.powf(1.0 / 2.4) - 0.055
    }
}

/// Hue (radians), saturation and value to linear RGB.
pub fn hsv(h: f64, s: f64, v: f64) -> [f64; 3] {
    let h = floor_mod(h.to_degrees(), 360.0) / 60.0;
    let c = v * s;
    let x = c * (1.0 - (h % 2.0 - 1.0).abs());
    let (r, g, b) = match h as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    [r + m, g + m, b + m]
}
