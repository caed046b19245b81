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

pub use crate::math::Plane;
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
/// A `quality` preset: sets `spp`, `bounces`, `epsilon` and `max_steps` at once (see
/// [`Quality::apply`]).
pub enum Quality {
    /// 4 spp, 4 bounces, epsilon 1e-3, 1000 steps: fast and noisy.
    Draft,
    /// 16 spp, 6 bounces, epsilon 1e-4, 1000 steps.
    Preview,
    /// 256 spp, 12 bounces, epsilon 1e-5, 5000 steps.
    Final,
    /// No preset: the four settings as written (the default).
    Custom,
}

#[derive(Clone, Debug, PartialEq)]
/// The scene's `render { ... }` block with every default filled in, the quality preset applied and
/// each value within its [`ranges`] entry.
pub struct RenderSettings {
    /// Image width in pixels (1 to 16384; default 320).
    pub width: u32,
    /// Image height in pixels (1 to 16384; default 240).
    pub height: u32,
    /// Frames of the animation (default 1); `t` runs from 0 on the first to 1 on the last.
    pub frames: u32,
    /// Samples (paths) per pixel.
    pub spp: u32,
    /// Most scattering events of one light path.
    pub bounces: u32,
    /// Ray marching: how close to a surface counts as a hit, in world units, in `(0, 1]`.
    pub epsilon: f64,
    /// Ray marching: most steps along one ray segment.
    pub max_steps: u32,
    /// Seed of the sampler; the same seed renders the same image on any number of threads.
    pub seed: u64,
    /// The filter applied to each finished frame (default à-trous).
    pub denoise: Denoise,
    /// The preset the settings came from (`Custom`: none).
    pub quality: Quality,
    /// Frames per second of an animated GIF, in `(0, 100]`.
    pub fps: f64,
    /// Brightness multiplier of the output, in `(0, 1e6]`: radiance is scaled by it before tone
    /// mapping (GIF, PNG) or storing (EXR).
    pub exposure: f64,
    /// Worker threads; 0 uses every core.
    pub threads: u32,
}

impl RenderSettings {
    /// The worker threads the scene asks for; `None` for every core (`threads = 0`).
    pub fn threads(&self) -> Option<usize> {
        (self.threads > 0).then_some(self.threads as usize)
    }
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
/// The scene's `camera { ... }` block: a pinhole camera in 4D that images the 3D slice spanned by
/// its right, up and forward axes.
pub struct Camera {
    /// Position on the first frame.
    pub from: [f64; 4],
    /// Position on the last frame; in between the camera moves linearly from `from`.
    pub to: [f64; 4],
    /// Orientation: plane rotations, whose angles may depend on `t`.
    pub look: Rotation,
    /// Horizontal field of view in radians.
    pub fov: f64,
}

#[derive(Clone, Debug, PartialEq)]
/// One `object name { shape = ...  material = ... }` of the scene.
pub struct Object {
    /// The name written after `object`.
    pub name: String,
    /// Where the object is written in its source, for diagnostics.
    pub span: Span,
    /// The solid, as a tree of shape nodes.
    pub shape: Rc<Shape>,
    /// A material, or a field of type material over `p`, `n` and `t` (a material map).
    pub material: Param<Rc<Material>>,
}

#[derive(Clone, Debug, PartialEq)]
/// A checked scene: settings, camera, sky, medium and objects, with every default filled in and
/// every constant evaluated. [`crate::Compilation`] makes it, [`crate::Compiled`] lowers it,
/// [`crate::render()`] renders it.
pub struct Scene {
    /// The `render` block's settings.
    pub render: RenderSettings,
    /// The camera.
    pub camera: Camera,
    /// Radiance of rays that leave the scene, linear RGB (default black).
    pub sky: [f64; 3],
    /// The global medium: `air` or a constant `fog`.
    pub medium: Material,
    /// The objects, in source order (an object's index is its id in tapes).
    pub objects: Vec<Object>,
    /// Every field expression the scene's parameters refer to by [`FieldId`].
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
