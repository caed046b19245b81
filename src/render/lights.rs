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
//! of half-angle `a`, `sin a = R / d`; every direction of the cone meets the ball, and only
//! those do. The S^2 of directions at angle `theta` from the axis has area `4 pi sin^2 theta`,
//! so with `v = 1 - cos theta` (`dv = sin theta dtheta`) a solid angle is `4 pi sin theta dv`
//! and `sin theta = sqrt(v (2 - v))`. A direction uniform in the cone would need `v`'s
//! density `~ sqrt(v (2 - v))` inverted, a transcendental equation (`theta - sin theta cos
//! theta = y`) solved by Newton with two `sin_cos` and an `asin` per sample. Instead `v` is
//! drawn with the density `~ sqrt(v)` on `[0, 1 - cos a]`, whose inverse is closed:
//! `v = (1 - cos a) u^(2/3)`, and the other two angles are a uniform direction on the S^2
//! orthogonal to the axis. Its solid-angle pdf is `3 / (8 pi (1 - cos a)^(3/2) sqrt(1 + cos
//! theta))`: within a factor `sqrt(2 / (1 + cos a))` of uniform over the cone (1.005 for a
//! cone of 0.2 rad, 1.41 at most, for a point on the ball's surface), and `cos a` comes from
//! `sin a` by a square root, without the angle itself. The price is a little variance: the
//! pdf grows towards the rim, where a surface facing the lamp sees it at a slant, so the
//! direct light of a lamp straight above a floor has 1.4 to 1.6 times the variance per sample
//! that uniform directions give (a small share of a real scene's noise: the room's error at
//! equal samples is unchanged, and its frames render about 11% faster).

use super::sampling::{Frame, cube_root, uniform_s2};
use crate::math::lanes::{Lane, dot, scale};
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

impl SphereLight {
    /// Where the ray from `o` along the unit direction `d` enters the ball: 0 from inside it,
    /// `None` if it misses.
    pub fn enter(&self, o: DVec4, d: DVec4) -> Option<f64> {
        let to = self.center - o;
        let (b, c) = (to.dot(d), to.length_squared() - self.radius * self.radius);
        if c <= 0.0 {
            return Some(0.0);
        }
        let disc = b * b - c;
        (b > 0.0 && disc >= 0.0).then(|| c / (b + disc.sqrt()))
    }
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

/// The cone a ball fills, seen from a point outside it: its axis, the distance to the centre
/// and `1 - cos a`.
/// In each lane, for `Cone<F4>`.
struct Cone<L> {
    axis: [L; 4],
    distance: L,
    /// `1 - cos a`, from `sin^2 a = r^2 / d^2` as `sin^2 a / (1 + cos a)` (no cancellation in a
    /// tiny cone).
    depth: L,
}

impl<L: Lane> Cone<L> {
    /// The cone of the ball (`center`, `r`) seen from `x`, where the mask holds; not where `x`
    /// is inside the ball or on its surface, the values are not usable, or the cone is so
    /// narrow that `depth^3` underflows to 0 (below about 1e-54 rad), which keeps the pdf below
    /// about 1e162: no light sample is drawn there, and BSDF samples that meet the light take all the weight
    /// (`ball_pdf` is 0), as from inside it. The square roots of `d^2` and of `cos^2 a` do not
    /// wait for each other. (`r^2` loses precision for radii below about 1e-154, scenes far
    /// below any marching epsilon.)
    #[inline(always)]
    fn of(x: [L; 4], center: [L; 4], r: L) -> (L::Mask, Cone<L>) {
        let one = L::splat(1.0);
        let to: [L; 4] = std::array::from_fn(|i| center[i] - x[i]);
        let dd = dot(to, to);
        let outside = dd.is_finite() & r.gt(L::splat(0.0)) & dd.gt(r * r);
        let sin2 = r * r / dd;
        let depth = sin2 / (one + (one - sin2).sqrt());
        let d = dd.sqrt();
        let cone = Cone {
            axis: scale(to, one / d),
            distance: d,
            depth,
        };
        (outside & (depth * depth * depth).gt(L::splat(0.0)), cone)
    }

