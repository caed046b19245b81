//! Sampling building blocks for light transport in four dimensions.
//!
//! Every formula here is the 4D one of `docs/physics.md` ("Surfaces", "Media", "Light
//! sampling"); the 3D habits that are wrong in 4D are called out where they would creep in.
//! Samplers take their random numbers as a `DVec3` of independent uniforms in `[0, 1)` so that
//! they stay deterministic functions, easy to test and to feed with quasi-random points.
//!
//! Local frames put the surface normal (or a lobe's axis) on the **fourth axis, e4 = `w`**: a
//! direction `(x, y, z, w)` in a local frame has `cos(theta) = w`, and `(x, y, z)` is its
//! tangential part.

use crate::math::lanes::{Lane, dot, scale};
use glam::{DVec3, DVec4};
use std::f64::consts::PI;

/// Volume of the unit 3-ball, `4 pi / 3`: the projected solid angle of the hemisphere of S^3,
/// i.e. the integral of `cos(theta) d(omega)` over it (pi is the 3D value).
pub const BALL3_VOLUME: f64 = 4.0 * PI / 3.0;

/// Area of the unit 3-sphere S^3, `2 pi^2`.
pub const SPHERE3_AREA: f64 = 2.0 * PI * PI;

/// A direction uniform on the unit 2-sphere S^2 (`z = 1 - 2 u1`, azimuth `2 pi u2`, by
/// Archimedes' hat-box theorem); in each lane.
#[inline(always)]
pub fn uniform_s2<L: Lane>(u1: L, u2: L) -> [L; 3] {
    let one = L::splat(1.0);
    let z = one - L::splat(2.0) * u1;
    let r = (one - z * z).max(L::splat(0.0)).sqrt();
    let (s, c) = sin_cos_turns(u2);
    [r * c, r * s, z]
}

/// `(2 pi u).sin_cos()`, the angle given in turns (`|u|` below 2^48), to within 3e-16 of it:
/// the nearest quarter turn taken off exactly (`x - round(x)` is exact), then Taylor
/// polynomials within an eighth of a turn (the first terms left out are below 5e-17), and the
/// quarter put back by swapping and negating without a branch (the quarter is random in a
/// sample). The library's `sin_cos`, which reduces any angle, was a sixteenth of the room's
/// render. In each lane.
#[inline(always)]
pub fn sin_cos_turns<L: Lane>(u: L) -> (L, L) {
    debug_assert!(
        (0..L::N).all(|l| u.at(l).abs() < 2f64.powi(48)),
        "turns out of range"
    );
    // Rounded to the nearest integer by adding 1.5 * 2^52, whose unit in the last place is 1
    // (`round` is a library call without SSE4.1); the integer's low bits are the sum's.
    const ROUND: f64 = 1.5 * (1u64 << 52) as f64;
    let quarters = L::splat(4.0) * u;
    let sum = quarters + L::splat(ROUND);
    let nearest = sum - L::splat(ROUND);
    let x = (quarters - nearest) * L::splat(PI / 2.0);
    let x2 = x * x;
    let sin = x * poly(x2, &SIN_TAYLOR);
    let cos = poly(x2, &COS_TAYLOR);
    let turned = |l: usize, which: u64| turn(sum.at(l).to_bits(), sin.at(l), cos.at(l), which);
    (L::each(|l| turned(l, 0)), L::each(|l| turned(l, 1)))
}

/// `(sin, cos)` of an angle turned by `q` quarters (the low bits of `q`), without a branch:
/// the sine for `which` 0, the cosine for 1.
#[inline(always)]
fn turn(q: u64, sin: f64, cos: f64, which: u64) -> f64 {
    let swap = 0u64.wrapping_sub(q & 1);
    let (sb, cb) = (sin.to_bits(), cos.to_bits());
    let bits = [sb ^ ((sb ^ cb) & swap), cb ^ ((sb ^ cb) & swap)][which as usize];
    f64::from_bits(bits ^ ((q.wrapping_add(which) & 2) << 62))
}

