//! Rays against a hyperbox, sharp or rounded (`Form::Box`): where a ray enters the set
//! `box(u) <= r` or leaves it, in closed form. A sharp box (`r <= 0`: the box shrunk by `-r`)
//! is met by the slab method. A rounded one (`r > 0`) is the sharp box grown by `r` with its
//! edges rounded: its slab bounds where the ray can meet it, and inside that, piece by piece
//! of the ray, the squared distance to the sharp box is a quadratic (`within`). The set is
//! convex, so leaving it is entering it along the reversed ray from beyond its far side.

use super::dot;
use crate::math::lanes::{self, F4, Lane, M4, each};

/// Four points or directions, coordinate by coordinate (`x[i][lane]`): what `meet_lanes`
/// takes, so that every step is a loop over the lanes, which the compiler puts in the lanes of
/// a vector.
pub type Four = [[f64; 4]; 4];

/// The signed distance to `box(u) <= r`.
#[inline(always)]
pub fn value(u: [f64; 4], half: [f64; 4], r: f64) -> f64 {
    // Four copies of `u`: the lanes' code is the only one.
    values(&u.map(F4::splat), half, r).0.at(0)
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
    let u: [F4; 4] = u.map(|x| F4::each(|l| x.at(l % L::N)));
    let signs = values(&u, half, r).1;
    L::each(|l| signs.at(l))
}

/// `value` and `sign` at four points: `math::kernel::box_dist`'s operations in its order for
/// the value (`Real::max` and `min`, which keep `x` where a comparison with NaN fails).
#[inline(always)]
fn values(u: &[F4; 4], half: [f64; 4], r: f64) -> (F4, F4) {
    let zero = F4::splat(0.0);
    let (max, min) = (lanes::greater, lanes::lesser);
    let q: [F4; 4] = each(|i| u[i].abs() - F4::splat(half[i]));
    let o = q.map(|q| max(q, zero));
    let length = lanes::dot(o, o);
    let most = min(max(max(q[0], q[1]), max(q[2], q[3])), zero);
    let value = length.sqrt() + most - F4::splat(r);
    // The sign's own parts, with `f64::max`, which takes the other number where one is NaN
    // (as `sign` always has); both sides' tests, without branches.
    let p = q.map(|q| q.max(zero));
    let far = lanes::dot(p, p);
    let top = q[0].max(q[1]).max(q[2].max(q[3]));
    let out = top.gt(zero);
    let rr = F4::splat(r);
    let outside = (out & (rr.le(zero) | far.ge(rr * rr))) | (!out & (top - rr).ge(zero));
    (value, F4::select(outside, F4::splat(1.0), F4::splat(-1.0)))
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
    let (u, w): ([F4; 4], [F4; 4]) = (each(|i| F4(u[i])), each(|i| F4(w[i])));
    let zero = F4::splat(0.0);
    let (v, side) = values(&u, half, r);
    // The side from the sign alone, which needs no square root: the meeting then need not
    // wait for one (`v` is only the value's).
    let (s, k) = super::side(F4::splat(sign) * side, shell);
    let sign = s * F4::splat(sign);
    let (value, grown) = (sign * v - F4::splat(k), F4::splat(r) + sign * F4::splat(k));
    let inside = sign.lt(zero);
    // The sharp box each ray meets, grown by its `r'`: half-extents lane by lane.
    let g: [F4; 4] = each(|i| F4::splat(half[i]) + grown);
    // Rays that start inside (in a hollow shell's room, all of them) cannot pass it by.
    let pass = match F4::all(inside) {
        true => !inside,
        false => passes((&u, &w), (half, &g), (grown, inside)),
    };
    // A ray meets the surface where it starts unless the value there is positive (a NaN
    // value too: where it starts is not known to be outside).
    let ahead = value.gt(zero);
    let mut first = F4::select(ahead, F4::splat(f64::NAN), zero).0;
    // Rays that start in the set or pass it by, as most do, need not span it.
    let spans = !ahead | pass;
    if (0..live).all(|l| spans.at(l)) {
        return (value.0, first);
    }
    let (enter, leave) = slabs((&u, &w), &g);
    // A sharp box is met where the ray spans it: where it enters from outside, where it
    // leaves from inside, or where it starts for a point inside that the slabs round out of
    // (on the surface).
    let sharp = grown.le(zero);
    let nan = F4::splat(f64::NAN);
    let across = enter.le(leave);
    let out = F4::select(across & leave.ge(zero), enter.max(zero), nan);
    let met = F4::select(inside, F4::select(across, leave.max(zero), zero), out);
    first = F4::select(spans | !sharp, F4(first), met).0;
    for l in (0..live).filter(|&l| !spans.at(l) & !sharp.at(l)) {
        let ray = (lanes::lane(u, l), lanes::lane(w, l));
        let span = (enter.at(l), leave.at(l));
        first[l] = finish(ray, (half, grown.at(l)), inside.at(l), span).unwrap_or(f64::NAN);
    }
    (value.0, first)
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
    (u, w): (&[F4; 4], &[F4; 4]),
    (half, g): ([f64; 4], &[F4; 4]),
    (r, inside): (F4, M4),
) -> M4 {
    let corner = F4::splat(dot(half, half).sqrt());
    let reach = corner + r;
    let rr = F4::select(r.gt(F4::splat(0.0)), reach * reach, lanes::dot(*g, *g));
    let (b, ww, uu) = (lanes::dot(*u, *w), lanes::dot(*w, *w), lanes::dot(*u, *u));
    let s = b / ww;
    let off: [F4; 4] = each(|i| u[i] - s * w[i]);
    let oo = lanes::dot(off, off);
    let wide = oo.gt(rr * F4::splat(1.0 + 1e-12));
    !inside & uu.gt(rr) & (b.gt(F4::splat(0.0)) | wide)
}

