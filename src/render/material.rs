//! Materials as the integrator sees them at one point: read from the outputs of an object's
//! material tape (selector, then every leaf's parameters), or from the scene's constant medium.

use crate::material::{Material, Slot};
use glam::DVec3;

/// What a hit point scatters like.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Surface {
    /// Lambertian reflection, optionally glowing too.
    Diffuse {
        /// Reflectance per channel, 0 to 1.
        albedo: DVec3,
        /// Emitted radiance, added to what is reflected.
        emission: DVec3,
    },
    /// An emitter that reflects nothing.
    Light {
        /// Emitted radiance, the same in every direction.
        radiance: DVec3,
    },
    /// A perfect specular reflector.
    Mirror {
        /// Reflectance per channel.
        tint: DVec3,
    },
    /// A refracting boundary with a medium inside; `tint` filters each crossing.
    Glass {
        /// Index of refraction of the inside (the outside counts as 1).
        ior: f64,
        /// Transmittance per channel of each crossing.
        tint: DVec3,
        /// The medium inside the object.
        inside: Medium,
    },
    /// Glossy GGX reflection.
    Shiny {
        /// Perceptual roughness, 0 (mirror-like) to 1.
        roughness: f64,
        /// Reflectance at normal incidence per channel.
        color: DVec3,
    },
    /// No surface: the ray crosses into (or out of) the medium filling the object (fog, or
    /// clear `air` carved out of a surrounding medium).
    Boundary {
        /// The medium inside the object.
        inside: Medium,
    },
}

impl Surface {
    /// The colour recorded in the albedo buffer (for denoising).
    pub fn albedo(&self) -> DVec3 {
        match *self {
            Surface::Diffuse { albedo, .. } => albedo,
            Surface::Light { radiance } => radiance.min(DVec3::ONE),
            Surface::Mirror { tint } => tint,
            Surface::Glass { tint, .. } => tint,
            Surface::Shiny { color, .. } => color,
            Surface::Boundary { inside } => inside.albedo,
        }
    }

    /// The radiance the surface emits.
    pub fn emission(&self) -> DVec3 {
        match *self {
            Surface::Diffuse { emission, .. } => emission,
            Surface::Light { radiance } => radiance,
            _ => DVec3::ZERO,
        }
    }
}

/// A homogeneous medium: extinction `sigma_t` (per unit length, grey), single-scattering albedo
/// `sigma_s / sigma_t` per channel, and the Henyey-Greenstein anisotropy `g`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Medium {
    /// Extinction coefficient per unit length; 0 is vacuum.
    pub sigma_t: f64,
    /// Single-scattering albedo per channel, 0 to 1.
    pub albedo: DVec3,
    /// Henyey-Greenstein anisotropy, -1 (back) to 1 (forward), 0 isotropic.
    pub g: f64,
}

impl Medium {
    /// Empty space: nothing absorbs or scatters.
    pub const VACUUM: Medium = Medium {
        sigma_t: 0.0,
        albedo: DVec3::ONE,
        g: 0.0,
    };

    /// Whether rays pass through without interacting (no extinction).
    pub fn is_vacuum(&self) -> bool {
        self.sigma_t <= 0.0
    }
}

/// A parameter's first output in a material tape, and the builtin table's default that stands
/// in for a non-finite value.
pub type At = (usize, f64);

/// Where each leaf's parameters sit among a material tape's outputs: each number's output,
/// and each colour's first of three.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    leaves: Vec<Material<At, At>>,
}

impl Layout {
    /// The layout of a material tape whose outputs are the selector (output 0), then every
    /// leaf's parameters at the outputs `leaves` gives.
    pub fn new(leaves: Vec<Material<At, At>>) -> Layout {
        Layout { leaves }
    }

    /// Whether some leaf needs a medium or boundary (glass, fog or air).
    pub fn has_interior(&self) -> bool {
        self.leaves.iter().any(|l| l.kind().has_interior())
    }

    /// The surface described by one point's tape outputs. The selector is clamped to the
    /// leaves, so no output value can index out of range; a non-finite parameter takes its
    /// default from the builtin table.
    pub fn surface(&self, out: &[f32]) -> Surface {
        let last = self.leaves.len().saturating_sub(1);
        let sel = out[0];
        let i = if sel.is_finite() {
            (sel.max(0.0) as usize).min(last)
        } else {
            0
        };
        let m: Material<f64, DVec3> = self.leaves[i].convert(|p| match p {
            Slot::Num(&(at, default)) => Slot::Num(finite(out[at] as f64, default)),
            Slot::Color(&(at, default)) => {
                Slot::Color(DVec3::from_array(std::array::from_fn(|k| {
                    finite(out[at + k] as f64, default).max(0.0)
                })))
            }
        });
        match m {
            Material::Diffuse { albedo, emission } => Surface::Diffuse {
                albedo: albedo.min(DVec3::ONE),
                emission,
            },
            Material::Light { color, intensity } => Surface::Light {
                radiance: color * intensity.max(0.0),
            },
            Material::Mirror { tint } => Surface::Mirror {
                tint: tint.min(DVec3::ONE),
            },
            Material::Glass {
                ior,
                tint,
                extinction,
                albedo,
            } => Surface::Glass {
                ior: ior.max(1e-3),
                tint: tint.min(DVec3::ONE),
                inside: Medium {
                    sigma_t: extinction.max(0.0),
                    albedo: albedo.min(DVec3::ONE),
                    g: 0.0,
                },
            },
            Material::Shiny { roughness, color } => Surface::Shiny {
                roughness: roughness.clamp(0.0, 1.0),
                color: color.min(DVec3::ONE),
            },
            Material::Fog {
                extinction,
                albedo,
                anisotropy,
            } => Surface::Boundary {
                inside: Medium {
                    sigma_t: extinction.max(0.0),
                    albedo: albedo.min(DVec3::ONE),
                    g: anisotropy.clamp(-1.0, 1.0),
                },
            },
            Material::Air => Surface::Boundary {
                inside: Medium::VACUUM,
            },
        }
    }
}

fn finite(x: f64, default: f64) -> f64 {
    if x.is_finite() { x } else { default }
}
