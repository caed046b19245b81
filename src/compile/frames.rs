//! What the compile stage hands the renderer: a scene's every frame, built on demand from any
//! thread. [`Frames`] holds the lowered IR, the bounds and the scene's plain settings (it is
//! `Send + Sync`, unlike the scene, whose fields share subtrees), and builds each frame's
//! tapes, cells, camera, material layouts, lights and media: the renderer reads nothing else.

use super::{Compiled, LightPlacement, frame_time};
use crate::ir::Id;
use crate::ir::SceneIr;
use crate::ir::lower::{Leaf, nearest, visible};
use crate::material::{Material, Slot};
use crate::render::camera::FrameCamera;
use crate::render::frame::{Build, Features, FrameObject, FrameScene, FrameSource, Shot};
use crate::render::lights::{Lights, Side, SphereLight};
use crate::render::march::{Limits, MarcherKind};
use crate::render::material::{Layout, Medium, Surface};
use crate::render::shadow_cull::ShadowCull;
use crate::scene::{Param, Scene};
use crate::vm::Tape;
use crate::vm::cells::{Cells, Placed, Roots, epsilon_at};
use crate::vm::escape::{Escape, proven_box};
use glam::{DVec3, DVec4};

/// A scene compiled for rendering: what every frame is built from.
#[derive(Clone, Debug)]
pub struct Frames {
    /// The scene lowered to IR, and its objects' bounds.
    pub compiled: Compiled,
    /// The render's settings.
    pub shot: Shot,
    /// The camera's position on the first and the last frame.
    from_to: (DVec4, DVec4),
    /// Horizontal field of view in radians.
    fov: f64,
    /// The medium filling the world outside objects.
    medium: Medium,
    /// Radiance of rays that leave the scene.
    sky: DVec3,
}

impl Frames {
    /// Lower `scene` once, and keep what its frames are built from.
    pub fn new(scene: &Scene) -> Frames {
        let r = &scene.render;
        Frames {
            compiled: Compiled::new(scene),
            shot: Shot {
                width: r.width,
                height: r.height,
                frames: r.frames,
                spp: r.spp,
                bounces: r.bounces,
                seed: r.seed,
                limits: Limits {
                    epsilon: r.epsilon,
                    max_steps: r.max_steps,
                },
                threads: r.threads(),
            },
            from_to: (
                DVec4::from_array(scene.camera.from),
                DVec4::from_array(scene.camera.to),
            ),
            fov: scene.camera.fov,
            medium: medium(&scene.medium),
            sky: DVec3::from_array(scene.sky),
        }
    }

    /// The frame at animation time `t` (0 on the first frame, 1 on the last): its tapes with
    /// `t` folded in, its camera, media and lights, and cells where `build`'s marcher marches
    /// through them (for `Auto`, where the frame's probe shows that they pay).
    pub fn at(&self, t: f64, build: Build) -> FrameScene {
        let compiled = &self.compiled;
        let frame = compiled.frame(t);
        let program = frame.program;
        let objects: Vec<FrameObject> = (program.objects.into_iter())
            .zip(&program.ir.objects)
            .map(|(o, ir)| FrameObject::new(o.distance, o.material, layout(&ir.material.leaves), t))
            .collect();
        let lights = (frame.lights.iter())
            .filter_map(|l| sphere_light(l, &objects[l.object], t))
            .collect();
        let (from, to) = self.from_to;
        let camera = FrameCamera::new(from + (to - from) * t, self.fov, &frame.look);
        let (escape, plan) = regions(
            &program.ir,
            &compiled.bounds,
            &compiled.tiled,
            (camera.position, t),
            (
                self.shot.limits.epsilon,
                build.marcher != MarcherKind::Plain,
            ),
        );
        let cells = (build.marcher == MarcherKind::Cells).then(|| plan.build(&program.ir));
        let features = Features {
            interiors: build.general || compiled.ir.interior.is_some(),
        };
        let mut fs = FrameScene {
            t,
            camera,
            cells,
            escape,
            scene: program.scene,
            interior: program.interior,
            lights: sides(
                Lights::new(lights, objects.len()),
                (&objects, &program.ir),
                t,
                self.shot.limits.epsilon,
            ),
            unlit: vec![],
            shadow_culls: vec![],
            objects,
            medium: self.medium,
            sky: self.sky,
            features,
            relax: build.marcher != MarcherKind::Plain,
            probe: None,
        };
        // Where every ray meets the scene's few exact pieces once, cells would only meet the
        // same pieces (and shadow rays meet them up to their light's ball, `ShadowCull`).
        let exact = fs.escape.meets_every_ray();
        if build.marcher == MarcherKind::Auto && !exact {
            fs.choose_marcher(&self.shot, || plan.build(&program.ir));
        }
        if fs.cells.is_none() && build.marcher != MarcherKind::Plain && !exact {
            fs.unlit = unlit(&program.ir, fs.lights.lights());
        }
        // As the frame's rays meet them: off the cells, and not by the plain marcher.
        let eps = self.shot.limits.epsilon;
        let culls = (fs.field().pieces(false))
            .filter(|_| build.marcher != MarcherKind::Plain)
            .map(|pieces| {
                (fs.lights.lights().iter())
                    .map(|l| ShadowCull::of(pieces, l, eps))
                    .collect()
            });
        fs.shadow_culls = culls.unwrap_or_default();
        fs
    }
}