/// `1 - x^2/3! + x^4/5! - ...` and `1 - x^2/2! + x^4/4! - ...` up to `x^14` and `x^16`.
const SIN_TAYLOR: [f64; 8] = taylor(1);
const COS_TAYLOR: [f64; 9] = taylor(0);

/// The coefficients `(-1)^k / (2k + odd)!` of a Taylor series in `x^2`.
const fn taylor<const N: usize>(odd: u32) -> [f64; N] {
    let mut c = [0.0; N];
    let (mut k, mut term) = (0, 1.0);
    while k < N {
        c[k] = term;
        let n = (2 * k as u32 + odd + 1) as f64;
        term = -term / (n * (n + 1.0));
        k += 1;
    }
    c
}

/// A polynomial in `y` by Horner's rule.
#[inline(always)]
fn poly<L: Lane>(y: L, coefficients: &[f64]) -> L {
    (coefficients.iter().rev()).fold(L::splat(0.0), |acc, &c| acc * y + L::splat(c))
}

/// The cube root of `x >= 0` to about 1e-12 relative, for `u^(2/3)` in light samples and the
/// radius of a point in the 3-ball (`f64::cbrt` was a twentieth of the room's render): the
/// exponent divided by three in the bits (Kahan's constant, within 3.2%), then two steps of
/// Halley's iteration, `y (r + 2) / (2 r + 1)` with `r = y^3 / x` (cubic: 1e-14 after two;
/// three Newton steps took six divisions in a row). `r` is taken as `(y / x) y^2` through
/// `1 / x`, whose factors neither overflow nor underflow anywhere in the normal range
/// (subnormal `x` is scaled into it). In each lane; outside the domain (not above 0, or not
/// finite), `max(x, 0)`.
#[inline(always)]
pub fn cube_root<L: Lane>(x: L) -> L {
    let (zero, one) = (L::splat(0.0), L::splat(1.0));
    let domain = x.gt(zero) & x.is_finite();
    // Subnormal, where `1 / x` overflows: scaled by 2^54 exactly, and the root by 2^18. Lanes
    // outside the domain take the root of 1, and throw it away.
    let subnormal = x.lt(L::splat(f64::MIN_POSITIVE));
    let scaled = L::select(subnormal, x * L::splat(2f64.powi(54)), x);
    let s = L::select(domain, scaled, one);
    let inv = one / s;
    let mut y = L::each(|l| f64::from_bits(s.at(l).to_bits() / 3 + 0x2a9f_7893_782d_a1ce));
    for _ in 0..2 {
        let r = (y * inv) * (y * y);
        y = y * ((r + L::splat(2.0)) / (L::splat(2.0) * r + one));
    }
    let y = L::select(subnormal, y / L::splat(2f64.powi(18)), y);
    L::select(domain, y, x.max(zero))
}

/// A point uniform in the unit 3-ball: radius `u.x^(1/3)` (the volume below radius r grows as
/// r^3; drawing the radius as `u.x` would crowd the centre), direction uniform on S^2. In each
/// lane.
#[inline(always)]
pub fn uniform_ball3<L: Lane>([u0, u1, u2]: [L; 3]) -> [L; 3] {
    scale(uniform_s2(u1, u2), cube_root(u0))
}

/// A direction uniform on S^3, pdf `1 / (2 pi^2)` ([`SPHERE3_AREA`]).
///
/// Exact and cheaper than normalising four Gaussians: viewing S^3 as the unit sphere of C^2,
/// `(|z1|^2, arg z1, arg z2)` are independent and uniform on `[0,1] x [0,2pi) x [0,2pi)` under
/// the uniform measure.
pub fn uniform_s3(u: DVec3) -> DVec4 {
    let r1 = u.x.sqrt();
    let r2 = (1.0 - u.x).max(0.0).sqrt();
    let (s1, c1) = sin_cos_turns(u.y);
    let (s2, c2) = sin_cos_turns(u.z);
    DVec4::new(r1 * c1, r1 * s1, r2 * c2, r2 * s2)
}

