//! Materials as the integrator sees them at one point: read from the outputs of an object's
//! material tape (selector, then every leaf's parameters), or from the scene's constant medium.

use crate::check::value::{Material, MaterialKind, Value};
use crate::ir::lower::Leaf;
use glam::DVec3;

/// What a hit point scatters like.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Surface {
    Diffuse {
        albedo: DVec3,
        emission: DVec3,
    },
    /// An emitter that reflects nothing.
    Light {
        radiance: DVec3,
    },
    Mirror {
        tint: DVec3,
    },
    /// A refracting boundary with a medium inside; `tint` filters each crossing.
    Glass {
        ior: f64,
        tint: DVec3,
        inside: Medium,
    },
    Shiny {
        roughness: f64,
        color: DVec3,
    },
    /// No surface: the ray crosses into (or out of) the medium filling the object (fog, or
    /// clear `air` carved out of a surrounding medium).
    Boundary {
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
    pub sigma_t: f64,
    pub albedo: DVec3,
    pub g: f64,
}

impl Medium {
    pub const VACUUM: Medium = Medium {
        sigma_t: 0.0,
        albedo: DVec3::ONE,
        g: 0.0,
    };

    pub fn is_vacuum(&self) -> bool {
        self.sigma_t <= 0.0
    }

    /// The scene's global medium (`air` or a constant `fog`).
    pub fn of_material(m: &Material) -> Medium {
        let num = |name, default| match m.param(name) {
            Some(Value::Num(x)) => *x,
            _ => default,
        };
        let color = |name, default| match m.param(name) {
            Some(Value::Color(c)) => DVec3::from_array(*c),
            Some(Value::Num(x)) => DVec3::splat(*x),
            _ => default,
        };
        match m.kind {
            MaterialKind::Fog => Medium {
                sigma_t: num("extinction", 0.1),
                albedo: color("albedo", DVec3::splat(0.9)),
                g: num("anisotropy", 0.0),
            },
            _ => Medium::VACUUM,
        }
    }
}

/// A parameter's name, first output and number of outputs (1 for numbers, 3 for colours).
type Slot = (&'static str, usize, usize);

/// Where each leaf's parameters sit among a material tape's outputs.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    leaves: Vec<(MaterialKind, Vec<Slot>)>,
}

impl Layout {
    pub fn new(leaves: &[Leaf]) -> Layout {
        let mut at = 1; // output 0 is the selector
        let leaves = leaves
            .iter()
            .map(|l| {
                let params = l
                    .params
                    .iter()
                    .map(|(name, ids)| {
                        let p = (*name, at, ids.len());
                        at += ids.len();
                        p
                    })
                    .collect();
                (l.kind, params)
            })
            .collect();
        Layout { leaves }
    }

    /// Whether some leaf needs a medium or boundary (glass, fog or air).
    pub fn has_interior(&self) -> bool {
        self.leaves.iter().any(|(k, _)| {
            matches!(
                k,
                MaterialKind::Glass | MaterialKind::Fog | MaterialKind::Air
            )
        })
    }

    /// The surface described by one point's tape outputs. The selector is clamped to the
    /// leaves, so no output value can index out of range.
    pub fn surface(&self, out: &[f32]) -> Surface {
        let last = self.leaves.len().saturating_sub(1);
        let sel = out[0];
        let i = if sel.is_finite() {
            (sel.max(0.0) as usize).min(last)
        } else {
            0
        };
        let (kind, params) = &self.leaves[i];
        let find = |name: &str| params.iter().find(|(n, _, _)| *n == name);
        let num = |name, default: f64| {
            find(name).map_or(default, |&(_, at, _)| finite(out[at] as f64, default))
        };
        let color = |name, default: f64| {
            find(name).map_or(DVec3::splat(default), |&(_, at, len)| {
                let c = |k: usize| finite(out[at + k.min(len - 1)] as f64, default).max(0.0);
                DVec3::new(c(0), c(1), c(2))
            })
        };
        match kind {
            MaterialKind::Diffuse => Surface::Diffuse {
                albedo: color("albedo", 0.8).min(DVec3::ONE),
                emission: color("emission", 0.0),
            },
            MaterialKind::Light => Surface::Light {
                radiance: color("color", 1.0) * num("intensity", 1.0).max(0.0),
            },
            MaterialKind::Mirror => Surface::Mirror {
                tint: color("tint", 1.0).min(DVec3::ONE),
            },
            MaterialKind::Glass => Surface::Glass {
                ior: num("ior", 1.5).max(1e-3),
                tint: color("tint", 1.0).min(DVec3::ONE),
                inside: Medium {
                    sigma_t: num("extinction", 0.0).max(0.0),
                    albedo: color("albedo", 1.0).min(DVec3::ONE),
                    g: 0.0,
                },
            },
            MaterialKind::Shiny => Surface::Shiny {
                roughness: num("roughness", 0.3).clamp(0.0, 1.0),
                color: color("color", 0.9).min(DVec3::ONE),
            },
            MaterialKind::Fog => Surface::Boundary {
                inside: Medium {
                    sigma_t: num("extinction", 0.1).max(0.0),
                    albedo: color("albedo", 0.9).min(DVec3::ONE),
                    g: num("anisotropy", 0.0).clamp(-1.0, 1.0),
                },
            },
            MaterialKind::Air => Surface::Boundary {
                inside: Medium::VACUUM,
            },
        }
    }
}

fn finite(x: f64, default: f64) -> f64 {
    if x.is_finite() { x } else { default }
}
