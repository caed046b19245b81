//! Rays against a hyperbox, sharp or rounded (`Form::Box`): where a ray enters the set
//! `box(u) <= r` or leaves it. A sharp box (`r <= 0`: the box shrunk by `-r`) is met by the
//! slab method, in closed form. A rounded one (`r > 0`) is the sharp box grown by `r` with its
//! edges rounded: its slab bounds the march, which follows the exact distance in `f64` inside
//! them. The set is convex, so the distance along a line is a convex function: neither a
//! sphere step nor a secant through two points short of the surface passes it, and once the
//! distance grows it grows for good.

use crate::math::kernel::box_dist;

/// Most distance evaluations a rounded box's march takes before it says how far it got.
const ROUNDED_STEPS: usize = 48;

/// Where the line `u + t w` is inside the sharp box of half-extents `half`: `(enter, leave)`,
/// or none.
fn slab(u: [f64; 4], w: [f64; 4], half: [f64; 4]) -> Option<(f64, f64)> {
    let (mut enter, mut leave) = (f64::NEG_INFINITY, f64::INFINITY);
    for i in 0..4 {
        if half[i] < 0.0 {
            return None;
        }
        if w[i] == 0.0 {
            if u[i].abs() > half[i] {
                return None;
            }
            continue;
        }
        let (a, b) = ((-half[i] - u[i]) / w[i], (half[i] - u[i]) / w[i]);
        enter = enter.max(a.min(b));
        leave = leave.min(a.max(b));
    }
    (enter <= leave).then_some((enter, leave))
}

/// The signed distance to `box(u) <= r`.
pub fn value(u: [f64; 4], half: [f64; 4], r: f64) -> f64 {
    let mut v = [0.0; 9];
    v[4..8].copy_from_slice(&half);
    v[8] = r;
    box_dist(u, v)
}

/// How the ray `u + t w` (`w` a unit vector) meets `box(u) <= r`: with `inside` false, where
/// it first enters it from outside; with `inside` true, where it leaves it from inside. `Ok`
/// holds the `t` (none: it never does); `Err` says how far the ray is known to stay where it
/// is, where a rounded box's march gave up first (a ray grazing an edge).
pub fn meet(
    u: [f64; 4],
    w: [f64; 4],
    (half, r): ([f64; 4], f64),
    inside: bool,
) -> Result<Option<f64>, f64> {
    let grown = half.map(|h| h + r);
    let span = slab(u, w, grown);
    if r <= 0.0 {
        return Ok(match (span, inside) {
            (Some((enter, leave)), false) if leave >= 0.0 => Some(enter.max(0.0)),
            (Some((_, leave)), true) => Some(leave.max(0.0)),
            // A point inside that the slab rounds out of is on the surface.
            (None, true) => Some(0.0),
            _ => None,
        });
    }
    let at = |t: f64| value(std::array::from_fn(|i| u[i] + t * w[i]), half, r);
    if inside {
        // Leaving a convex set is entering it along the reversed ray, from beyond its far
        // side.
        let Some((_, leave)) = span else {
            return Err(-at(0.0));
        };
        let far: [f64; 4] = std::array::from_fn(|i| u[i] + leave * w[i]);
        let back = w.map(|x| -x);
        return match march(far, back, half, r, leave) {
            Ok(Some(s)) => Ok(Some((leave - s).max(0.0))),
            // The ray's own point is inside: it leaves somewhere before the far side.
            _ => Err(-at(0.0)),
        };
    }
    match span {
        Some((enter, leave)) if leave >= 0.0 => {
            let from = enter.max(0.0);
            let start: [f64; 4] = std::array::from_fn(|i| u[i] + from * w[i]);
            match march(start, w, half, r, leave - from) {
                Ok(t) => Ok(t.map(|t| from + t)),
                Err(t) => Err(from + t),
            }
        }
        _ => Ok(None),
    }
}

/// The first `t` in `[0, limit]` at which the ray `u + t w`, starting outside `box(u) <= r`,
/// reaches it (`Ok(None)`: it does not), or how far it got (`Err`).
fn march(u: [f64; 4], w: [f64; 4], half: [f64; 4], r: f64, limit: f64) -> Result<Option<f64>, f64> {
    let at = |t: f64| value(std::array::from_fn(|i| u[i] + t * w[i]), half, r);
    // Converged within a trillionth of the rounding radius, or where the distance is at the
    // rounding of what it is computed from here (the march starts on the grown box's slab):
    // a half-extent far larger than the point's coordinate along it does not enter.
    let scale = (0..4).fold(r, |m, i| m.max(u[i].abs().min(half[i])));
    let tol = (1e-12 * r).max(4.0 * f64::EPSILON * scale);
    let (mut t, mut d) = (0.0, at(0.0));
    let mut last: Option<(f64, f64)> = None;
    for _ in 0..ROUNDED_STEPS {
        if d <= tol {
            return Ok(Some(t));
        }
        if t > limit {
            return Ok(None);
        }
        let mut next = t + d;
        if let Some((t0, d0)) = last {
            // Convex along the line: growing, it never comes back down.
            if d > d0 + tol {
                return Ok(None);
            }
            if d < d0 {
                next = next.max(t + d * (t - t0) / (d0 - d));
            }
        }
        last = Some((t, d));
        t = next;
        d = at(t);
    }
    if d <= tol {
        return Ok(Some(t));
    }
    // Every step fell short of the surface.
    Err(t)
}
