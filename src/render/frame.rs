//! Everything the integrator needs for one frame: the tapes with that frame's `t` folded in,
//! the camera, each object's material layout, and which features the scene uses.

use super::camera::FrameCamera;
use super::lights::{Lights, SphereLight};
use super::material::{Layout, Medium, Surface};
use crate::check::Scene;
use crate::check::types::Type;
use crate::check::value::{
    DEP_N, DEP_P, FieldOp, Fields, Material, MaterialKind, Plane, Shape, ShapeKind, Value,
};
use crate::ir::eval::Reference;
use crate::math::plane::rotate;
use crate::ir::{Graph, Id, K, Node, SceneIr, Un, Var, opt};
use crate::vm::{Program, Tape};
use glam::{DVec3, DVec4};
use std::rc::Rc;

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
    /// The spherical emitters of this frame, for next-event estimation.
    pub lights: Lights,
}

/// The scene's IR, lowered once and specialised per frame.
pub struct Prepared<'s> {
    pub scene: &'s Scene,
    ir: SceneIr,
    /// The same graph with the interior distance as its scene root.
    interior: Option<SceneIr>,
    layouts: Vec<Layout>,
    pub features: Features,
    /// The objects that are spherical lights, and how to place them at any `t`.
    lights: LightPlans,
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
        let lights = LightPlans::new(scene);
        Prepared {
            scene,
            ir,
            interior,
            layouts,
            features,
            lights,
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
        let objects: Vec<FrameObject> = (program.objects.into_iter().zip(&self.layouts))
            .map(|(o, layout)| FrameObject {
                distance: o.distance,
                material: o.material,
                layout: layout.clone(),
            })
            .collect();
        let lights = self.lights.at(t, &objects);
        FrameScene {
            t,
            camera: FrameCamera::new(&self.scene.camera, t, &look),
            scene: program.scene,
            interior,
            objects,
            medium: Medium::of_material(&self.scene.medium),
            sky: DVec3::from_array(self.scene.sky),
            features: self.features,
            lights,
        }
    }
}

/// A number known when the scene is prepared, or a function of `t` (a root of the parameter
/// graph of [`LightPlans`]).
#[derive(Clone, Copy, Debug)]
enum Scalar {
    K(f64),
    Node(Id),
}

/// One shape operation around a light's hypersphere.
#[derive(Clone, Debug)]
enum Place {
    Translate([Scalar; 4]),
    Rotate(Vec<(Plane, Scalar)>),
    Scale(Scalar),
    Round(Scalar),
}

/// How to find one spherical light at any `t`: the operations from the outermost inwards, and
/// the hypersphere's own radius.
#[derive(Clone, Debug)]
struct LightPlan {
    object: usize,
    places: Vec<Place>,
    radius: Scalar,
}

/// The spherical lights of a scene. Parameters that depend on `t` are lowered through the
/// ordinary lowering (each one as the distance of a made-up `sdf` object of a scene of its own),
/// so they mean exactly what they mean in the distance tapes, and are evaluated per frame in
/// `f64` by the reference evaluator.
struct LightPlans {
    plans: Vec<LightPlan>,
    /// The graph of the `t`-dependent parameters, if any.
    params: Option<(Graph, Vec<Id>)>,
}

/// Collects `t`-dependent parameters as made-up objects, to be lowered together.
struct ParamScene<'s> {
    scene: &'s Scene,
    fields: Fields,
    objects: Vec<crate::check::Object>,
}

