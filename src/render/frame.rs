//! Everything the integrator needs for one frame: the tapes with that frame's `t` folded in,
//! the camera, each object's material layout, and which features the scene uses.

use super::camera::FrameCamera;
use super::lights::{Lights, SphereLight};
use super::march::{Field, Limits, MarcherKind};
use super::material::{Layout, Medium, Surface};
use super::probe::Probe;
use crate::compile::{Compiled, LightPlacement};
use crate::ir::SceneIr;
use crate::scene::Scene;
use crate::vm::Tape;
use crate::vm::cells::{Cells, Roots};
use crate::vm::escape::Escape;
use glam::{DVec3, DVec4};

/// One object's tapes for one frame.
pub struct FrameObject {
    /// The object's own signed distance: its normal, and whether a point is inside it.
    pub distance: Tape,
    /// Outputs: the material selector, then every leaf material's parameters at the point.
    pub material: Tape,
    /// Where each leaf's parameters sit among `material`'s outputs.
    pub layout: Layout,
}

/// What a scene uses, so the renderer pays only for those features.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Features {
    /// Some object can be entered (glass, fog or air in its material): rays may travel inside
    /// objects, which needs the interior tape and a medium stack.
    pub interiors: bool,
}

/// Everything the integrator reads to render one frame.
pub struct FrameScene {
    /// The animation time of the frame: 0 on the first, 1 on the last.
    pub t: f64,
    /// The camera, moved and turned to this frame.
    pub camera: FrameCamera,
    /// Outputs: signed distance to the nearest visible object, and its index.
    pub scene: Tape,
    /// Outputs: unsigned distance to the nearest surface (`min |d_i|`), and its object, for
    /// rays inside objects; `None` when no object can be entered.
    pub interior: Option<Tape>,
    /// Every object, indexed as the scene lists them.
    pub objects: Vec<FrameObject>,
    /// The medium filling the world outside objects (vacuum unless the scene sets `air` or a fog).
    pub medium: Medium,
    /// Radiance of rays that leave the scene.
    pub sky: DVec3,
    /// What the scene uses, so unused features cost nothing.
    pub features: Features,
    /// The spherical emitters of this frame, for next-event estimation.
    pub lights: Lights,
    /// The scene and interior tapes pruned to regions of space: what rays march through
    /// (none for the plain marcher, which marches the whole tapes).
    pub cells: Option<Cells>,
    /// What proves that a ray has left every object.
    pub escape: Escape,
    /// Whether rays over-relax their steps (every marcher but the plain one).
    pub relax: bool,
    /// What the probe that chose the marcher found (`MarcherKind::Auto` only).
    pub probe: Option<Probe>,
}

impl FrameScene {
    /// The frame at animation time `t`: its compiled program, camera, media and lights, for
    /// the cells' marcher.
    pub fn new(scene: &Scene, compiled: &Compiled, features: Features, t: f64) -> FrameScene {
        FrameScene::for_marcher(scene, compiled, features, t, MarcherKind::Cells)
    }

    /// The frame at `t`, with cells only where `marcher` marches through them (for `Auto`,
    /// where the frame's probe shows that they pay: `render::probe`).
    pub fn for_marcher(
        scene: &Scene,
        compiled: &Compiled,
        features: Features,
        t: f64,
        marcher: MarcherKind,
    ) -> FrameScene {
        let frame = compiled.frame(t);
        let program = frame.program;
        let objects: Vec<FrameObject> = (program.objects.into_iter())
            .zip(&program.ir.objects)
            .map(|(o, ir)| FrameObject {
                distance: o.distance,
                material: o.material,
                layout: Layout::new(&ir.material.leaves),
            })
            .collect();
        let lights = (frame.lights.iter())
            .filter_map(|l| sphere_light(l, &objects[l.object], t))
            .collect();
        let camera = FrameCamera::new(&scene.camera, t, &frame.look);
        let (cells, escape) = cells(
            &program.ir,
            &compiled.bounds,
            (camera.position, t),
            scene.render.epsilon,
            marcher,
        );
        let mut fs = FrameScene {
            t,
            camera,
            cells,
            escape,
            scene: program.scene,
            interior: program.interior,
            lights: Lights::new(lights, objects.len()),
            objects,
            medium: Medium::of_material(&scene.medium),
            sky: DVec3::from_array(scene.sky),
            features,
            relax: marcher != MarcherKind::Plain,
            probe: None,
        };
        if marcher == MarcherKind::Auto {
            let r = &scene.render;
            let probe = Probe::run(
                fs.field(),
                &fs.camera,
                &fs.objects,
                (r.width, r.height),
                Limits::of(r),
            );
            if !probe.cells_pay() {
                fs.cells = None;
            }
            fs.probe = Some(probe);
        }
        fs
    }
}

