//! Spherical emitters, for next-event estimation (light sampling).
//!
//! An object counts as a spherical light when its shape is a `hypersphere` under any chain of
//! `translate`, `rotate`, `scale` (positive factor) and `round` (parameters constant or
//! functions of the frame variable `t`), and its material is a plain `light(...)` whose colour
//! and intensity do not depend on the point or the normal (found in `ir::lower`, placed per frame by
//! `compile`). Every other emitter
//! (lights of other shapes, emissive `diffuse`, material maps) is found by BSDF sampling alone,
//! which stays unbiased: the integrator gives those hits MIS weight 1.
//!
//! # Sampling a 4D ball by solid angle
//! Seen from a point `x` at distance `d > R` from the centre, a ball of radius `R` fills the cone
//! of half-angle `a`, `sin a = R / d`. The cap of S^3 of half-angle `a` has area
//! `2 pi (a - sin a cos a)` (the S^2 of directions at angle `theta` from the axis has area
//! `4 pi sin^2 theta`), so a direction uniform in the cone has the constant pdf
//! `1 / (2 pi (a - sin a cos a))`. Theta has the density `sin^2 theta / (a - sin a cos a) / 2` on
//! `[0, a]`, inverted by safeguarded Newton; the other two angles are a uniform direction on the
//! S^2 orthogonal to the axis. Every direction of the cone meets the ball, and only those do, so
//! the pdf of a direction that hit the ball (found by BSDF sampling) is the same constant.

use super::sampling::{Frame, cube_root, safeguarded_newton, uniform_s2};
use glam::{DVec3, DVec4};
use std::f64::consts::PI;

/// A spherical emitter in one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereLight {
    /// Centre in world space.
    pub center: DVec4,
    /// Radius in world units, positive.
    pub radius: f64,
    /// Emitted radiance (the same everywhere on the surface and in every direction).
    pub radiance: DVec3,
    /// The object's index in the scene (as marching reports it).
    pub object: u32,
}

/// One light sample drawn from a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    /// Which light (an index into [`Lights::lights`]).
    pub light: usize,
    /// Unit world direction from the point towards the light.
    pub wo: DVec4,
    /// Solid-angle pdf of `wo`, the light selection probability included.
    pub pdf: f64,
    /// Distance from the point to the light's centre: a shadow ray that gets this far without
    /// meeting the light has missed it.
    pub distance: f64,
}

/// `theta - sin(theta) cos(theta)`, accurate for small `theta` too, where the difference
/// cancels (`~ 2 theta^3 / 3`): a series below 0.1 (relative error < 1e-15).
pub fn cap_integral(theta: f64) -> f64 {
    if theta < 0.1 {
        let t2 = theta * theta;
        // 2t^3/3 - 2t^5/15 + 4t^7/315 - 2t^9/2835 + 4t^11/155925
        let series = 2.0 / 3.0
            + t2 * (-2.0 / 15.0
                + t2 * (4.0 / 315.0 + t2 * (-2.0 / 2835.0 + t2 * (4.0 / 155925.0))));
        theta * t2 * series
    } else {
        theta - 0.5 * (2.0 * theta).sin()
    }
}

/// `cap_integral(theta) - y` and its derivative `2 sin^2 theta`, from one `sin_cos` (none
/// below 0.1, where the series serves and the slope needs only steer Newton: its truncation
/// there, 2e-10 relative at most, slows nothing).
fn cap_integral_and_slope(theta: f64, y: f64) -> (f64, f64) {
    cap_terms(theta, y).0
}

/// `cap_integral_and_slope`, and the sine and cosine of `theta` where it took them.
fn cap_terms(theta: f64, y: f64) -> ((f64, f64), Option<(f64, f64)>) {
    if theta < 0.1 {
        let t2 = theta * theta;
        let sin = theta * (1.0 - t2 / 6.0 * (1.0 - t2 / 20.0));
        ((cap_integral(theta) - y, 2.0 * sin * sin), None)
    } else {
        let (s, c) = theta.sin_cos();
        ((theta - s * c - y, 2.0 * s * s), Some((s, c)))
    }
}

/// Area of the cap of the unit 3-sphere with half-angle `a`: `2 pi (a - sin a cos a)`
/// (`2 pi^2`, the whole of S^3, at `a = pi`).
pub fn cap_area(a: f64) -> f64 {
    2.0 * PI * cap_integral(a)
}