impl FrameSource for Frames {
    fn shot(&self) -> &Shot {
        &self.shot
    }

    fn frame(&self, frame: u32, build: Build) -> FrameScene {
        self.at(frame_time(frame, self.shot.frames), build)
    }
}

/// `lights` with each light's side of each object's surface marked (`Lights::mark_sides`):
/// outside or inside where the object's distance at the light's centre is beyond its radius
/// by more than the `f32` rounding there. Air stops no shadow ray: it is never marked.
fn sides(
    mut lights: Lights,
    (objects, ir): (&[FrameObject], &SceneIr),
    t: f64,
    eps: f64,
) -> Lights {
    lights.mark_sides(|l, o| {
        if o == l.object as usize || ir.objects[o].material.is_air() {
            return Side::Across;
        }
        let d = objects[o].distance_at(l.center, t);
        let beyond = l.radius + 4.0 * epsilon_at(l.center, eps);
        if d > beyond {
            Side::Outside
        } else if d < -beyond {
            Side::Inside
        } else {
            Side::Across
        }
    });
    lights
}

/// For each light, the scene's distance and nearest object without it (`FrameScene::unlit`).
/// Each light's running min goes into one copy of the frame's graph; a tape compiles only
/// the nodes its roots reach.
fn unlit(ir: &SceneIr, lights: &[SphereLight]) -> Vec<Tape> {
    let mut g = ir.graph.clone();
    (lights.iter())
        .map(|l| {
            let ds: Vec<(usize, Id)> = (visible(&ir.objects))
                .filter(|&(i, _)| i != l.object as usize)
                .collect();
            let (d, n) = nearest(&mut g, &ds);
            Tape::compile("unlit", &g, &[d, n])
        })
        .collect()
}

/// The layout of a material tape whose outputs are the selector, then `leaves`' parameters in
/// order: each number's output, and each colour's first of three, with the builtin table's
/// default that stands in for a non-finite value.
fn layout(leaves: &[Leaf]) -> Layout {
    let mut at = 1; // output 0 is the selector
    let mut next = |n: usize| {
        at += n;
        at - n
    };
    let leaves: Vec<Material<_, _>> = (leaves.iter())
        .map(|l| {
            l.map(|spec, p| match p {
                Slot::Num(_) => Slot::Num((next(1), spec.default.num())),
                Slot::Color(_) => Slot::Color((next(3), spec.default.num())),
            })
        })
        .collect();
    Layout::new(leaves)
}

/// The scene's global medium (`air` or a constant `fog`).
fn medium(m: &crate::scene::Material) -> Medium {
    match m {
        Material::Fog {
            extinction: Param::Const(sigma_t),
            albedo: Param::Const(albedo),
            anisotropy: Param::Const(g),
        } => Medium {
            sigma_t: *sigma_t,
            albedo: DVec3::from_array(*albedo),
            g: *g,
        },
        _ => Medium::VACUUM,
    }
}

