//! The seed's median filter: per pixel and per channel, the median over the (x, y, frame)
//! neighbourhood of 3x3 pixels times 3 frames.
//!
//! The window is clamped to the animation: at an image border it holds fewer pixels, on the
//! first and last frame (or in an animation of one or two frames) fewer frames. Non-finite
//! values are left out; a channel with no finite value in its window keeps its value. With an
//! even count the median is the mean of the two middle values.
//!
//! Known flaws (`docs/physics.md`, "Denoising"), which is why a-trous is the filter to use:
//! - Monte Carlo noise is skewed (many dark samples, a few bright ones), so a pixel's mean has a
//!   median below its mean and the median filter is **biased dark**: with 10% of the samples at
//!   10 and the rest at 0 (mean 1), the filtered image of 3 frames is 1.6% too dark at 64 samples
//!   per pixel, 10% at 16 and 8% at 8 (`tests/denoise.rs`).
//! - It **erodes thin features**: a line one or two pixels wide is a minority of every window
//!   and disappears.
//!
//! It does remove fireflies (a single outlier is a minority of 27 values), so it is kept as an
//! option and as a firefly detector: compare a pixel with [`medians`].

use super::Film;
use glam::DVec3;
use rayon::prelude::*;

/// Replace every frame's colour by its median-filtered colour.
pub fn median(frames: &mut [Film]) {
    let out = medians(frames);
    for (f, m) in frames.iter_mut().zip(out) {
        if let Some(m) = m {
            f.color = m;
        }
    }
}

/// The median-filtered colour of every frame, without changing the films (`None` for a film
/// whose colour buffer disagrees with its size).
pub fn medians(frames: &[Film]) -> Vec<Option<Vec<DVec3>>> {
    (0..frames.len())
        .map(|k| {
            let window = k.saturating_sub(1)..(k + 2).min(frames.len());
            median_at(&frames[window.clone()], k - window.start)
        })
        .collect()
}

/// The median-filtered colour of `frames[centre]`, whose neighbours in time are the other
/// frames of `frames` (at most one on each side); `None` for a film whose colour buffer
/// disagrees with its size. A stream of frames needs to hold only three.
pub fn median_at(frames: &[Film], centre: usize) -> Option<Vec<DVec3>> {
    let ok = |f: &Film| f.width.checked_mul(f.height) == Some(f.color.len());
    let f = &frames[centre];
    if !ok(f) {
        return None;
    }
    // The frames of the window that match in size.
    let window: Vec<&Film> = (frames.iter())
        .filter(|g| ok(g) && g.width == f.width && g.height == f.height)
        .collect();
    let (w, h) = (f.width, f.height);
    let mut out = f.color.clone();
    if w == 0 {
        return Some(out);
    }
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let ys = y.saturating_sub(1)..=(y + 1).min(h - 1);
        for (x, px) in row.iter_mut().enumerate() {
            let xs = x.saturating_sub(1)..=(x + 1).min(w - 1);
            for c in 0..3 {
                let mut vals = [0.0f64; 27];
                let mut n = 0;
                for g in &window {
                    for qy in ys.clone() {
                        for qx in xs.clone() {
                            let v = g.color[qy * w + qx][c];
                            if v.is_finite() {
                                vals[n] = v;
                                n += 1;
                            }
                        }
                    }
                }
                if let Some(m) = median_of(&mut vals[..n]) {
                    px[c] = m;
                }
            }
        }
    });
    Some(out)
}

/// The median of finite values (mean of the middle two for an even count); `None` when empty.
pub fn median_of(vals: &mut [f64]) -> Option<f64> {
    let n = vals.len();
    if n == 0 {
        return None;
    }
    let (_, &mut hi, _) = vals.select_nth_unstable_by(n / 2, f64::total_cmp);
    if n % 2 == 1 {
        return Some(hi);
    }
    // The lower middle is the largest of the values below the upper middle.
    let lo = vals[..n / 2]
        .iter()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    Some(0.5 * (lo + hi))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_even_and_empty() {
        assert_eq!(median_of(&mut [3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median_of(&mut [4.0, 1.0, 3.0, 2.0]), Some(2.5));
        assert_eq!(median_of(&mut []), None);
        assert_eq!(median_of(&mut [7.0]), Some(7.0));
    }
}
