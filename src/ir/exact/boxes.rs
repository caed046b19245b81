//! Rays against a hyperbox, sharp or rounded (`Form::Box`): where a ray enters the set
//! `box(u) <= r` or leaves it, in closed form. A sharp box (`r <= 0`: the box shrunk by `-r`)
//! is met by the slab method. A rounded one (`r > 0`) is the sharp box grown by `r` with its
//! edges rounded: its slab bounds where the ray can meet it, and inside that, piece by piece
//! of the ray, the squared distance to the sharp box is a quadratic (`within`). The set is
//! convex, so leaving it is entering it along the reversed ray from beyond its far side.

use super::dot;
use crate::math::lanes::{self, Lane, each};

/// Four points or directions, coordinate by coordinate (`x[i][lane]`): what `meet_lanes`
/// takes, so that every step is a loop over the lanes, which the compiler puts in the lanes of
/// a vector.
pub type Four = [[f64; 4]; 4];

/// Four copies of `x`, for one point met as four (the lanes' code is the only one).
#[inline(always)]
fn broadcast(x: [f64; 4]) -> Four {
    x.map(|c| [c; 4])
}

/// The signed distance to `box(u) <= r`.
#[inline(always)]
pub fn value(u: [f64; 4], half: [f64; 4], r: f64) -> f64 {
    values(&broadcast(u), half, r).0[0]
}

/// The gradient of the distance to the sharp box of half-extents `half` at `u` (one point or
/// four; grown or shrunk by any `r`, the same): outside, the unit vector from the nearest
/// point of the box; inside, the normal of the nearest face (the first of a tie, as `max`
/// takes it).
#[inline(always)]
pub fn gradient<L: Lane>(u: [L; 4], half: [f64; 4]) -> [L; 4] {
    let (zero, one) = (L::splat(0.0), L::splat(1.0));
    let q: [L; 4] = each(|i| u[i].abs() - L::splat(half[i]));
    let sign = u.map(|x| L::select(x.lt(zero), -one, one));
    let out = q.map(|x| x.max(zero));
    let len = lanes::dot(out, out).sqrt();
    // Inside: the first of the highest `q`s.
    let (mut high, mut top) = (q[0], zero);
    for (i, &q) in q.iter().enumerate().skip(1) {
        let higher = q.gt(high);
        (high, top) = (
            L::select(higher, q, high),
            L::select(higher, L::splat(i as f64), top),
        );
    }
    each(|i| {
        let face = top.gt(L::splat(i as f64 - 0.5)) & top.lt(L::splat(i as f64 + 0.5));
        let inside = L::select(face, sign[i], zero);
        L::select(len.gt(zero), sign[i] * out[i] / len, inside)
    })
}

/// The sign of `value(u, half, r)` (1 or -1) at one point or four, without its square root:
/// outside the sharp box, `|max(q, 0)|` against `r` by their squares. Where the two round
/// apart (`value` within its rounding of 0, often exactly 0), either sign is right: the point
/// is on the surface.
#[inline(always)]
pub fn sign<L: Lane>(u: [L; 4], half: [f64; 4], r: f64) -> L {
    // One point fills all four lanes. The value's square root is dead code here, and left
    // out.
    let u: Four = u.map(|x| each(|l| x.at(l % L::N)));
    let signs = values(&u, half, r).1;
    L::each(|l| signs[l])
}

/// `a . b` lane by lane, in `dot`'s order.
#[inline(always)]
fn dots(a: &Four, b: &Four) -> [f64; 4] {
    each(|l| a[0][l] * b[0][l] + a[1][l] * b[1][l] + a[2][l] * b[2][l] + a[3][l] * b[3][l])
}