/// Where each line `u + t w` is inside the sharp box of half-extents `g`: `(enter,
/// leave)`, empty (`enter > leave`, as `(inf, -inf)`) where it is nowhere. One division per
/// coordinate: the two planes' roots are within 1.5 ulp of dividing each. A direction too
/// small to invert (zero, or subnormal) runs along the planes.
#[inline(always)]
fn slabs((u, w): (&[F4; 4], &[F4; 4]), g: &[F4; 4]) -> (F4, F4) {
    let inf = F4::splat(f64::INFINITY);
    let inv: [F4; 4] = each(|i| F4::splat(1.0) / w[i]);
    let along: [M4; 4] = each(|i| !inv[i].is_finite());
    let gap: [M4; 4] = each(|i| g[i].lt(F4::splat(0.0)) | (along[i] & u[i].abs().gt(g[i])));
    let empty = gap[0] | gap[1] | gap[2] | gap[3];
    // `lesser` and `greater`, not `f64::min` and `max`, whose care for NaN takes three
    // instructions a lane where one does. A ray's roots are NaN only where it runs along the
    // planes, and those lanes keep what they had; elsewhere only non-finite points or
    // half-extents, which no ray's meeting has, give NaN, and then another span than
    // `f64::min` and `max` would.
    let (min, max) = (lanes::lesser, lanes::greater);
    let (mut enter, mut leave) = (-inf, inf);
    for (i, &along) in along.iter().enumerate() {
        let a = (-g[i] - u[i]) * inv[i];
        let b = (g[i] - u[i]) * inv[i];
        let near = max(enter, min(a, b));
        let far = min(leave, max(a, b));
        enter = F4::select(along, enter, near);
        leave = F4::select(along, leave, far);
    }
    (
        F4::select(empty, inf, enter),
        F4::select(empty, -inf, leave),
    )
}

/// Where a ray that does not pass the rounded box `box <= r` (`r > 0`) by first enters it
/// from outside, or leaves it from `inside` (none: it never does), from where it spans the
/// grown box. (A sharp box's meeting is the span's own, in the lanes: `meet_lanes`.)
#[inline(always)]
fn finish(
    (u, w): ([f64; 4], [f64; 4]),
    (half, r): ([f64; 4], f64),
    inside: bool,
    (enter, leave): (f64, f64),
) -> Option<f64> {
    let span = (enter <= leave).then_some((enter, leave));
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
/// Each piece ends at the nearest crossing past its start: rays met in the room's rounded
/// box visited 1.1 pieces on average, and sorting all eight crossings first cost more than
/// the pieces did.
#[inline(always)]
fn within(u: [f64; 4], w: [f64; 4], (half, r): ([f64; 4], f64), limit: f64) -> Option<f64> {
    let (u, w, half, zero) = (F4(u), F4(w), F4(half), F4::splat(0.0));
    let inv = F4::splat(1.0) / w;
    // Where each coordinate crosses its two planes. (One that runs along them crosses them
    // nowhere: NaN or infinite.)
    let crossings = [(-half - u) * inv, (half - u) * inv];
    let sum = |x: F4, start: f64| (0..4).fold(start, |s, l| s + x.at(l));
    let mut from = 0.0;
    loop {
        let (start, end) = (F4::splat(from), F4::splat(limit));
        let [near, far] = crossings.map(|t| F4::select(t.gt(start) & t.lt(end), t, end));
        let next = near.min(far);
        let to = (next.at(0).min(next.at(1))).min(next.at(2).min(next.at(3)));
        // The piece's quadratic in `s = t - from`, from the point where it starts (small
        // coefficients, whatever the ray's origin): `a s^2 + b s + c`.
        let m = u + F4::splat(0.5 * (from + to)) * w;
        let (out, sign) = (m.abs().gt(half), F4::splat(1.0).copysign(m));
        let e = F4::select(out, sign * (u + start * w) - half, zero);
        let k = F4::select(out, sign * w, zero);
        let (a, b, c) = (
            sum(k * k, 0.0),
            sum(F4::splat(2.0) * e * k, 0.0),
            sum(e * e, -r * r),
        );
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
        // (Each piece ends further on than the last, so this ends; at a NaN limit, at once.)
        if to >= limit || limit.is_nan() {
            return None;
        }
        from = to;
    }
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