/// The cone a ball fills, seen from outside it: its half-angle and `cap_integral` of it, from
/// the sine `r / d` and the cosine at hand (no sine of the angle to take again).
#[derive(Debug)]
struct Cone {
    a: f64,
    integral: f64,
}

impl Cone {
    /// The cone of a ball of radius `r` seen from distance `d`; `None` when the point is inside
    /// the ball or on its surface (`d <= r`), or the values are not usable.
    fn of(d: f64, r: f64) -> Option<Cone> {
        if !(d.is_finite() && r > 0.0 && d > r) {
            return None;
        }
        let sin = r / d;
        let a = sin.asin();
        let integral = if a < 0.1 {
            cap_integral(a)
        } else {
            a - sin * ((1.0 - sin) * (1.0 + sin)).sqrt()
        };
        (a > 0.0).then_some(Cone { a, integral })
    }

    /// The solid-angle pdf of a direction uniform in it: one over the cap's area.
    fn pdf(&self) -> f64 {
        1.0 / (2.0 * PI * self.integral)
    }
}

/// The half-angle of the cone a ball of radius `r` fills, seen from distance `d`; `None` when
/// the point is inside the ball or on its surface (`d <= r`), or the values are not usable.
pub fn cone_half_angle(d: f64, r: f64) -> Option<f64> {
    Cone::of(d, r).map(|c| c.a)
}

/// Solid-angle pdf of [`sample_ball`] from a point at distance `d` from the centre of a ball
/// of radius `r` (for any direction inside the cone); 0 where no sample can be drawn.
pub fn ball_pdf(d: f64, r: f64) -> f64 {
    Cone::of(d, r).map_or(0.0, |c| c.pdf())
}

/// The angle from the axis of a direction uniform in the cone of half-angle `a` (in `(0, pi]`),
/// from a uniform `u` in `[0, 1)`: solves `g(theta) = u g(a)`, `g = theta - sin cos`
/// (`solve_cone_theta`).
pub fn sample_cone_theta(a: f64, u: f64) -> f64 {
    solve_cone_theta(a, u, cap_integral_and_slope)
}

/// `sample_cone_theta` with `f_df(theta, y)` giving `g(theta) - y` and its derivative `2 sin^2
/// theta`. Newton from the small-angle series of `g` inverted to tenth order: with `t = (3 y /
/// 2)^(1/3)`, `theta = t (1 + t^2 / 15 + 2 t^4 / 175 + 4 t^6 / 1575 + 43 t^8 / 67375 + ...)`,
/// whose next term is `1.7e-4 t^10` of it; kept in a shrinking bisection bracket (a step that
/// leaves it, or meets the flat start of `g` near 0, becomes a bisection step). It stops after a
/// Newton step below `1e-8 a`: convergence is quadratic with the constant `g'' / 2 g' = cot
/// theta`, so the point that step reaches is within about `1e-16 a^2 / theta` of the root. A
/// cone of 0.3 rad took 4.2 evaluations on average with the first-order guess and a tolerance
/// of `1e-15 a`, and 2.0 with the second-order guess (a model of this solver, 2,000 `u`); below
/// about 0.2 rad the tenth-order guess is within the tolerance, and one evaluation confirms it.
pub fn solve_cone_theta(a: f64, u: f64, f_df: impl Fn(f64, f64) -> (f64, f64)) -> f64 {
    solve_cone_theta_at((a, cap_integral(a)), u, f_df)
}

/// `solve_cone_theta` in the cone of half-angle `a` whose `g(a)` is `integral`.
fn solve_cone_theta_at(
    (a, integral): (f64, f64),
    u: f64,
    f_df: impl Fn(f64, f64) -> (f64, f64),
) -> f64 {
    let y = u.clamp(0.0, 1.0) * integral;
    let t = cube_root(1.5 * y);
    let t2 = t * t;
    let series = 43.0 / 67375.0;
    let series = 1.0 + t2 * (1.0 / 15.0 + t2 * (2.0 / 175.0 + t2 * (4.0 / 1575.0 + t2 * series)));
    safeguarded_newton(
        |theta| f_df(theta, y),
        (t * series).clamp(0.0, a),
        (0.0, a),
        1e-8 * a,
    )
}

