//! Everything that evaluates a scene over a point set, behind one small interface so the harness
//! times them all the same way.

use crate::fidget_eval::FidgetEval;
use crate::native;
use crate::scenes::Scene;
use crate::vm::{VmCells, VmScene};
use crate::workload::Points;
use fidget::eval::MathFunction;

pub trait Contender {
    fn name(&self) -> &'static str;
    /// Writes the scene distance at every point into `out` (`out.len() == pts.len()`).
    fn run(&mut self, pts: &Points, out: &mut [f32]);
    /// Nearest-object ids from the last run, for contenders that compute them.
    fn ids(&self) -> Option<&[f32]> {
        None
    }
    /// For contenders that give a lower bound where the distance is large (pruned cells): the
    /// value at each point of the last run below which theirs is exact.
    fn reach(&self) -> Option<&[f32]> {
        None
    }
}

/// Native scalar or packet code; computes ids too for multi-object scenes.
pub struct Native<'a, S> {
    scene: &'a S,
    packet: bool,
    ids: Vec<f32>,
}

impl<'a, S: Scene> Native<'a, S> {
    pub fn scalar(scene: &'a S) -> Self {
        Native {
            scene,
            packet: false,
            ids: Vec::new(),
        }
    }
    pub fn packet(scene: &'a S) -> Self {
        Native {
            scene,
            packet: true,
            ids: Vec::new(),
        }
    }
}

impl<S: Scene> Contender for Native<'_, S> {
    fn name(&self) -> &'static str {
        if self.packet {
            "native packet [f32;8]"
        } else {
            "native scalar"
        }
    }
    fn run(&mut self, pts: &Points, out: &mut [f32]) {
        self.ids.resize(if S::MULTI { pts.len() } else { 0 }, 0.0);
        let eval = if self.packet {
            native::eval_packet::<S>
        } else {
            native::eval_scalar::<S>
        };
        eval(self.scene, pts, out, &mut self.ids);
    }
    fn ids(&self) -> Option<&[f32]> {
        S::MULTI.then_some(&self.ids[..])
    }
}

pub struct Fidget<F: MathFunction> {
    name: &'static str,
    eval: FidgetEval<F>,
}

impl<F: MathFunction> Fidget<F> {
    pub fn new<S: Scene>(name: &'static str, scene: &S, chunk: usize) -> Self {
        Fidget {
            name,
            eval: FidgetEval::new(scene, chunk),
        }
    }
    pub fn tape_len(&self) -> usize {
        self.eval.tape_len
    }
}

impl<F: MathFunction> Contender for Fidget<F> {
    fn name(&self) -> &'static str {
        self.name
    }
    fn run(&mut self, pts: &Points, out: &mut [f32]) {
        self.eval.eval(pts, out);
    }
}

/// The project VM, over whole slices or one point per call.
pub struct Vm {
    scene: VmScene,
    batched: bool,
}

impl Vm {
    pub fn batched(source: &str) -> Self {
        Vm {
            scene: VmScene::compile(source),
            batched: true,
        }
    }
    pub fn point(source: &str) -> Self {
        Vm {
            scene: VmScene::compile(source),
            batched: false,
        }
    }
    /// (instructions, registers) of the VM's scene tape.
    pub fn tape_size(&self) -> (usize, usize) {
        self.scene.size()
    }
}

impl Contender for Vm {
    fn name(&self) -> &'static str {
        if self.batched {
            "VM batched"
        } else {
            "VM point"
        }
    }
    fn run(&mut self, pts: &Points, out: &mut [f32]) {
        if self.batched {
            self.scene
                .eval_batch(&pts.xs, &pts.ys, &pts.zs, &pts.ws, out);
        } else {
            for (i, o) in out.iter_mut().enumerate() {
                *o = self.scene.eval_point(pts.get(i));
            }
        }
    }
}

/// The project VM on each point's pruned cell tape, as the marcher runs it.
pub struct Cells(pub VmCells);

impl Contender for Cells {
    fn name(&self) -> &'static str {
        "VM pruned cells"
    }
    fn run(&mut self, pts: &Points, out: &mut [f32]) {
        self.0.eval(pts, out);
    }
    fn reach(&self) -> Option<&[f32]> {
        Some(&self.0.reach)
    }
}