impl ParamScene<'_> {
    /// A scalar parameter (number or angle), or `None` if it is not one that depends on `t`
    /// alone.
    fn scalar(&mut self, v: &Value, object: usize) -> Option<Scalar> {
        match v {
            Value::Num(x) | Value::Angle(x) => Some(Scalar::K(*x)),
            Value::Field(id, ty @ (Type::Num | Type::Angle)) => {
                self.node(Value::Field(*id, ty.clone()), object)
            }
            _ => None,
        }
    }

    fn vector(&mut self, v: &Value, object: usize) -> Option<[Scalar; 4]> {
        match v {
            Value::Vec4(x) => Some(x.map(Scalar::K)),
            Value::Field(id, Type::Vec4) => {
                let mut out = [Scalar::K(0.0); 4];
                for (k, o) in out.iter_mut().enumerate() {
                    let c = self
                        .fields
                        .push(FieldOp::Component(*id, k as u8), Type::Num);
                    *o = self.node(Value::Field(c, Type::Num), object)?;
                }
                Some(out)
            }
            _ => None,
        }
    }

    /// A scalar field of `t` as the distance of a new object; `Scalar::Node` holds its index
    /// among the new objects until the graph is built.
    fn node(&mut self, v: Value, object: usize) -> Option<Scalar> {
        if self.fields.deps(&v) & (DEP_P | DEP_N) != 0 {
            return None;
        }
        let shape = Shape {
            kind: ShapeKind::Custom,
            params: vec![("distance", v)],
            children: vec![],
            depth: 0,
        };
        self.objects.push(crate::check::Object {
            name: format!("light parameter {}", self.objects.len()),
            span: self.scene.objects[object].span,
            shape: Rc::new(shape),
            material: Value::Material(Rc::new(Material {
                kind: MaterialKind::Diffuse,
                params: vec![],
            })),
        });
        Some(Scalar::Node(Id(self.objects.len() as u32 - 1)))
    }

    /// The plan of object `i` if it is a spherical light.
    fn plan(&mut self, i: usize) -> Option<LightPlan> {
        let o = &self.scene.objects[i];
        match &o.material {
            Value::Material(m) if m.kind == MaterialKind::Light => {}
            _ => return None,
        }
        if self.scene.fields.deps(&o.material) & (DEP_P | DEP_N) != 0 {
            return None;
        }
        let mut places = vec![];
        let mut s = o.shape.clone();
        loop {
            let param = |name: &str| s.param(name).cloned();
            let place = match s.kind {
                ShapeKind::Hypersphere => {
                    let radius = self.scalar(&param("radius")?, i)?;
                    return Some(LightPlan {
                        object: i,
                        places,
                        radius,
                    });
                }
                ShapeKind::Translate => Place::Translate(self.vector(&param("offset")?, i)?),
                ShapeKind::Scale => Place::Scale(self.scalar(&param("factor")?, i)?),
                ShapeKind::Round => Place::Round(self.scalar(&param("radius")?, i)?),
                ShapeKind::Rotate => {
                    let Some(Value::Rotation(steps)) = param("rotation") else {
                        return None;
                    };
                    let steps = (steps.iter())
                        .map(|(plane, a)| Some((*plane, self.scalar(a, i)?)))
                        .collect::<Option<Vec<_>>>()?;
                    Place::Rotate(steps)
                }
                _ => return None,
            };
            places.push(place);
            let [child] = s.children.as_slice() else {
                return None;
            };
            s = child.clone();
        }
    }
}

impl LightPlans {
    fn new(scene: &Scene) -> LightPlans {
        let mut ps = ParamScene {
            scene,
            fields: scene.fields.clone(),
            objects: vec![],
        };
        let mut plans = vec![];
        for i in 0..scene.objects.len() {
            let before = (ps.objects.len(), ps.fields.nodes.len());
            match ps.plan(i) {
                Some(p) => plans.push(p),
                None => {
                    // Drop what a rejected object added.
                    ps.objects.truncate(before.0);
                    ps.fields.nodes.truncate(before.1);
                }
            }
        }
        let params = (!ps.objects.is_empty()).then(|| {
            let mut sub = scene.clone();
            sub.objects = ps.objects;
            sub.fields = ps.fields;
            let ir = crate::ir::lower(&sub);
            let roots = ir.objects.iter().map(|o| o.distance).collect();
            (ir.graph, roots)
        });
        LightPlans { plans, params }
    }

    /// The lights at time `t`; their radiance is read from each light's material tape.
    fn at(&self, t: f64, objects: &[FrameObject]) -> Lights {
        let mut values = vec![];
        if let Some((graph, roots)) = &self.params {
            let mut reference = Reference::new(graph, roots);
            let mut vars = [0.0; 9];
            vars[Var::T.index()] = t;
            reference.run(&vars);
            values = roots.iter().map(|r| reference.value(*r)).collect();
        }
        let get = |s: Scalar| match s {
            Scalar::K(x) => x,
            Scalar::Node(Id(i)) => values[i as usize],
        };
        let mut lights = vec![];
        'plans: for plan in &self.plans {
            // From the hypersphere outwards.
            let mut center = DVec4::ZERO;
            let mut radius = get(plan.radius);
            for place in plan.places.iter().rev() {
                match place {
                    Place::Translate(o) => center += DVec4::from_array(o.map(get)),
                    Place::Rotate(steps) => {
                        let steps = steps.iter().map(|&(plane, a)| (plane, get(a)));
                        center = DVec4::from_array(rotate(center.to_array(), steps));
                    }
                    Place::Scale(k) => {
                        let k = get(*k);
                        if k.is_nan() || k <= 0.0 {
                            continue 'plans;
                        }
                        center *= k;
                        radius *= k;
                    }
                    Place::Round(r) => radius += get(*r),
                }
            }
            if !(radius > 0.0 && radius.is_finite() && center.is_finite()) {
                continue;
            }
            let o = &objects[plan.object];
            let mut regs = crate::vm::Regs::<f32, 1>::new(&o.material);
            let p = center + DVec4::X * radius;
            let out = crate::vm::eval_point(
                &o.material,
                &mut regs,
                p.as_vec4().to_array(),
                [1.0, 0.0, 0.0, 0.0],
                t as f32,
            );
            if let Surface::Light { radiance } = o.layout.surface(&out) {
                lights.push(SphereLight {
                    center,
                    radius,
                    radiance,
                    object: plan.object as u32,
                });
            }
        }
        Lights::new(lights, objects.len())
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
