//! Surface scattering (BSDFs) in four dimensions.
//!
//! # Conventions
//! - Every BSDF works in a **local frame whose normal is e4** (the `w` axis); the integrator maps
//!   directions with a [`Frame`](super::sampling::Frame). `cos(theta) = w`.
//! - `wi` and `wo` are unit vectors that both **point away from the surface**. `wi` is the
//!   direction the path arrived from (towards the camera side), `wo` the direction a sample
//!   continues in (towards the light side). `sample(wi, u)` draws `wo`.
//! - Reflective BSDFs ([`Lambert`], [`Mirror`], [`Ggx`]) are one-sided: they scatter only when
//!   `wi.w > 0` and `wo.w > 0`; a two-sided surface is handled by flipping the frame towards `wi`.
//!   [`Dielectric`] is two-sided (see its documentation for the side convention).
//! - A sample's `weight` is `eval(wi, wo) * |wo.w| / pdf` for a non-delta sample (computed in a
//!   form that stays finite), and the throughput multiplier directly for a delta sample, whose
//!   `pdf` is then the discrete probability of the chosen branch. `eval` and `pdf` are 0 for
//!   delta lobes.
//! - Colours are linear RGB `DVec3`.

use super::sampling::{
    BALL3_VOLUME, cosine_hemisphere, cosine_hemisphere_pdf, fresnel_dielectric, reflect, refract,
    uniform_ball3,
};
use glam::{DVec3, DVec4};

/// One drawn scattering direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    /// The sampled direction, local frame, pointing away from the surface.
    pub wo: DVec4,
    /// Throughput multiplier: `eval * |cos| / pdf`, or the delta lobe's factor.
    pub weight: DVec3,
    /// Solid-angle pdf of `wo`, or the branch probability of a delta sample.
    pub pdf: f64,
    /// The lobe is a Dirac delta: `eval`/`pdf` cannot reproduce this sample (no MIS with it).
    pub delta: bool,
}

/// A BSDF in the local frame (normal = e4); see the module documentation for the conventions.
pub trait Bsdf {
    /// The BSDF value `f(wi, wo)`, without the cosine factor. Zero for delta lobes.
    fn eval(&self, wi: DVec4, wo: DVec4) -> DVec3;
    /// Draws `wo` from three uniforms in `[0, 1)`. `None` means a zero-weight sample: the
    /// integrator ends the path (it must not redraw, that would bias the estimate).
    fn sample(&self, wi: DVec4, u: DVec3) -> Option<BsdfSample>;
    /// Solid-angle pdf with which `sample` draws `wo`. Zero for delta lobes.
    fn pdf(&self, wi: DVec4, wo: DVec4) -> f64;
}

/// The mirror image of `wi` about the normal e4, both pointing away from the surface.
fn mirror_direction(wi: DVec4) -> DVec4 {
    -reflect(wi, DVec4::W)
}

/// Ideal diffuse reflection. `f = rho / V_3 = 3 rho / (4 pi)`: the hemisphere's projected solid
/// angle in 4D is `4 pi / 3`, so the 3D `rho / pi` would be 33% too bright.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lambert {
    /// Reflectance per channel, 0 to 1.
    pub albedo: DVec3,
}

impl Lambert {
    /// The sample `sample` makes of `wo`, a `cosine_hemisphere` direction (drawn four at a
    /// time by the integrator's diffuse vertices).
    pub fn sampled(&self, wi: DVec4, wo: DVec4) -> Option<BsdfSample> {
        if wi.w <= 0.0 {
            return None;
        }
        (wo.w > 0.0).then(|| BsdfSample {
            wo,
            weight: self.albedo,
            pdf: cosine_hemisphere_pdf(wo.w),
            delta: false,
        })
    }
}

impl Bsdf for Lambert {
    fn eval(&self, wi: DVec4, wo: DVec4) -> DVec3 {
        if wi.w > 0.0 && wo.w > 0.0 {
            self.albedo / BALL3_VOLUME
        } else {
            DVec3::ZERO
        }
    }

    /// Malley cosine sampling: the weight is exactly `albedo`.
    fn sample(&self, wi: DVec4, u: DVec3) -> Option<BsdfSample> {
        self.sampled(wi, DVec4::from_array(cosine_hemisphere(u.to_array())))
    }

