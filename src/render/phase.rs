//! Phase functions of participating media in four dimensions.
//!
//! Direction convention, the same as the BSDFs': `wi` and `wo` both point **away from the
//! scattering point**; `wi` towards where the path came from (the camera side), `wo` the
//! direction the path continues in. Light travels along `-wo` and then along `wi`, so the
//! scattering angle between the two travelling directions has `mu = (-wo).wi = -wi.wo`; forward
//! scattering (`g > 0`) sends `wo` near `-wi`, the camera ray's own travelling direction.
//!
//! Sampling is exact, so a sample's weight is 1 and its pdf equals `eval`.

use super::sampling::{Frame, SPHERE3_AREA, safeguarded_newton, uniform_s2, uniform_s3};
use glam::{DVec3, DVec4};
use std::f64::consts::PI;

/// One drawn direction; its weight is exactly 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhaseSample {
    /// The scattered direction, a unit 4D vector.
    pub wo: DVec4,
    /// Solid-angle pdf of `wo` (equal to the phase function's value).
    pub pdf: f64,
}

/// A normalised phase function (integrates to 1 over S^3).
pub trait PhaseFunction {
    /// The phase function's value, per unit solid angle of S^3.
    fn eval(&self, wi: DVec4, wo: DVec4) -> f64;
    /// Draws `wo` from three uniforms in `[0, 1)`, exactly proportional to `eval`.
    fn sample(&self, wi: DVec4, u: DVec3) -> PhaseSample;
    /// The pdf with which `sample` draws `wo`: `eval` itself.
    fn pdf(&self, wi: DVec4, wo: DVec4) -> f64 {
        self.eval(wi, wo)
    }
}

/// Isotropic scattering, `1 / (2 pi^2)` (the area of S^3 is `2 pi^2`, not `4 pi`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Isotropic;

impl PhaseFunction for Isotropic {
    fn eval(&self, _wi: DVec4, _wo: DVec4) -> f64 {
        1.0 / SPHERE3_AREA
    }

    fn sample(&self, _wi: DVec4, u: DVec3) -> PhaseSample {
        PhaseSample {
            wo: uniform_s3(u),
            pdf: 1.0 / SPHERE3_AREA,
        }
    }
}

/// The 4D Henyey-Greenstein phase function
/// `p(mu) = (1 - g^2) / (2 pi^2 (1 + g^2 - 2 g mu)^2)` (the Poisson kernel of the 4-ball), whose
/// mean cosine is exactly `g`. The 3D exponent 3/2 would not be normalised on S^3.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HenyeyGreenstein {
    g: f64,
}

impl HenyeyGreenstein {
    /// Below this `|g|` the lobe is isotropic to within 4e-4 relative, while the theta CDF, which
    /// divides by `(2g)^2`, would start to lose digits to cancellation.
    pub const ISOTROPIC_BELOW: f64 = 1e-4;
    /// `|g|` is clamped here: at `|g| = 1` the lobe is a delta.
    pub const G_MAX: f64 = 0.999;

    /// The phase function with anisotropy `g` (mean cosine; -1 back, 0 isotropic, 1 forward),
    /// clamped to `±G_MAX`.
    pub fn new(g: f64) -> HenyeyGreenstein {
        HenyeyGreenstein {
            g: g.clamp(-Self::G_MAX, Self::G_MAX),
        }
    }

    /// The asymmetry parameter actually used (after clamping).
    pub fn g(&self) -> f64 {
        self.g
    }

    fn is_isotropic(&self) -> bool {
        self.g.abs() < Self::ISOTROPIC_BELOW
    }

    /// The phase function at scattering cosine `mu`.
    pub fn eval_cos(&self, mu: f64) -> f64 {
        if self.is_isotropic() {
            return 1.0 / SPHERE3_AREA;
        }
        let g = self.g;
        let d = 1.0 + g * g - 2.0 * g * mu;
        (1.0 - g * g) / (SPHERE3_AREA * d * d)
    }

    /// Density of the scattering angle theta in `[0, pi]`:
    /// `(2 (1 - g^2) / pi) sin^2 theta / (a - b cos theta)^2`, `a = 1 + g^2`, `b = 2g`
    /// (the S^2 of directions at angle theta has area `4 pi sin^2 theta`).
    pub fn theta_pdf(&self, theta: f64) -> f64 {
        let g = self.g;
        let (a, b) = (1.0 + g * g, 2.0 * g);
        let (s, c) = theta.sin_cos();
        let d = a - b * c;
        2.0 * (1.0 - g * g) / PI * s * s / (d * d)
    }

    /// Exact CDF of theta (for `|g| >= ISOTROPIC_BELOW`):
    /// `F = (2(1-g^2)/pi) [ (a A - theta)/b^2 - sin theta / (b (a - b cos theta)) ]` with
    /// `A = (2/(1-g^2)) atan2((1+g) sin(theta/2), (1-g) cos(theta/2))`.
    pub fn theta_cdf(&self, theta: f64) -> f64 {
        let g = self.g;
        let (a, b) = (1.0 + g * g, 2.0 * g);
        let k = 1.0 - g * g;
        let (sh, ch) = (0.5 * theta).sin_cos();
        let big_a = 2.0 / k * ((1.0 + g) * sh).atan2((1.0 - g) * ch);
        let (s, c) = theta.sin_cos();
        2.0 * k / PI * ((a * big_a - theta) / (b * b) - s / (b * (a - b * c)))
    }

    /// Inverts [`Self::theta_cdf`] at `xi`. There is no closed form, so: Newton's method from the
    /// 3D Henyey-Greenstein inverse as a first guess, kept inside a shrinking bisection bracket
    /// (a Newton step that leaves the bracket, or meets a flat CDF near 0 or pi where the density
    /// vanishes like `sin^2`, is replaced by a bisection step).
    pub fn sample_theta(&self, xi: f64) -> f64 {
        let g = self.g;
        let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * xi);
        let mu = ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0);
        safeguarded_newton(
            |theta| (self.theta_cdf(theta) - xi, self.theta_pdf(theta)),
            mu.acos(),
            (0.0, PI),
            1e-13,
        )
    }
}

impl PhaseFunction for HenyeyGreenstein {
    fn eval(&self, wi: DVec4, wo: DVec4) -> f64 {
        self.eval_cos(-wi.dot(wo))
    }

    /// Theta from the inverted CDF, the other two angles uniform on the S^2 around `-wi`.
    fn sample(&self, wi: DVec4, u: DVec3) -> PhaseSample {
        if self.is_isotropic() {
            return Isotropic.sample(wi, u);
        }
        let theta = self.sample_theta(u.x);
        let (sin_t, cos_t) = theta.sin_cos();
        let local = (sin_t * DVec3::from_array(uniform_s2(u.y, u.z))).extend(cos_t);
        PhaseSample {
            wo: Frame::new(-wi).to_world(local),
            pdf: self.eval_cos(cos_t),
        }
    }
}