/// Cosine-weighted direction on the hemisphere `w > 0` of a local frame (normal = e4), by
/// Malley's lift: a point uniform in the unit 3-ball lifted to `w = sqrt(1 - |p|^2)`. The
/// projection of `cos(theta) d(omega)` onto the equatorial 3-ball is its volume element, so the
/// pdf is [`cosine_hemisphere_pdf`]. In each lane.
#[inline(always)]
pub fn cosine_hemisphere<L: Lane>(u: [L; 3]) -> [L; 4] {
    let [x, y, z] = uniform_ball3(u);
    let w = (L::splat(1.0) - (x * x + y * y + z * z))
        .max(L::splat(0.0))
        .sqrt();
    [x, y, z, w]
}

/// Pdf (per unit solid angle on S^3) of [`cosine_hemisphere`]: `3 cos(theta) / (4 pi)`,
/// zero below the horizon.
pub fn cosine_hemisphere_pdf(cos_theta: f64) -> f64 {
    cos_theta.max(0.0) / BALL3_VOLUME
}

/// Mirror reflection of a *travelling* direction `d` about the plane with unit normal `n`:
/// `d - 2 (d.n) n`. For directions that point away from the surface (as the BSDFs use), the
/// mirrored direction of `wi` is `-reflect(wi, n)`.
pub fn reflect(d: DVec4, n: DVec4) -> DVec4 {
    d - 2.0 * d.dot(n) * n
}

/// Refraction of a *travelling* direction `d` (unit, `n.d < 0`) through an interface with unit
/// normal `n` facing the incoming side, `eta = eta_i / eta_t`. Valid in any dimension.
/// `None` on total internal reflection.
pub fn refract(d: DVec4, n: DVec4, eta: f64) -> Option<DVec4> {
    let c = -d.dot(n);
    let k = 1.0 - eta * eta * (1.0 - c * c);
    if k < 0.0 {
        return None;
    }
    Some(eta * d + (eta * c - k.sqrt()) * n)
}

/// Exact unpolarised Fresnel reflectance of a dielectric interface, `(R_s + R_p) / 2`, for light
/// arriving at `cos_i = |cos(theta_i)|` from the side of index `eta_i` towards `eta_t`.
/// Returns 1 under total internal reflection. (Schlick's approximation is off by 0.04-0.06 at
/// eta 1.5, and wrong above the critical angle unless it uses `cos(theta_t)`.)
pub fn fresnel_dielectric(cos_i: f64, eta_i: f64, eta_t: f64) -> f64 {
    if eta_i == eta_t {
        return 0.0;
    }
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin_t2 = (eta_i / eta_t).powi(2) * (1.0 - cos_i * cos_i);
    if sin_t2 >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin_t2).sqrt();
    let r_s = (eta_i * cos_i - eta_t * cos_t) / (eta_i * cos_i + eta_t * cos_t);
    let r_p = (eta_t * cos_i - eta_i * cos_t) / (eta_t * cos_i + eta_i * cos_t);
    0.5 * (r_s * r_s + r_p * r_p)
}

/// An orthonormal frame whose local e4 axis is the unit vector `n` (the normal, or a lobe axis).
///
/// The map is the Householder reflection that swaps e4 and `n`, signed so that its vector `v`
/// never vanishes: if `n.w > 0` use `v = n + e4` and `x -> -H x`, else `v = n - e4` and `x -> H x`,
/// with `H = I - 2 v v^T / (v^T v)`. Then `|v|^2 >= 2`, so there is no cancellation when `n` is
/// near e4 (the black-wall artefact of the one-branch version). The map is symmetric and its own
/// inverse, so [`Frame::to_local`] and [`Frame::to_world`] are the same operation. It is improper
/// (determinant -1), which is harmless for lobes that are isotropic about the normal: every lobe
/// in this renderer is.
/// A `Frame<F4>` is four frames, one per lane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame<L = f64> {
    v: [L; 4],
    /// `2 / (v.v)`.
    scale: L,
    /// -1 for `-H`, +1 for `H`.
    sign: L,
}

