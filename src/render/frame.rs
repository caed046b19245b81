//! What the renderer takes from the compile stage: the shot's settings and, per frame, the
//! tapes with that frame's `t` folded in, the cells, the camera, each object's material
//! layout, the lights, the media and which features the scene uses. Nothing here reads the
//! scene or its IR: the compile stage (`compile::Frames`) builds these.

use super::camera::FrameCamera;
use super::integrator::Stack;
use super::lights::Lights;
use super::march::{Field, Limits, MarcherKind};
use super::material::{Layout, Medium, Surface};
use super::probe::{Choice, Probe, Sight};
use super::shadow_cull::ShadowCull;
use crate::vm::Tape;
use crate::vm::cells::Cells;
use crate::vm::escape::Escape;
use glam::{DVec3, DVec4};

/// One object's tapes for one frame.
#[doc(hidden)]
pub struct FrameObject {
    /// The object's own signed distance: its normal, and whether a point is inside it.
    pub distance: Tape,
    /// Outputs: the material selector, then every leaf material's parameters at the point.
    pub material: Tape,
    /// Where each leaf's parameters sit among `material`'s outputs.
    pub layout: Layout,
    /// The surface at every point, where `material` reads neither the point nor the normal
    /// (most materials): computed once, instead of running the tape at each hit.
    pub uniform: Option<Surface>,
}

impl FrameObject {
    /// The object's tapes and layout, with its surface where it is the same everywhere.
    pub fn new(distance: Tape, material: Tape, layout: Layout, t: f64) -> FrameObject {
        let mut o = FrameObject {
            distance,
            material,
            layout,
            uniform: None,
        };
        if o.material.inputs.is_empty() {
            o.uniform = Some(o.surface_at(DVec4::ZERO, DVec4::W, t));
        }
        o
    }

    /// The surface at `p`, with unit normal `n`, at animation time `t`: the material tape at
    /// one point.
    pub fn surface_at(&self, p: DVec4, n: DVec4, t: f64) -> Surface {
        let mut regs = crate::vm::Regs::<f32, 1>::new(&self.material);
        let (p, n) = (p.as_vec4().to_array(), n.as_vec4().to_array());
        let out = crate::vm::eval_point(&self.material, &mut regs, p, n, t as f32);
        self.layout.surface(&out)
    }

    /// The object's signed distance at `p`, at animation time `t` (one point on its tape).
    pub fn distance_at(&self, p: DVec4, t: f64) -> f64 {
        let mut regs = crate::vm::Regs::<f32, 1>::new(&self.distance);
        let at = p.as_vec4().to_array();
        crate::vm::eval_point(&self.distance, &mut regs, at, [0.0; 4], t as f32)[0] as f64
    }
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
    #[doc(hidden)]
    pub scene: Tape,
    /// Outputs: unsigned distance to the nearest surface (`min |d_i|`), and its object, for
    /// rays inside objects; `None` when no object can be entered.
    #[doc(hidden)]
    pub interior: Option<Tape>,
    /// Every object, indexed as the scene lists them.
    #[doc(hidden)]
    pub objects: Vec<FrameObject>,
    /// The medium filling the world outside objects (vacuum unless the scene sets `air` or a fog).
    pub medium: Medium,
    /// Radiance of rays that leave the scene.
    pub sky: DVec3,
    /// What the scene uses, so unused features cost nothing.
    pub features: Features,
    /// The spherical emitters of this frame, for next-event estimation.
    pub lights: Lights,
    /// For each of `lights`, the scene tape without that light, which shadow rays towards
    /// it march up to its ball; empty where the frame marches through cells (whose tapes
    /// meet spheres exactly), where every ray meets the scene's exact pieces
    /// (`Escape::pieces`), or under `--marcher plain` (the baseline takes no shortcut).
    #[doc(hidden)]
    pub unlit: Vec<Tape>,
    /// For each of `lights`, where every ray meets the scene's exact pieces (and not under
    /// `--marcher plain`), the pieces its shadow rays meet up to its ball from inside every
    /// region left out (`ShadowCull::holds`); empty elsewhere.
    #[doc(hidden)]
    pub shadow_culls: Vec<ShadowCull>,
    /// The scene and interior tapes pruned to regions of space: what rays march through
    /// (none for the plain marcher, which marches the whole tapes).
    #[doc(hidden)]
    pub cells: Option<Cells>,
    /// What proves that a ray has left every object.
    #[doc(hidden)]
    pub escape: Escape,
    /// Whether rays over-relax their steps (every marcher but the plain one, and `auto` where
    /// its probe finds plain steps cheaper).
    pub relax: bool,
    /// What the probe that chose the marcher found (`MarcherKind::Auto` only, where not every
    /// ray meets the scene's exact pieces).
    #[doc(hidden)]
    pub probe: Option<Probe>,
}

/// Every setting of the render the scene makes: the image, its samples and frames, the
/// random streams' seed, the bounces and the marching limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shot {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Frames of the animation.
    pub frames: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Most scattering events of one path.
    pub bounces: u32,
    /// Seeds every sample's random stream (with the frame, pixel and sample index).
    pub seed: u64,
    /// Marching epsilon and step limit.
    pub limits: Limits,
    /// Worker threads the scene asks for; `None` for every core.
    pub threads: Option<usize>,
}

/// How a frame is built: the render's choices that are not the scene's.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Build {
    /// How its rays are marched, so cells are built only for a marcher that uses them.
    pub marcher: MarcherKind,
    /// Every feature's code path, even where the scene does not need it.
    pub general: bool,
}

impl Build {
    /// A frame for `marcher`, with only the features the scene uses.
    pub fn marcher(marcher: MarcherKind) -> Build {
        Build {
            marcher,
            general: false,
        }
    }
}

/// What the compile stage hands the renderer: the shot's settings, and each frame, built on
/// demand from any thread (the renderer prepares a group of frames in parallel).
pub trait FrameSource: Sync {
    /// The render's settings.
    fn shot(&self) -> &Shot;
    /// Frame `frame` (0-based), built as `build` asks.
    fn frame(&self, frame: u32, build: Build) -> FrameScene;
}

impl FrameScene {
    /// Under [`MarcherKind::Auto`]: probe the frame's rays and give it cells (`cells` builds
    /// them) only where marching them pays (`render::probe`), and drop the relaxation where
    /// plain steps cost less, keeping what the probe found. Cells are not built where the
    /// probe's whole-tape stage alone rules them out: building them was most of a small
    /// frame's set-up.
    pub fn choose_marcher(&mut self, shot: &Shot, cells: impl FnOnce() -> Cells) {
        let inside =
            self.interior.is_some() && !Stack::at_camera(self, shot.limits.epsilon).is_empty();
        let sight = Sight {
            camera: &self.camera,
            objects: &self.objects,
            size: (shot.width, shot.height),
            spp: shot.spp,
            limits: shot.limits,
            inside,
        };
        let probe = match Probe::whole(self.field(), sight) {
            Ok(probe) => probe,
            Err(first) => {
                let cells = Some(cells());
                let field = Field {
                    cells: cells.as_ref(),
                    ..self.field()
                };
                let probe = Probe::through(field, sight, first);
                if probe.cells_pay() {
                    self.cells = cells;
                }
                probe
            }
        };
        if probe.choice() == Choice::PlainSteps {
            self.relax = false;
        }
        self.probe = Some(probe);
    }
}

impl FrameScene {
    /// What the frame's rays march through.
    #[doc(hidden)]
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
        self.objects[i].distance_at(p, self.t) < -eps
    }
}