/// The cells of a frame (for the cells' marcher): a cube around the camera and every bounded
/// object but the tiled ones, twice their extent, so rays near them and on the ground between
/// them use pruned tapes; and the proof of escape from the box of the bounded objects. An
/// object is bounded by its ball (`bounds`) or, without one, by a box interval bounds prove
/// (`proven_box`: custom fields that are a few spheres). Bounded tilings (`tiled`, a grid with
/// limits) and objects bounded by intervals stay outside the cube, with the unbounded ones, as
/// the cells found them before they were bounded: around a few hundred copies far apart, the
/// cells that resolve the epsilon near each are so many that a ray passing them took more
/// than 2,000 steps, one per cell. The escape proof has the unbounded objects' covers where
/// `covers` (every marcher but the plain one, which takes no exact shortcut).
fn regions(
    ir: &SceneIr,
    bounds: &[Option<([f64; 4], f64)>],
    tiled: &[bool],
    (camera, t): (DVec4, f64),
    (epsilon, covers): (f64, bool),
) -> (Escape, CellsPlan) {
    // The bounded objects' box, and the cells' cube.
    let mut objects = (DVec4::INFINITY, DVec4::NEG_INFINITY);
    let (mut cube_lo, mut cube_hi) = (camera, camera);
    let (mut unbounded, mut wide) = (vec![], vec![]);
    for (i, (o, b)) in ir.objects.iter().zip(bounds).enumerate() {
        if o.material.is_air() {
            continue;
        }
        let ball = match b {
            Some((c, r)) if r.is_finite() && c.iter().all(|x| x.is_finite()) => {
                let c = DVec4::from_array(*c);
                Some((c - DVec4::splat(*r), c + DVec4::splat(*r)))
            }
            _ => None,
        };
        match ball.or_else(|| proven_box(&ir.graph, o.distance, t)) {
            Some((l, h)) => {
                objects = (objects.0.min(l), objects.1.max(h));
                if ball.is_some() && !tiled[i] {
                    (cube_lo, cube_hi) = (cube_lo.min(l), cube_hi.max(h));
                } else {
                    wide.push((i, o.distance));
                }
            }
            None => unbounded.push((i, o.distance)),
        }
    }
    let scene = (ir.distance, ir.nearest);
    // The escape proof's box holds the camera too.
    let around = (objects.0.min(camera), objects.1.max(camera));
    let escape = Escape::new(
        &ir.graph,
        (around, objects),
        &unbounded,
        (scene, ir.interior),
        (t, covers),
    );
    let (lo, hi) = (cube_lo, cube_hi);
    let size = 2.0 * (hi - lo).max_element().max(1.0);
    let corner = (lo + hi) / 2.0 - DVec4::splat(size / 2.0);
    let plan = CellsPlan {
        cube: (corner, size),
        unbounded,
        wide,
        epsilon,
    };
    (escape, plan)
}

/// What a frame's cells are built over (`Cells::new`): built only for a marcher that uses
/// them, and under `Auto` only where the probe's first stage cannot rule them out.
struct CellsPlan {
    cube: (DVec4, f64),
    unbounded: Vec<Placed>,
    wide: Vec<Placed>,
    epsilon: f64,
}

impl CellsPlan {
    fn build(&self, ir: &SceneIr) -> Cells {
        let roots = Roots {
            scene: (ir.distance, ir.nearest),
            interior: ir.interior,
            objects: ir.objects.iter().map(|o| o.distance).collect(),
        };
        let placed = (&self.unbounded[..], &self.wide[..]);
        Cells::new(&ir.graph, roots, self.cube, placed, self.epsilon)
    }
}

/// A placed light with its radiance, read from its material tape (it is constant over the
/// surface); `None` if that material is not a light at this frame.
fn sphere_light(l: &LightPlacement, o: &FrameObject, t: f64) -> Option<SphereLight> {
    let center = DVec4::from_array(l.center);
    match o.surface_at(center + DVec4::X * l.radius, DVec4::X, t) {
        Surface::Light { radiance } => Some(SphereLight {
            center,
            radius: l.radius,
            radiance,
            object: l.object as u32,
        }),
        _ => None,
    }
}

// The renderer builds a group of frames on its worker threads and shares each across them.
const _: fn() = || {
    fn send_sync<T: Send + Sync>() {}
    send_sync::<Frames>();
    send_sync::<FrameScene>();
};