/// `value` and `sign` at four points: `math::kernel::box_dist`'s operations in its order for
/// the value (`Real::max` and `min`, which keep `x` where a comparison with NaN fails).
#[inline(always)]
fn values(u: &Four, half: [f64; 4], r: f64) -> ([f64; 4], [f64; 4]) {
    let max = |x: f64, y: f64| if y > x { y } else { x };
    let min = |x: f64, y: f64| if y < x { y } else { x };
    let q: Four = each(|i| each(|l| u[i][l].abs() - half[i]));
    let o: Four = each(|i| each(|l| max(q[i][l], 0.0)));
    let length = dots(&o, &o);
    let most = each(|l| min(max(max(q[0][l], q[1][l]), max(q[2][l], q[3][l])), 0.0));
    let value = each(|l| length[l].sqrt() + most[l] - r);
    // The sign's own parts, with `f64::max`, which takes the other number where one is NaN
    // (as `sign` always has); both sides' tests, without branches.
    let p: Four = each(|i| each(|l| q[i][l].max(0.0)));
    let far = dots(&p, &p);
    let top = each(|l| q[0][l].max(q[1][l]).max(q[2][l].max(q[3][l])));
    let sign = each(|l| {
        let out = top[l] > 0.0;
        let outside = (out & ((r <= 0.0) | (far[l] >= r * r))) | (!out & (top[l] - r >= 0.0));
        if outside { 1.0 } else { -1.0 }
    });
    (value, sign)
}

/// How four rays `u + t w` (`t` in units of `w`, which a row of `A` that is zero leaves shorter
/// than a unit vector) meet `sign (box(u) - r)`, or with `shell` `Some(k)`, the shell `|sign
/// (box(u) - r)| - k` on the side of it each starts on: each one's value at its start and
/// the first `t` at which it reaches the surface from where the value is positive (0 where it
/// is not positive; NaN where it never does), for the first `live` lanes. On its side, a ray either
/// enters the set `box <= r'` from outside or leaves it from inside.
#[inline(always)]
pub fn meet_lanes(
    (u, w): (&Four, &Four),
    (half, r, sign): ([f64; 4], f64, f64),
    shell: Option<f64>,
    live: usize,
) -> ([f64; 4], [f64; 4]) {
    let (v, side) = values(u, half, r);
    // The side from the sign alone, which needs no square root: the meeting then need not
    // wait for one (`v` is only the value's).
    let (mut value, mut grown, mut inside) = ([0.0; 4], [0.0; 4], [false; 4]);
    for l in 0..4 {
        let (s, k) = super::side(sign * side[l], shell);
        let sign = s * sign;
        (value[l], grown[l], inside[l]) = (sign * v[l] - k, r + sign * k, sign < 0.0);
    }
    // The sharp box each ray meets, grown by its `r'`: half-extents lane by lane.
    let g: Four = each(|i| each(|l| half[i] + grown[l]));
    // Rays that start inside (in a hollow shell's room, all of them) cannot pass it by.
    let pass = match inside.iter().all(|&i| i) {
        true => [false; 4],
        false => passes((u, w), (half, &g), (grown, inside)),
    };
    // A ray meets the surface where it starts unless the value there is positive (a NaN
    // value too: where it starts is not known to be outside).
    let ahead = each(|l| value[l] > 0.0);
    let mut first = each(|l| if ahead[l] { f64::NAN } else { 0.0 });
    // Rays that start in the set or pass it by, as most do, need not span it.
    if (0..live).all(|l| !ahead[l] | pass[l]) {
        return (value, first);
    }
    let spans = slabs((u, w), &g);
    for l in (0..live).filter(|&l| ahead[l] & !pass[l]) {
        let ray = (super::lane(u, l), super::lane(w, l));
        first[l] = finish(ray, (half, grown[l]), inside[l], spans[l]).unwrap_or(f64::NAN);
    }
    (value, first)
}