    fn pdf(&self, wi: DVec4, wo: DVec4) -> f64 {
        if wi.w > 0.0 {
            cosine_hemisphere_pdf(wo.w)
        } else {
            0.0
        }
    }
}

/// A perfect mirror that multiplies by `tint` (a constant reflectance).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mirror {
    /// Reflectance per channel, 0 to 1.
    pub tint: DVec3,
}

impl Bsdf for Mirror {
    fn eval(&self, _wi: DVec4, _wo: DVec4) -> DVec3 {
        DVec3::ZERO
    }

    fn sample(&self, wi: DVec4, _u: DVec3) -> Option<BsdfSample> {
        (wi.w > 0.0).then(|| BsdfSample {
            wo: mirror_direction(wi),
            weight: self.tint,
            pdf: 1.0,
            delta: true,
        })
    }

    fn pdf(&self, _wi: DVec4, _wo: DVec4) -> f64 {
        0.0
    }
}

/// A smooth dielectric interface (glass) with exact Fresnel and total internal reflection.
///
/// Side convention: the normal e4 points to the **exterior, of index 1**; the interior (`w < 0`)
/// has index `ior`. `wi.w > 0` means the path arrives from outside.
///
/// Reflection or refraction is chosen with probability `F`, so both branches have weight 1
/// except for radiance scaling: `L / eta^3` is invariant across an interface in 4D (`eta^(n-1)`),
/// so a transmitted sample carries `(eta_wi_side / eta_wo_side)^3`, the camera side over the
/// light side (entering glass of index 1.5 from air: `1 / 1.5^3`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dielectric {
    /// Index of refraction of the inside relative to the outside (1.5 for glass in air).
    pub ior: f64,
}

impl Bsdf for Dielectric {
    fn eval(&self, _wi: DVec4, _wo: DVec4) -> DVec3 {
        DVec3::ZERO
    }

    fn sample(&self, wi: DVec4, u: DVec3) -> Option<BsdfSample> {
        let (eta_wi, eta_other, facing) = if wi.w >= 0.0 {
            (1.0, self.ior, DVec4::W)
        } else {
            (self.ior, 1.0, -DVec4::W)
        };
        let f = fresnel_dielectric(wi.w.abs(), eta_wi, eta_other);
        let reflection = BsdfSample {
            wo: mirror_direction(wi),
            weight: DVec3::ONE,
            pdf: f,
            delta: true,
        };
        if u.x < f {
            return Some(reflection);
        }
        // F < 1 here, so there is no total internal reflection; the fallback only guards u.x = 1.
        let Some(wo) = refract(-wi, facing, eta_wi / eta_other) else {
            return Some(reflection);
        };
        Some(BsdfSample {
            wo,
            weight: DVec3::splat((eta_wi / eta_other).powi(3)),
            pdf: 1.0 - f,
            delta: true,
        })
    }

    fn pdf(&self, _wi: DVec4, _wo: DVec4) -> f64 {
        0.0
    }
}

/// GGX (Trowbridge-Reitz) microfacet reflection in 4D: the normal distribution of an ellipsoid
/// with semi-axes `(1, 1, 1, alpha)`, exact height-correlated Smith masking-shadowing, and
/// visible-normal sampling generalised from Heitz 2018 (the disk becomes a 3-ball).
///
/// Fresnel is Schlick's with `color` as `F0`, a metal: `F = F0 + (1 - F0)(1 - cos)^5` at the
/// microfacet (`color = 1` gives `F = 1`, the furnace setting).
///
/// A lobe with `alpha < ALPHA_MIN` is treated as a perfect mirror (a delta lobe with Schlick
/// Fresnel at `wi.w`), so roughness 0 never divides by zero.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ggx {
    /// GGX roughness, `roughness^2`; 0 is a perfect mirror.
    pub alpha: f64,
    /// Reflectance at normal incidence per channel (Schlick's `F0`).
    pub color: DVec3,
}

impl Ggx {
    /// The narrowest continuous lobe: `D` peaks at `3 / (4 pi alpha^3)`, about 2e11, still far
    /// from overflow; below it the lobe is a mirror.
    pub const ALPHA_MIN: f64 = 1e-4;