/// A direction uniform in the solid angle of the ball (`center`, `radius`) seen from `x`, and
/// its pdf and the distance to the centre; `None` when `x` is inside the ball.
pub fn sample_ball(x: DVec4, center: DVec4, radius: f64, u: DVec3) -> Option<(DVec4, f64, f64)> {
    let to = center - x;
    let d = to.length();
    let cone = Cone::of(d, radius)?;
    let axis = to / d;
    // Newton's last evaluation took the sine and cosine of a point within its last step of
    // the root: turned by that step (at most 1e-6 here, so the Taylor terms dropped are
    // below 1e-25), they are the root's, without another `sin_cos`.
    let last = std::cell::Cell::new((0.0, None));
    let theta = solve_cone_theta_at((cone.a, cone.integral), u.x, |t, y| {
        let (terms, sin_cos) = cap_terms(t, y);
        last.set((t, sin_cos));
        terms
    });
    let (sin_t, cos_t) = match last.get() {
        (t, Some((s, c))) if (theta - t).abs() <= 1e-6 => {
            let h = theta - t;
            let (sh, ch) = (h * (1.0 - h * h / 6.0), 1.0 - h * h / 2.0);
            (s * ch + c * sh, c * ch - s * sh)
        }
        _ => theta.sin_cos(),
    };
    let local = (sin_t * uniform_s2(u.y, u.z)).extend(cos_t);
    let wo = Frame::new(axis).to_world(local).normalize();
    Some((wo, cone.pdf(), d))
}

/// The spherical lights of one frame, chosen in proportion to their power
/// (`radiance * radius^3`, the mean of the three channels).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Lights {
    lights: Vec<SphereLight>,
    /// Selection probability of each light, and their running sum.
    probability: Vec<f64>,
    cumulative: Vec<f64>,
    /// For every object index, its light, if it is one.
    by_object: Vec<Option<u32>>,
    /// For every light and object (light-major), where the light's ball lies against the
    /// object's surface (`mark_sides`); empty until marked.
    sides: Vec<Side>,
    /// For every light, the objects it lies wholly inside: `sides` gathered once for light
    /// sampling, which asks for each sample.
    enclosing: Vec<Vec<u32>>,
}

/// Where a light's ball lies against a surface of an object that stops shadow rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// Wholly outside it: a shadow ray from inside the object meets its surface first.
    Outside,
    /// Wholly inside it: a shadow ray from outside the object meets its surface first.
    Inside,
    /// Across it, or not known (the light's own object, air, which stops no ray).
    Across,
}

impl Lights {
    /// The lights among `objects` objects; lights that emit nothing, or have no usable size,
    /// are left out (BSDF sampling still finds them).
    pub fn new(candidates: Vec<SphereLight>, objects: usize) -> Lights {
        let power = |l: &SphereLight| {
            let p = l.radiance.element_sum() / 3.0 * l.radius.powi(3);
            if p.is_finite() { p } else { 0.0 }
        };
        let lights: Vec<SphereLight> = candidates
            .into_iter()
            .filter(|l| {
                l.center.is_finite()
                    && l.radius.is_finite()
                    && l.radius > 0.0
                    && l.radiance.is_finite()
                    && power(l) > 0.0
                    && (l.object as usize) < objects
            })
            .collect();
        let total: f64 = lights.iter().map(power).sum();
        let probability: Vec<f64> = lights.iter().map(|l| power(l) / total).collect();
        let mut cumulative = Vec::with_capacity(lights.len());
        let mut acc = 0.0;
        for p in &probability {
            acc += p;
            cumulative.push(acc);
        }
        let mut by_object = vec![None; objects];
        for (i, l) in lights.iter().enumerate() {
            by_object[l.object as usize] = Some(i as u32);
        }
        Lights {
            lights,
            probability,
            cumulative,
            by_object,
            sides: vec![],
            enclosing: vec![],
        }
    }

    /// Mark, for every light and object, `side(light, object)`: where the light's ball lies
    /// against the object's surface.
    pub fn mark_sides(&mut self, side: impl Fn(&SphereLight, usize) -> Side) {
        let objects = self.by_object.len();
        self.sides = (self.lights.iter())
            .flat_map(|l| (0..objects).map(|o| side(l, o)).collect::<Vec<_>>())
            .collect();
        self.enclosing = (self.sides.chunks(objects.max(1)))
            .map(|row| (0..row.len() as u32).filter(|&o| row[o as usize] == Side::Inside))
            .map(|inside| inside.collect())
            .collect();
    }

    /// Where light `i` lies against object `object`'s surface (`Across` unmarked).
    pub fn side(&self, i: usize, object: u32) -> Side {
        let at = i * self.by_object.len() + object as usize;
        self.sides.get(at).copied().unwrap_or(Side::Across)
    }