/// Whether each ray, from outside, passes the box `box <= r` by (most rays from outside
/// pass far from it): whether it misses a ball around it at all, starting outside it and
/// heading away, or passing wide. The ball through a sharp box's corners, and for a rounded
/// one (the sharp box grown by a ball of radius `r`) that ball grown by `r`, which lies
/// within the ball through its grown corners (`|half| + r <= |half + r|`, the latter `r` on
/// every axis). `w` need not be a unit vector (a row of `A` may be zero), and the ray's
/// offset from the centre is taken apart from its start, not as `|u|^2 - b^2`, which
/// cancels far away. `g` is `half + r`, lane by lane.
#[inline(always)]
fn passes(
    (u, w): (&Four, &Four),
    (half, g): ([f64; 4], &Four),
    (r, inside): ([f64; 4], [bool; 4]),
) -> [bool; 4] {
    let corner = dot(half, half).sqrt();
    let grown = dots(g, g);
    let reach = each(|l| corner + r[l]);
    let rr = each(|l| {
        if r[l] > 0.0 {
            reach[l] * reach[l]
        } else {
            grown[l]
        }
    });
    let (b, ww, uu) = (dots(u, w), dots(w, w), dots(u, u));
    let s = each(|l| b[l] / ww[l]);
    let off: Four = each(|i| each(|l| u[i][l] - s[l] * w[i][l]));
    let oo = dots(&off, &off);
    each(|l| !inside[l] & (uu[l] > rr[l]) & ((b[l] > 0.0) | (oo[l] > rr[l] * (1.0 + 1e-12))))
}

/// Where each line `u + t w` is inside the sharp box of half-extents `g`: `(enter,
/// leave)`, empty (`enter > leave`, as `(inf, -inf)`) where it is nowhere. One division per
/// coordinate: the two planes' roots are within 1.5 ulp of dividing each. A direction too
/// small to invert (zero, or subnormal) runs along the planes.
#[inline(always)]
fn slabs((u, w): (&Four, &Four), g: &Four) -> [(f64, f64); 4] {
    let inv: Four = each(|i| each(|l| 1.0 / w[i][l]));
    let a: Four = each(|i| each(|l| (-g[i][l] - u[i][l]) * inv[i][l]));
    let b: Four = each(|i| each(|l| (g[i][l] - u[i][l]) * inv[i][l]));
    let (mut enter, mut leave) = ([f64::NEG_INFINITY; 4], [f64::INFINITY; 4]);
    let mut empty = [false; 4];
    for i in 0..4 {
        let along = each(|l| !inv[i][l].is_finite());
        empty = each(|l| empty[l] | (g[i][l] < 0.0) | (along[l] & (u[i][l].abs() > g[i][l])));
        let near = each(|l| enter[l].max(a[i][l].min(b[i][l])));
        let far = each(|l| leave[l].min(a[i][l].max(b[i][l])));
        enter = each(|l| if along[l] { enter[l] } else { near[l] });
        leave = each(|l| if along[l] { leave[l] } else { far[l] });
    }
    each(|l| match empty[l] {
        true => (f64::INFINITY, f64::NEG_INFINITY),
        false => (enter[l], leave[l]),
    })
}

/// Where a ray that does not pass the box `box <= r` by first enters it from outside, or
/// leaves it from `inside` (none: it never does), from where it spans the grown box.
#[inline(always)]
fn finish(
    (u, w): ([f64; 4], [f64; 4]),
    (half, r): ([f64; 4], f64),
    inside: bool,
    (enter, leave): (f64, f64),
) -> Option<f64> {
    let span = (enter <= leave).then_some((enter, leave));
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

    proptest! {
        /// `value` is the VM's box distance (`math::kernel::box_dist`, which the scene's tapes
        /// evaluate) bit for bit, at points inside, outside and on the faces, for sharp,
        /// shrunk and rounded boxes: the lanes' copy of its operations keeps their order.
        #[test]
        fn value_is_the_kernels(
            u in prop::array::uniform4(prop_oneof![-4.0..4.0f64, Just(1.0), Just(-0.0)]),
            half in prop::array::uniform4(0.0..3.0f64),
            r in -0.5..1.5f64,
        ) {
            let mut v = [0.0; 9];
            v[4..8].copy_from_slice(&half);
            v[8] = r;
            let kernel = crate::math::kernel::box_dist(u, v);
            prop_assert_eq!(value(u, half, r).to_bits(), kernel.to_bits());
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