    /// The user's perceptual roughness `r` in `[0, 1]` maps to `alpha = r^2` (the usual
    /// remapping, so that the lobe width changes evenly along the slider). `r = 0` is a perfect
    /// mirror; any other `r` gets `alpha >= ALPHA_MIN`.
    pub fn from_roughness(roughness: f64, color: DVec3) -> Ggx {
        let r = roughness.clamp(0.0, 1.0);
        let alpha = if r > 0.0 {
            (r * r).max(Self::ALPHA_MIN)
        } else {
            0.0
        };
        Ggx { alpha, color }
    }

    /// Whether this lobe is treated as a delta mirror (also for a NaN alpha).
    pub fn is_mirror(&self) -> bool {
        self.alpha.is_nan() || self.alpha < Self::ALPHA_MIN
    }

    /// The NDF `D(h) = 3 alpha^2 / (4 pi (alpha^2 cos^2 + sin^2)^(5/2))` for a unit `h`, zero
    /// below the horizon. Written with `sin^2 = |h_xyz|^2` so it stays accurate near the normal.
    pub fn ndf(&self, h: DVec4) -> f64 {
        if h.w <= 0.0 {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        let t = a2 * h.w * h.w + h.truncate().length_squared();
        a2 / (BALL3_VOLUME * t * t * t.sqrt())
    }

    /// `sqrt(cos^2 + alpha^2 sin^2)` of a direction (any length), the quantity behind Smith.
    fn smith_root(&self, v: DVec4) -> f64 {
        (v.w * v.w + self.alpha * self.alpha * v.truncate().length_squared()).sqrt()
    }

    /// Smith's `Lambda(v) = (-1 + sqrt(1 + alpha^2 tan^2 theta)) / 2`, the same in every
    /// dimension; infinite at or below the horizon.
    pub fn lambda(&self, v: DVec4) -> f64 {
        if v.w <= 0.0 {
            return f64::INFINITY;
        }
        0.5 * (self.smith_root(v) / v.w - 1.0)
    }

    /// Smith masking `G1 = 1 / (1 + Lambda)`, in the cancellation-free form
    /// `2 cos / (cos + sqrt(cos^2 + alpha^2 sin^2))`.
    pub fn g1(&self, v: DVec4) -> f64 {
        if v.w <= 0.0 {
            return 0.0;
        }
        2.0 * v.w / (v.w + self.smith_root(v))
    }

    /// Height-correlated masking-shadowing `G2 = 1 / (1 + Lambda(i) + Lambda(o))`.
    pub fn g2(&self, wi: DVec4, wo: DVec4) -> f64 {
        if wi.w <= 0.0 || wo.w <= 0.0 {
            return 0.0;
        }
        2.0 * wi.w * wo.w / (self.smith_root(wi) * wo.w + self.smith_root(wo) * wi.w)
    }

    /// Schlick's Fresnel with `color` as `F0`, at `cos = i.h`.
    pub fn fresnel(&self, cos: f64) -> DVec3 {
        let m = (1.0 - cos.clamp(0.0, 1.0)).powi(5);
        self.color + (DVec3::ONE - self.color) * m
    }

    /// The microfacet BRDF before Fresnel and masking: `D(h) / (8 |i.h| |i.n| |o.n|)`, with
    /// `h = normalize(wi + wo)`. The `8 (i.h)` is 4D's half-vector Jacobian
    /// `|d omega_h / d omega_o| = 1 / (8 (o.h)^2)` (3D has `1 / (4 o.h)`). Zero when `h` is below
    /// the horizon; infinite for tangent directions.
    pub fn unshadowed(&self, wi: DVec4, wo: DVec4) -> f64 {
        let h = (wi + wo).normalize_or_zero();
        let d = self.ndf(h);
        if d == 0.0 {
            return 0.0;
        }
        d / (8.0 * wi.dot(h).abs() * wi.w.abs() * wo.w.abs())
    }

    /// A microfacet normal drawn from the distribution of normals visible from `wi`
    /// (`wi.w > 0`), `D_wi(m) = G1(wi) max(0, wi.m) D(m) / wi.w`, by the six steps of the physics
    /// notes: stretch to the unit-sphere configuration, sample the projected 3-ball of the
    /// visible hemisphere (warped along the in-plane axis `t`), unstretch.
    pub fn sample_visible_normal(&self, wi: DVec4, u: DVec3) -> DVec4 {
        let a = self.alpha;
        // 1. The incident direction in the stretched (alpha = 1) configuration.
        let vs = DVec4::new(a * wi.x, a * wi.y, a * wi.z, wi.w).normalize();
        // 2. t = normalize(e4 - (e4.vs) vs) lies in the plane of e4 and vs's tangential part
        //    `dir`: t = -vs.w dir + |vs_xyz| e4 (unit because |vs| = 1). At normal incidence any
        //    tangential `dir` serves. b1, b2 span the rest: the tangential complement of `dir`.
        let tangential = vs.truncate();
        let sin_s = tangential.length();
        let dir = if sin_s > 0.0 {
            tangential / sin_s
        } else {
            DVec3::X
        };
        let t = (-vs.w * dir).extend(sin_s);
        let (b1, b2) = dir.any_orthonormal_pair();
        // 3-4. A uniform point of the 3-ball, squeezed along t onto the visible part.
        let p = DVec3::from_array(uniform_ball3(u.to_array()));
        let (p1, p2) = (p.y, p.z);
        let half_chord = (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
        let s = 0.5 * (1.0 + vs.w);
        let pt = (1.0 - s) * half_chord + s * p.x;
        // 5. Lift onto the hemisphere around vs.
        let lift = (1.0 - pt * pt - p1 * p1 - p2 * p2).max(0.0).sqrt();
        let ms = pt * t + p1 * b1.extend(0.0) + p2 * b2.extend(0.0) + lift * vs;
        // 6. Unstretch.
        DVec4::new(a * ms.x, a * ms.y, a * ms.z, ms.w.max(0.0)).normalize()
    }
}

impl Bsdf for Ggx {
    /// `f = F(i.h) G2 D / (8 (i.h) (i.n) (o.n))`; symmetric in `wi`, `wo`.
    fn eval(&self, wi: DVec4, wo: DVec4) -> DVec3 {
        if self.is_mirror() || wi.w <= 0.0 || wo.w <= 0.0 {
            return DVec3::ZERO;
        }
        let h = (wi + wo).normalize();
        self.fresnel(wi.dot(h)) * (self.g2(wi, wo) * self.unshadowed(wi, wo))
    }

    /// Visible-normal sampling; weight `F G2 / G1(wi) <= 1`. A reflected direction below the
    /// horizon is a zero-weight sample (`None`), never redrawn: redrawing would delete the
    /// energy that masking loses and reshape the lobe.
    fn sample(&self, wi: DVec4, u: DVec3) -> Option<BsdfSample> {
        if wi.w <= 0.0 {
            return None;
        }
        if self.is_mirror() {
            return Some(BsdfSample {
                wo: mirror_direction(wi),
                weight: self.fresnel(wi.w),
                pdf: 1.0,
                delta: true,
            });
        }
        let m = self.sample_visible_normal(wi, u);
        let cos_im = wi.dot(m);
        let wo = 2.0 * cos_im * m - wi;
        if cos_im <= 0.0 || wo.w <= 0.0 {
            return None;
        }
        let pdf = self.pdf(wi, wo);
        (pdf > 0.0).then(|| BsdfSample {
            wo,
            weight: self.fresnel(cos_im) * (self.g2(wi, wo) / self.g1(wi)),
            pdf,
            delta: false,
        })
    }

    /// `pdf_o = D_wi(h) / (8 (i.h)^2) = G1(i) D(h) / (8 (i.n) (i.h))`. It integrates to less than
    /// 1 over the upper hemisphere: the rest is the mass of the `None` samples.
    fn pdf(&self, wi: DVec4, wo: DVec4) -> f64 {
        if self.is_mirror() || wi.w <= 0.0 || wo.w <= 0.0 {
            return 0.0;
        }
        let h = (wi + wo).normalize();
        self.g1(wi) * self.ndf(h) / (8.0 * wi.w * wi.dot(h))
    }
}