impl<L: Lane> Frame<L> {
    /// The frame with local e4 mapped to the unit vector `n`, in each lane.
    #[inline(always)]
    pub fn of(n: [L; 4]) -> Frame<L> {
        let up = n[3].gt(L::splat(0.0));
        // `n + e4` or `n - e4`, coordinate by coordinate as glam adds them (`-0 + 0` is `+0`).
        let e4 = |i: usize| L::splat(if i == 3 { 1.0 } else { 0.0 });
        let v = std::array::from_fn(|i| L::select(up, n[i] + e4(i), n[i] - e4(i)));
        Frame {
            v,
            scale: L::splat(2.0) / dot(v, v),
            sign: L::select(up, L::splat(-1.0), L::splat(1.0)),
        }
    }

    /// Local coordinates (normal = e4) to world coordinates, in each lane.
    #[inline(always)]
    pub fn world(&self, local: [L; 4]) -> [L; 4] {
        let a = self.scale * dot(self.v, local);
        std::array::from_fn(|i| self.sign * (local[i] - a * self.v[i]))
    }
}

impl Frame {
    /// The frame with local e4 mapped to the unit vector `n`.
    pub fn new(n: DVec4) -> Frame {
        Frame::of(n.to_array())
    }

    /// Local coordinates (normal = e4) to world coordinates.
    pub fn to_world(&self, local: DVec4) -> DVec4 {
        DVec4::from_array(self.world(local.to_array()))
    }

    /// World coordinates to local coordinates (normal = e4); the map is an involution.
    pub fn to_local(&self, world: DVec4) -> DVec4 {
        self.to_world(world)
    }
}