/// The cells of a frame (for the cells' marcher): a cube around the camera and every bounded
/// object, twice their extent, so rays near them and on the ground between them use pruned
/// tapes; and the proof of escape from the box of the bounded objects.
fn cells(
    ir: &SceneIr,
    bounds: &[Option<([f64; 4], f64)>],
    (camera, t): (DVec4, f64),
    epsilon: f64,
    marcher: MarcherKind,
) -> (Option<Cells>, Escape) {
    let (mut lo, mut hi) = (camera, camera);
    let mut unbounded = vec![];
    for (i, (o, b)) in ir.objects.iter().zip(bounds).enumerate() {
        if o.material.is_air() {
            continue;
        }
        match b {
            Some((c, r)) if r.is_finite() && c.iter().all(|x| x.is_finite()) => {
                let c = DVec4::from_array(*c);
                lo = lo.min(c - DVec4::splat(*r));
                hi = hi.max(c + DVec4::splat(*r));
            }
            _ => unbounded.push((i, o.distance)),
        }
    }
    let distances: Vec<_> = unbounded.iter().map(|u| u.1).collect();
    let scene = (ir.distance, ir.nearest);
    let escape = Escape::new(&ir.graph, (lo, hi), &distances, (scene, ir.interior), t);
    if matches!(marcher, MarcherKind::Plain | MarcherKind::Whole) {
        return (None, escape);
    }
    let roots = Roots {
        scene: (ir.distance, ir.nearest),
        interior: ir.interior,
        objects: ir.objects.iter().map(|o| o.distance).collect(),
    };
    let size = 2.0 * (hi - lo).max_element().max(1.0);
    let corner = (lo + hi) / 2.0 - DVec4::splat(size / 2.0);
    let cube = (corner, size);
    let cells = Cells::new(&ir.graph, roots, cube, &unbounded, epsilon);
    (Some(cells), escape)
}

impl Features {
    /// What the compiled scene uses.
    pub fn of(compiled: &Compiled) -> Features {
        Features {
            interiors: compiled.ir.interior.is_some(),
        }
    }
}

/// A placed light with its radiance, read from its material tape (it is constant over the
/// surface); `None` if that material is not a light at this frame.
fn sphere_light(l: &LightPlacement, o: &FrameObject, t: f64) -> Option<SphereLight> {
    let center = DVec4::from_array(l.center);
    let mut regs = crate::vm::Regs::<f32, 1>::new(&o.material);
    let p = center + DVec4::X * l.radius;
    let out = crate::vm::eval_point(
        &o.material,
        &mut regs,
        p.as_vec4().to_array(),
        [1.0, 0.0, 0.0, 0.0],
        t as f32,
    );
    match o.layout.surface(&out) {
        Surface::Light { radiance } => Some(SphereLight {
            center,
            radius: l.radius,
            radiance,
            object: l.object as u32,
        }),
        _ => None,
    }
}

impl FrameScene {
    /// What the frame's rays march through.
    pub fn field(&self) -> Field<'_> {
        Field {
            cells: self.cells.as_ref(),
            relax: self.relax,
            scene: &self.scene,
            interior: self.interior.as_ref(),
            escape: &self.escape,
        }
    }

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
