//! Everything the integrator needs for one frame: the tapes with that frame's `t` folded in,
//! the camera, each object's material layout, and which features the scene uses.

use super::camera::FrameCamera;
use super::material::{Layout, Medium};
use crate::check::Scene;
use crate::ir::eval::Reference;
use crate::ir::{K, Node, SceneIr, Un, Var, opt};
use crate::vm::{Program, Tape};
use glam::{DVec3, DVec4};

pub struct FrameObject {
    pub distance: Tape,
    pub material: Tape,
    pub layout: Layout,
}

/// What a scene uses, so the renderer pays only for those features.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Features {
    /// Some object can be entered (glass, fog or air in its material): rays may travel inside
    /// objects, which needs the interior tape and a medium stack.
    pub interiors: bool,
}

pub struct FrameScene {
    pub t: f64,
    pub camera: FrameCamera,
    /// Outputs: signed distance to the nearest visible object, and its index.
    pub scene: Tape,
    /// Outputs: unsigned distance to the nearest surface (`min |d_i|`), and its object, for
    /// rays inside objects; `None` when no object can be entered.
    pub interior: Option<Tape>,
    pub objects: Vec<FrameObject>,
    pub medium: Medium,
    pub sky: DVec3,
    pub features: Features,
}

/// The scene's IR, lowered once and specialised per frame.
pub struct Prepared<'s> {
    pub scene: &'s Scene,
    ir: SceneIr,
    /// The same graph with the interior distance as its scene root.
    interior: Option<SceneIr>,
    layouts: Vec<Layout>,
    pub features: Features,
}

impl<'s> Prepared<'s> {
    pub fn new(scene: &'s Scene) -> Prepared<'s> {
        let ir = crate::ir::lower(scene);
        let layouts: Vec<Layout> = ir
            .objects
            .iter()
            .map(|o| Layout::new(&o.material.leaves))
            .collect();
        let interiors = layouts.iter().any(Layout::has_interior);
        let features = Features { interiors };
        let interior = interiors.then(|| interior_ir(&ir));
        Prepared {
            scene,
            ir,
            interior,
            layouts,
            features,
        }
    }

    /// The frame at animation time `t`.
    pub fn frame(&self, t: f64) -> FrameScene {
        let program = Program::from_ir(&self.ir, Some(t));
        let interior = self.interior.as_ref().map(|ir| {
            let o = opt::optimise(ir, Some(t));
            Tape::compile("interior", &o.graph, &[o.distance, o.nearest])
        });
        let look_ids: Vec<_> = self.ir.look.iter().map(|(_, a)| *a).collect();
        let mut reference = Reference::new(&self.ir.graph, &look_ids);
        let mut vars = [0.0; 9];
        vars[Var::T.index()] = t;
        reference.run(&vars);
        let look: Vec<_> = (self.ir.look.iter())
            .map(|(plane, a)| (*plane, reference.value(*a)))
            .collect();
        let objects = (program.objects.into_iter().zip(&self.layouts))
            .map(|(o, layout)| FrameObject {
                distance: o.distance,
                material: o.material,
                layout: layout.clone(),
            })
            .collect();
        FrameScene {
            t,
            camera: FrameCamera::new(&self.scene.camera, t, &look),
            scene: program.scene,
            interior,
            objects,
            medium: Medium::of_material(&self.scene.medium),
            sky: DVec3::from_array(self.scene.sky),
            features: self.features,
        }
    }
}

/// The scene IR with `min |d_i|` over the visible objects (and its argmin) as the scene root:
/// inside an object its distance is negative, and the nearest surface is where `|d|` is small.
fn interior_ir(ir: &SceneIr) -> SceneIr {
    let mut out = ir.clone();
    let g = &mut out.graph;
    let (mut distance, mut nearest) = (
        g.intern(Node::Const(K::new(f64::INFINITY))),
        g.intern(Node::Const(K::new(-1.0))),
    );
    for (i, o) in ir.objects.iter().enumerate() {
        if o.material.is_air() {
            continue;
        }
        let d = g.intern(Node::Un(Un::Abs, o.distance));
        let m = g.intern(Node::MinId(distance, nearest, d, K::new(i as f64)));
        distance = g.intern(Node::Proj(m, 0));
        nearest = g.intern(Node::Proj(m, 1));
    }
    out.distance = distance;
    out.nearest = nearest;
    out
}

impl FrameScene {
    /// Whether `p` is strictly inside object `i` (by more than `eps`).
    pub fn contains(&self, i: usize, p: DVec4, eps: f64) -> bool {
        let mut regs = crate::vm::Regs::<f32, 1>::new(&self.objects[i].distance);
        let d = crate::vm::eval_point(
            &self.objects[i].distance,
            &mut regs,
            p.as_vec4().to_array(),
            [0.0; 4],
            self.t as f32,
        );
        (d[0] as f64) < -eps
    }
}
