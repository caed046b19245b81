//! The typed scene: what the checker hands to every later stage (lowering, rendering, the
//! printer), with every default filled in. Shapes, materials and lattices are Rust types with
//! typed fields; values known only per point or per frame are field expressions (`field`).

pub mod builtins;
pub mod field;
pub mod lattice;
pub mod material;
pub mod print;
pub mod ranges;
pub mod shape;
pub mod types;

pub use field::{Const, FieldBin, FieldId, FieldOp, Fields, Input, MathFn, Param};
pub use lattice::Lattice;
pub use material::{Material, MaterialKind, Slot};
pub use print::Num;
pub use shape::{Polytope, Rotation, Shape, ShapeKind};
pub use types::Type;

/// The denoiser is the `denoise` module's own type; a scene names one.
pub use crate::denoise::Denoise;

use crate::source::Span;
use std::rc::Rc;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quality {
    Draft,
    Preview,
    Final,
    Custom,
}

#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    pub frames: u32,
    pub spp: u32,
    pub bounces: u32,
    pub epsilon: f64,
    pub max_steps: u32,
    pub seed: u64,
    pub denoise: Denoise,
    pub quality: Quality,
    pub fps: f64,
    pub exposure: f64,
    /// Worker threads; 0 uses every core.
    pub threads: u32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 320,
            height: 240,
            frames: 1,
            spp: 16,
            bounces: 8,
            epsilon: 1e-4,
            max_steps: 1000,
            seed: 0,
            denoise: Denoise::Atrous,
            quality: Quality::Custom,
            fps: 20.0,
            exposure: 1.0,
            threads: 0,
        }
    }
}

impl Quality {
    /// The name in scenes (`render { quality = "draft" }`).
    pub fn name(self) -> &'static str {
        match self {
            Quality::Draft => "draft",
            Quality::Preview => "preview",
            Quality::Final => "final",
            Quality::Custom => "custom",
        }
    }

    /// The preset's samples, bounces, marching epsilon and step limit.
    pub fn apply(self, r: &mut RenderSettings) {
        let (spp, bounces, eps, steps) = match self {
            Quality::Draft => (4, 4, 1e-3, 1000),
            Quality::Preview => (16, 6, 1e-4, 1000),
            Quality::Final => (256, 12, 1e-5, 5000),
            Quality::Custom => return,
        };
        (r.spp, r.bounces, r.epsilon, r.max_steps) = (spp, bounces, eps, steps);
        r.quality = self;
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub from: [f64; 4],
    pub to: [f64; 4],
    /// Orientation: plane rotations, whose angles may depend on `t`.
    pub look: Rotation,
    /// Horizontal field of view in radians.
    pub fov: f64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    pub name: String,
    pub span: Span,
    pub shape: Rc<Shape>,
    /// A material, or a field of type material over `p`, `n` and `t` (a material map).
    pub material: Param<Rc<Material>>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    pub render: RenderSettings,
    pub camera: Camera,
    pub sky: [f64; 3],
    /// The global medium: `air` or a constant `fog`.
    pub medium: Material,
    pub objects: Vec<Object>,
    pub fields: Fields,
}

impl Object {
    /// Which of `p`, `n`, `t` the material depends on.
    pub fn material_deps(&self, fields: &Fields) -> u8 {
        match &self.material {
            Param::Const(m) => m.deps(fields),
            Param::Field(id) => fields.get(*id).deps,
        }
    }
}
