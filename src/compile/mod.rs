//! The compile pipeline's single owner: a typed scene becomes what each frame renders.
//!
//! The scene is lowered to IR once ([`Compiled::new`]). For a frame at animation time `t`,
//! [`Compiled::frame`] folds `t` in, optimises, compiles the scene, interior and per-object
//! tapes ([`Compiled::program`]), and evaluates the camera's `look` angles and the spherical
//! lights' placement from the same IR in `f64`. `--emit ir|bytecode` prints exactly this
//! program, so what a user pins is what is rendered. [`Frames`] is what the renderer gets:
//! every frame built from it, cells, camera, materials and lights included.

mod frames;

pub use frames::Frames;

use crate::ir::eval::{Reference, vars};
use crate::ir::lower::{LightIr, Place};
use crate::ir::{self, Id, SceneIr, opt};
use crate::math::Plane;
use crate::math::plane::rotate;
use crate::scene::Scene;
use crate::vm::{ObjectTapes, Program, Tape};

/// A scene lowered once, ready to be specialised per frame.
#[derive(Clone, Debug)]
pub struct Compiled {
    /// The plain lowered IR, `t` free: the reference every optimised tape is tested against.
    #[doc(hidden)]
    pub ir: SceneIr,
    /// Each object's bounding sphere (centre, radius) where the scene gives one for every
    /// frame; `None` for unbounded shapes and ones that move.
    pub bounds: Vec<Option<([f64; 4], f64)>>,
    /// Whether each object's shape holds a tiling (`Shape::tiled`): a bounded one is in the
    /// escape proof's box but outside the cells' cube (`frames::cells`).
    pub tiled: Vec<bool>,
}

/// Where one spherical light is in one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightPlacement {
    /// The object's index in the scene.
    pub object: usize,
    /// The light's centre in world space, at this frame.
    pub center: [f64; 4],
    /// The light's radius in world units (positive and finite).
    pub radius: f64,
}

/// Everything compiled for one frame.
#[derive(Clone, Debug)]
#[doc(hidden)]
pub struct Frame {
    /// The animation time folded into this frame's tapes: 0 on the first frame, 1 on the last.
    pub t: f64,
    /// The tapes this frame renders with: the scene's distance, its interior and each object's.
    pub program: Program,
    /// The camera's `look` rotations with their angles at `t`.
    pub look: Vec<(Plane, f64)>,
    /// The spherical lights that exist at `t` (a zero or non-finite size drops one).
    pub lights: Vec<LightPlacement>,
}

impl Compiled {
    /// Lower `scene` to IR once, and note each object's bounding sphere; frames are specialised
    /// from it with [`Compiled::frame`].
    pub fn new(scene: &Scene) -> Compiled {
        Compiled {
            ir: ir::lower(scene),
            bounds: scene.objects.iter().map(|o| o.shape.bounds()).collect(),
            tiled: scene.objects.iter().map(|o| o.shape.tiled()).collect(),
        }
    }

    /// The tapes with `t` folded in (or left free with `None`).
    #[doc(hidden)]
    pub fn program(&self, t: Option<f64>) -> Program {
        program(&self.ir, t)
    }

    /// Everything frame-specific at animation time `t`.
    #[doc(hidden)]
    pub fn frame(&self, t: f64) -> Frame {
        let mut roots: Vec<Id> = self.ir.look.iter().map(|(_, a)| *a).collect();
        roots.extend(self.ir.lights.iter().flat_map(|l| l.ids()));
        let mut reference = Reference::new(&self.ir.graph, &roots);
        reference.run(&vars([0.0; 4], [0.0; 4], t));
        let get = |id: Id| reference.value(id);
        let look = (self.ir.look.iter()).map(|(p, a)| (*p, get(*a))).collect();
        let lights = (self.ir.lights.iter())
            .filter_map(|l| placement(l, get))
            .collect();
        Frame {
            t,
            program: self.program(Some(t)),
            look,
            lights,
        }
    }
}

/// Where light `l` is, with its parameters read through `get`: from the hypersphere outwards
/// through its operations. `None` when a scale is not positive or the result is not usable.
fn placement(l: &LightIr, get: impl Fn(Id) -> f64) -> Option<LightPlacement> {
    let mut center = [0.0; 4];
    let mut radius = get(l.radius);
    for place in l.places.iter().rev() {
        match place {
            Place::Translate(o) => center = std::array::from_fn(|i| center[i] + get(o[i])),
            Place::Rotate(steps) => {
                center = rotate(center, steps.iter().map(|(p, a)| (*p, get(*a))))
            }
            Place::Scale(k) => {
                let k = get(*k);
                if k.is_nan() || k <= 0.0 {
                    return None;
                }
                center = center.map(|x| x * k);
                radius *= k;
            }
            Place::Round(r) => radius += get(*r),
        }
    }
    let usable = radius > 0.0 && radius.is_finite() && center.iter().all(|x| x.is_finite());
    usable.then_some(LightPlacement {
        object: l.object,
        center,
        radius,
    })
}

/// The animation time of frame `f` of `frames`: 0 on the first, 1 on the last.
pub fn frame_time(f: u32, frames: u32) -> f64 {
    if frames <= 1 {
        0.0
    } else {
        f as f64 / (frames - 1) as f64
    }
}

/// Optimise `raw` (with `t` free, or fixed to one frame's value) and compile its tapes.
#[doc(hidden)]
pub fn program(raw: &SceneIr, t: Option<f64>) -> Program {
    let ir = opt::optimise(raw, t);
    let g = &ir.graph;
    let scene = Tape::compile("scene", g, &[ir.distance, ir.nearest]);
    let interior = (ir.interior).map(|(d, n)| Tape::compile("interior", g, &[d, n]));
    let objects = (ir.objects.iter())
        .map(|o| ObjectTapes {
            name: o.name.clone(),
            distance: Tape::compile(&format!("{} distance", o.name), g, &[o.distance]),
            material: Tape::compile(&format!("{} material", o.name), g, &o.material.roots()),
        })
        .collect();
    Program {
        ir,
        scene,
        interior,
        objects,
    }
}