    /// The solid-angle pdf of a direction at `cos theta` from the axis (`1 + cos theta` given):
    /// `3 / (8 pi depth^(3/2) sqrt(1 + cos theta))` with one square root and one division. A
    /// direction that meets the ball is in the cone, `1 + cos theta >= 2 - depth`; one that
    /// rounds past its rim (or a BSDF sample's from a point within a rounding of the ball)
    /// takes the rim's pdf, not one that grows without bound towards the opposite direction.
    #[inline(always)]
    fn pdf(&self, one_plus_cos: L) -> L {
        let one_plus_cos = one_plus_cos.max(L::splat(2.0) - self.depth);
        L::splat(3.0 / (8.0 * PI)) / (self.depth * (self.depth * one_plus_cos).sqrt())
    }
}

/// A direction towards the ball (`center`, `radius`) seen from `x`, drawn with `u` as the module
/// says, its solid-angle pdf and the distance to the centre; `None` when `x` is inside the ball
/// (or the ball too small to sample, `Cone::of`).
pub fn sample_ball(x: DVec4, center: DVec4, radius: f64, u: DVec3) -> Option<(DVec4, f64, f64)> {
    let (center, x) = (center.to_array(), x.to_array());
    let (drawn, wo, pdf, distance) = sample_balls(x, center, radius, u.to_array());
    drawn.then(|| (DVec4::from_array(wo), pdf, distance))
}

/// One lane of what [`sample_balls`] gives: whether it drew, the direction, its pdf and the
/// distance to the centre.
pub type Drawn = (bool, [f64; 4], f64, f64);

/// [`sample_ball`] in each lane: where the mask holds, the direction, its pdf and the distance
/// to the centre; elsewhere numbers that mean nothing.
#[inline(always)]
pub fn sample_balls<L: Lane>(
    x: [L; 4],
    center: [L; 4],
    radius: L,
    [u0, u1, u2]: [L; 3],
) -> (L::Mask, [L; 4], L, L) {
    let (drawn, cone) = Cone::of(x, center, radius);
    let (one, two) = (L::splat(1.0), L::splat(2.0));
    // `u^(2/3)` below 1 for `u < 1`, though the cube root may round past it.
    let v = cone.depth * cube_root(u0 * u0).min(one);
    let (cos_t, sin_t) = (one - v, (v * (two - v)).sqrt());
    // A unit vector to within its rounding, and the frame is orthogonal: it needs no
    // normalising (a square root and a division after all the rest).
    let [a, b, c] = scale(uniform_s2(u1, u2), sin_t);
    let wo = Frame::of(cone.axis).world([a, b, c, cos_t]);
    (drawn, wo, cone.pdf(two - v), cone.distance)
}

/// Solid-angle pdf with which [`sample_ball`] draws the direction `wo` (unit, meeting the ball)
/// from `x`; 0 where no sample can be drawn (`x` inside the ball, `Cone::of`).
pub fn ball_pdf(x: DVec4, center: DVec4, radius: f64, wo: DVec4) -> f64 {
    let (drawn, cone) = Cone::of(x.to_array(), center.to_array(), radius);
    match drawn {
        true => cone.pdf(1.0 + dot(wo.to_array(), cone.axis)),
        false => 0.0,
    }
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
        let i = self.choose(select)?;
        let l = &self.lights[i];
        let drawn = sample_balls(x.to_array(), l.center.to_array(), l.radius, u.to_array());
        self.drawn(i, drawn)
    }

    /// The light a sample with `select` draws from (none without lights).
    pub fn choose(&self, select: f64) -> Option<usize> {
        let last = self.lights.len().checked_sub(1)?;
        Some(self.cumulative.partition_point(|&c| c <= select).min(last))
    }

    /// The sample of light `i` that `sample_balls` drew in one lane: direction, pdf (of the
    /// ball's cone) and distance, where it drew one.
    pub fn drawn(&self, i: usize, (drawn, wo, pdf, distance): Drawn) -> Option<LightSample> {
        drawn.then(|| LightSample {
            light: i,
            wo: DVec4::from_array(wo),
            pdf: pdf * self.probability[i],
            distance,
        })
    }

    /// The pdf with which [`Lights::sample`] draws the direction `wo` from `x`, a direction that
    /// meets light `i` (selection included); 0 where it cannot (`x` inside the light).
    pub fn pdf(&self, i: usize, x: DVec4, wo: DVec4) -> f64 {
        let l = &self.lights[i];
        ball_pdf(x, l.center, l.radius, wo) * self.probability[i]
    }
}
