//! Rays against a hyperbox, sharp or rounded (`Form::Box`): where a ray enters the set
//! `box(u) <= r` or leaves it, in closed form. A sharp box (`r <= 0`: the box shrunk by `-r`)
//! is met by the slab method. A rounded one (`r > 0`) is the sharp box grown by `r` with its
//! edges rounded: its slab bounds where the ray can meet it, and inside that, piece by piece
//! of the ray, the squared distance to the sharp box is a quadratic (`within`). The set is
//! convex, so leaving it is entering it along the reversed ray from beyond its far side.

use super::dot;
use crate::math::kernel::box_dist;

/// Where the line `u + t w` is inside the sharp box of half-extents `half`: `(enter, leave)`,
/// or none.
#[inline(always)]
fn slab(u: [f64; 4], w: [f64; 4], half: [f64; 4]) -> Option<(f64, f64)> {
    let (mut enter, mut leave) = (f64::NEG_INFINITY, f64::INFINITY);
    for i in 0..4 {
        if half[i] < 0.0 {
            return None;
        }
        // One division: the two planes' roots are within 1.5 ulp of dividing each. A
        // direction too small to invert (zero, or subnormal) runs along the planes.
        let inv = 1.0 / w[i];
        if !inv.is_finite() {
            if u[i].abs() > half[i] {
                return None;
            }
            continue;
        }
        let (a, b) = ((-half[i] - u[i]) * inv, (half[i] - u[i]) * inv);
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

/// The gradient of the distance to the sharp box of half-extents `half` at `u` (grown or
/// shrunk by any `r`, the same): outside, the unit vector from the nearest point of the box;
/// inside, the normal of the nearest face (the first of a tie, as `max` takes it).
pub fn gradient(u: [f64; 4], half: [f64; 4]) -> [f64; 4] {
    let q: [f64; 4] = std::array::from_fn(|i| u[i].abs() - half[i]);
    let sign = u.map(|x| if x < 0.0 { -1.0 } else { 1.0 });
    let out = q.map(|x| x.max(0.0));
    let len = dot(out, out).sqrt();
    if len > 0.0 {
        return std::array::from_fn(|i| sign[i] * out[i] / len);
    }
    let top = (1..4).fold(0, |k, i| if q[i] > q[k] { i } else { k });
    std::array::from_fn(|i| if i == top { sign[i] } else { 0.0 })
}

/// The sign of `value(u, half, r)` (1 or -1), without its square root: outside the sharp
/// box, `|max(q, 0)|` against `r` by their squares. Where the two round apart (`value` within
/// its rounding of 0, often exactly 0), either sign is right: the point is on the surface.
pub fn sign(u: [f64; 4], half: [f64; 4], r: f64) -> f64 {
    let q: [f64; 4] = std::array::from_fn(|i| u[i].abs() - half[i]);
    let top = q[0].max(q[1]).max(q[2].max(q[3]));
    let outside = if top > 0.0 {
        r <= 0.0 || q.map(|x| x.max(0.0)).iter().map(|x| x * x).sum::<f64>() >= r * r
    } else {
        top - r >= 0.0
    };
    if outside { 1.0 } else { -1.0 }
}

/// How the ray `u + t w` meets `box(u) <= r` (`t` in units of `w`, which a row of `A` that is
/// zero leaves shorter than a unit vector): with `inside` false, where
/// it first enters it from outside; with `inside` true, where it leaves it from inside (none:
/// it never does). Inlined: its arguments passed through memory stalled their loads.
#[inline(always)]
pub fn meet(u: [f64; 4], w: [f64; 4], (half, r): ([f64; 4], f64), inside: bool) -> Option<f64> {
    let grown = half.map(|h| h + r);
    // Most rays from outside pass far from a box: first, whether they meet a ball around it
    // at all (a ray starting outside it that heads away, or passes wide): the ball through a
    // sharp box's corners, and for a rounded one (the sharp box grown by a ball of radius
    // `r`) that ball grown by `r`, which lies within the ball through its grown corners
    // (`|half| + r <= |half + r|`, the latter `r` on every axis).
    // `w` need not be a unit vector (a row of `A` may be zero), and the ray's offset from the
    // centre is taken apart from its start, not as `|u|^2 - b^2`, which cancels far away.
    let rr = match r > 0.0 {
        true => (dot(half, half).sqrt() + r).powi(2),
        false => dot(grown, grown),
    };
    if !inside && dot(u, u) > rr {
        let b = dot(u, w);
        let s = b / dot(w, w);
        let off: [f64; 4] = std::array::from_fn(|i| u[i] - s * w[i]);
        if b > 0.0 || dot(off, off) > rr * (1.0 + 1e-12) {
            return None;
        }
    }
    let span = slab(u, w, grown);
    if r <= 0.0 {
        return match (span, inside) {
            (Some((enter, leave)), false) if leave >= 0.0 => Some(enter.max(0.0)),
            (Some((_, leave)), true) => Some(leave.max(0.0)),
            // A point inside that the slab rounds out of is on the surface.
            (None, true) => Some(0.0),
            _ => None,
        };
    }
    let along = |t: f64| -> [f64; 4] { std::array::from_fn(|i| u[i] + t * w[i]) };
    match (span, inside) {
        // Leaving a convex set is entering it along the reversed ray, from beyond its far
        // side.
        (Some((_, leave)), true) if leave > 0.0 => {
            let s = within(along(leave), w.map(|x| -x), (half, r), leave);
            Some(s.map_or(0.0, |s| (leave - s).max(0.0)))
        }
        (_, true) => Some(0.0),
        (Some((enter, leave)), false) if leave >= 0.0 => {
            let from = enter.max(0.0);
            within(along(from), w, (half, r), leave - from).map(|t| from + t)
        }
        _ => None,
    }
}

/// The first `t` in `[0, limit]` at which the ray `u + t w` is within `r > 0` of the sharp
/// box, if it is. Between the points where a coordinate crosses a face's plane
/// (`u_i + t w_i = +-half_i`, at most eight), the same faces are outside, and the squared
/// distance to the box is a quadratic in `t`: the sum over them of `(|u_i + t w_i| -
/// half_i)^2`. The first piece where it comes down to `r^2` holds the root, in closed form.
fn within(u: [f64; 4], w: [f64; 4], (half, r): ([f64; 4], f64), limit: f64) -> Option<f64> {
    let mut cuts = [limit; 9];
    let mut n = 0;
    for i in 0..4 {
        for face in [-half[i], half[i]] {
            let t = (face - u[i]) / w[i];
            if t > 0.0 && t < limit {
                cuts[n] = t;
                n += 1;
            }
        }
    }
    cuts[..n].sort_unstable_by(f64::total_cmp);
    let mut from = 0.0;
    for &to in &cuts[..=n] {
        // The piece's quadratic in `s = t - from`, from the point where it starts (small
        // coefficients, whatever the ray's origin): `a s^2 + b s + c`.
        let mid = 0.5 * (from + to);
        let (mut a, mut b, mut c) = (0.0, 0.0, -r * r);
        for i in 0..4 {
            let m = u[i] + mid * w[i];
            if m.abs() > half[i] {
                let sign = m.signum();
                let (e, k) = (sign * (u[i] + from * w[i]) - half[i], sign * w[i]);
                (a, b, c) = (a + k * k, b + 2.0 * e * k, c + e * e);
            }
        }
        if c <= 0.0 {
            return Some(from);
        }
        // Coming down (`b < 0`) to a root: the smaller one, without cancellation.
        let disc = b * b - 4.0 * a * c;
        if b < 0.0 && disc >= 0.0 {
            let s = 2.0 * c / (-b + disc.sqrt());
            if from + s <= to {
                return Some(from + s);
            }
        }
        from = to;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// `sign` is the sign of `value`, but where `value` is within its rounding of 0,
        /// inside the box and out, sharp (`r <= 0`: shrunk) and rounded.
        #[test]
        fn sign_is_the_values(
            u in prop::array::uniform4(-4.0..4.0f64),
            half in prop::array::uniform4(0.0..3.0f64),
            r in -0.5..1.5f64,
        ) {
            let v = value(u, half, r);
            let scale = u.iter().chain(&half).fold(r.abs(), |m, x| m.max(x.abs()));
            if v.abs() > 1e-14 * scale {
                prop_assert_eq!(sign(u, half, r), v.signum(), "value {}", v);
            }
        }
    }

    /// On the box's surface and in its middle, where the two parts of `sign` meet.
    #[test]
    fn sign_at_the_edges() {
        let half = [1.0, 2.0, 0.5, 1.0];
        assert_eq!(sign([0.0; 4], half, 0.0), -1.0);
        assert_eq!(sign([1.0, 0.0, 0.0, 0.0], half, 0.0), 1.0);
        assert_eq!(sign([1.5, 0.0, 0.0, 0.0], half, 0.5), 1.0);
        assert_eq!(sign([1.4, 0.0, 0.0, 0.0], half, 0.5), -1.0);
        assert_eq!(sign([0.9, 0.0, 0.0, 0.0], half, -0.1), 1.0);
        assert_eq!(sign([0.8, 0.0, 0.0, 0.0], half, -0.1), -1.0);
        // Beyond a corner, by the length of the outside part.
        assert_eq!(sign([1.3, 2.4, 0.0, 0.0], half, 0.49), 1.0);
        assert_eq!(sign([1.3, 2.4, 0.0, 0.0], half, 0.51), -1.0);
    }
}