/// Solves `f(x) = 0` for an increasing `f` on `[lo, hi]` by Newton's method from `x`, kept in a
/// shrinking bisection bracket: a step that leaves the bracket (or meets a flat stretch where
/// the derivative vanishes) is replaced by bisection. `f_df` gives `f` and its derivative at
/// once (they share their trigonometry). Stops when a step or the bracket is below `tol`.
pub fn safeguarded_newton(
    f_df: impl Fn(f64) -> (f64, f64),
    mut x: f64,
    (mut lo, mut hi): (f64, f64),
    tol: f64,
) -> f64 {
    for _ in 0..100 {
        let (fx, dfx) = f_df(x);
        if fx > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        let newton = x - fx / dfx;
        // Converged: a Newton step this short would otherwise fail the strict bracket test
        // below (a zero step lands on `lo`) and start bisecting away from the root.
        if (newton - x).abs() <= tol {
            return newton.clamp(lo, hi);
        }
        let next = if newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
        let step = (next - x).abs();
        x = next;
        if step <= tol || hi - lo <= tol {
            break;
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `sin_cos_turns` is `(2 pi u).sin_cos()` to within 3e-16 on the turn a sampler draws
    /// from and beyond it, in every quarter and at their ends.
    #[test]
    fn sin_cos_of_turns_is_the_librarys() {
        let mut rng = rand_pcg::Pcg32::new(7, 11);
        let random = (0..200_000).map(|_| rand::Rng::random::<f64>(&mut rng));
        let ends = (0..=16).map(|k| k as f64 / 16.0);
        let beyond = [
            -0.75,
            -0.3,
            1.0 - f64::EPSILON / 2.0,
            1.3,
            2.875,
            1e-300,
            -0.0,
            1e5 + 0.1,
        ];
        for u in random.chain(ends).chain(beyond) {
            let (s, c) = sin_cos_turns(u);
            let (ws, wc) = (2.0 * PI * u).sin_cos();
            // The library's is of `2 pi u` rounded: its argument is off by up to 1.1e-16
            // times itself.
            let tol = 3e-16 + 1.2e-16 * (2.0 * PI * u).abs();
            assert!((s - ws).abs() <= tol, "sin at {u}: {s} against {ws}");
            assert!((c - wc).abs() <= tol, "cos at {u}: {c} against {wc}");
        }
    }

    /// `cube_root` is the cube root to within 2e-12, from the subnormal numbers to the largest,
    /// 0 at 0, and `max(x, 0)` outside its domain.
    #[test]
    fn cube_root_is_close() {
        assert_eq!(cube_root(0.0), 0.0);
        assert_eq!(cube_root(-1.0), 0.0);
        assert_eq!(cube_root(f64::NAN), 0.0);
        assert_eq!(cube_root(f64::INFINITY), f64::INFINITY);
        // Subnormals too, from the fourth (times 1.37 rounds up there; at the first it stays).
        let mut x = f64::from_bits(4);
        while x < f64::MAX / 1.37 {
            let (got, want) = (cube_root(x), x.cbrt());
            assert!(
                (got - want).abs() <= 2e-12 * want,
                "{x}: {got} against {want}"
            );
            x *= 1.37;
        }
    }

    /// Four lanes at once (`F4`) are each lane alone (`f64`), bit for bit, in every sampler
    /// written for both, on ordinary numbers and on those the selects stand in for: zeros of
    /// both signs, subnormals, negatives, infinities and NaN, normals along e4 and on its
    /// equator, points inside and on a light's ball.
    #[test]
    fn lanes_are_each_alone() {
        use crate::math::lanes::{F4, gather, lane};
        use crate::render::lights::sample_balls;
        use rand::{Rng, SeedableRng};
        let special = [
            0.0,
            -0.0,
            5e-324,
            1e-310,
            -1.0,
            f64::INFINITY,
            f64::NAN,
            1e300,
            0.5,
        ];
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(4);
        let number = |rng: &mut rand_pcg::Pcg64Mcg| match rng.random_range(0..4) {
            0 => special[rng.random_range(0..special.len())],
            _ => rng.random_range(-1.5..1.5),
        };
        // Bit for bit, but any NaN is any other: Rust leaves a NaN result's sign and payload
        // open, and the vector and scalar code (AVX's operand order) choose differently.
        let same = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .all(|(x, y)| x.to_bits() == y.to_bits() || x.is_nan() && y.is_nan())
        };
        for _ in 0..20_000 {
            let x: [[f64; 4]; 4] =
                std::array::from_fn(|_| std::array::from_fn(|_| number(&mut rng)));
            let four = gather(x);
            let one = |l: usize| x[l];
            let r = F4(std::array::from_fn(|l| x[l][0].abs()));
            let (drawn, wo, pdf, distance) =
                sample_balls(four, gather([one(1); 4]), r, [four[0], four[1], four[2]]);
            let frame = Frame::of(four);
            let world = frame.world(gather(x.map(|v| [v[3], v[2], v[1], v[0]])));
            let (sin, cos) = sin_cos_turns(four[1]);
            let hemisphere = cosine_hemisphere([four[0], four[1], four[2]]);
            for l in 0..4 {
                let v = x[l];
                assert!(
                    same(&[cube_root(four[0]).0[l]], &[cube_root(v[0])]),
                    "{v:?}"
                );
                let (s1, c1) = sin_cos_turns(v[1]);
                assert!(same(&[sin.0[l], cos.0[l]], &[s1, c1]), "{v:?}");
                assert!(same(
                    &lane(hemisphere, l),
                    &cosine_hemisphere([v[0], v[1], v[2]])
                ));
                let f = Frame::of(v);
                assert!(
                    same(&lane(world, l), &f.world([v[3], v[2], v[1], v[0]])),
                    "{v:?}"
                );
                let alone = sample_balls(v, x[1], v[0].abs(), [v[0], v[1], v[2]]);
                assert_eq!(drawn.at(l), alone.0, "{v:?}");
                let got = [lane(wo, l).as_slice(), &[pdf.0[l], distance.0[l]]].concat();
                let want = [alone.1.as_slice(), &[alone.2, alone.3]].concat();
                assert!(!alone.0 || same(&got, &want), "{v:?}");
            }
        }
    }
}