    /// The objects light `i` lies wholly inside (none unmarked).
    pub fn enclosing(&self, i: usize) -> &[u32] {
        self.enclosing.get(i).map_or(&[], |v| v.as_slice())
    }

    /// Whether the frame has no spherical light (next-event estimation is then skipped).
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    /// The lights that exist this frame (zero-sized, non-finite and dark ones are dropped).
    pub fn lights(&self) -> &[SphereLight] {
        &self.lights
    }

    /// The probability with which [`Lights::sample`] picks light `i`.
    pub fn probability(&self, i: usize) -> f64 {
        self.probability[i]
    }

    /// The light that object `object` is, if any.
    pub fn of_object(&self, object: u32) -> Option<usize> {
        self.by_object
            .get(object as usize)
            .copied()
            .flatten()
            .map(|i| i as usize)
    }

    /// Pick a light with `select` and a direction towards it with `u` (uniforms in `[0, 1)`).
    /// `None` when there are no lights, or `x` is inside the one picked.
    pub fn sample(&self, x: DVec4, select: f64, u: DVec3) -> Option<LightSample> {
        if self.lights.is_empty() {
            return None;
        }
        let i = self
            .cumulative
            .partition_point(|&c| c <= select)
            .min(self.lights.len() - 1);
        let l = &self.lights[i];
        let (wo, pdf, distance) = sample_ball(x, l.center, l.radius, u)?;
        Some(LightSample {
            light: i,
            wo,
            pdf: pdf * self.probability[i],
            distance,
        })
    }

    /// The pdf with which [`Lights::sample`] draws a direction from `x` that meets light `i`
    /// (selection included); 0 where it cannot (`x` inside the light).
    pub fn pdf(&self, i: usize, x: DVec4) -> f64 {
        let l = &self.lights[i];
        ball_pdf((l.center - x).length(), l.radius) * self.probability[i]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Below 0.2 rad the series guess is the root to within the tolerance: one evaluation;
    /// at 0.3 rad, at most two.
    #[test]
    fn the_series_guess_needs_one_evaluation_in_small_cones() {
        for (a, most) in [
            (0.01, 1),
            (0.05, 1),
            (0.1, 1),
            (0.15, 1),
            (0.2, 1),
            (0.3, 2),
        ] {
            for k in 0..200 {
                let u = (k as f64 + 0.5) / 200.0;
                let calls = std::cell::Cell::new(0);
                let theta = solve_cone_theta(a, u, |t, y| {
                    calls.set(calls.get() + 1);
                    cap_integral_and_slope(t, y)
                });
                assert!(
                    calls.get() <= most,
                    "a {a} u {u}: {} evaluations",
                    calls.get()
                );
                let back = cap_integral(theta) / cap_integral(a);
                assert!((back - u).abs() < 1e-12, "a {a} u {u}: {back}");
            }
        }
    }

    /// A sampled direction makes the solved angle with the axis, its sine and cosine turned
    /// from Newton's last point or taken anew (cones below and above 0.1 rad, samples near
    /// the axis and the rim).
    #[test]
    fn ball_samples_make_the_solved_angle() {
        let center = DVec4::new(0.3, -0.2, 0.1, 0.4);
        for (d, r) in [(10.0, 0.2), (3.0, 0.5), (1.5, 1.0), (1.01, 1.0)] {
            let x = center - DVec4::new(0.0, 0.0, d, 0.0);
            let a = cone_half_angle(d, r).expect("outside");
            for k in 0..50 {
                let u = DVec3::new((k as f64 + 0.5) / 50.0, 0.37, 0.81);
                let (wo, _, _) = sample_ball(x, center, r, u).expect("outside");
                let cos = wo.dot((center - x) / d);
                let theta = sample_cone_theta(a, u.x);
                assert!((cos - theta.cos()).abs() < 1e-13, "{d} {r} {u}: {cos}");
                assert!((wo.length() - 1.0).abs() < 1e-14);
            }
        }
    }

    /// The cone's integral from the ball's sine and cosine is `cap_integral` of its angle.
    #[test]
    fn cone_integral_is_the_caps() {
        for (d, r) in [
            (1e6, 1.0),
            (10.0, 0.99),
            (2.0, 1.0),
            (1.0 + 1e-9, 1.0),
            (3.0, 2.9),
        ] {
            let c = Cone::of(d, r).expect("outside the ball");
            let want = cap_integral(c.a);
            assert!((c.integral - want).abs() <= 1e-13 * want, "{d} {r}: {c:?}");
        }
    }
}
