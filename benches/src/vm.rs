//! The project VM's slot in the benchmark: compile a `.4ds` source through the whole pipeline
//! (check, lower, optimise, emit), then evaluate the scene tape over slices of points (batched,
//! 64 lanes) or at one point (the same interpreter with one lane).

use hyperslice::Compilation;
use hyperslice::vm::{self, LANES, Regs, Tape};

pub struct VmScene {
    tape: Tape,
    batch: Regs<f32, LANES>,
    one: Regs<f32, 1>,
}

impl VmScene {
    /// Compiles a scene; panics with the diagnostics if it fails.
    pub fn compile(source: &str) -> VmScene {
        let c = Compilation::from_source("bench.4ds", source);
        let Some(scene) = c.scene.as_ref().filter(|_| !c.has_errors()) else {
            panic!("{}", c.render_diagnostics(false));
        };
        // The scene tape with `t` folded in, as the renderer runs it per frame.
        let tape = hyperslice::compile::Compiled::new(scene)
            .program(Some(0.0))
            .scene;
        VmScene {
            batch: Regs::new(&tape),
            one: Regs::new(&tape),
            tape,
        }
    }

    /// The distance at every point (`out[i]` for `(xs[i], ys[i], zs[i], ws[i])`).
    pub fn eval_batch(&mut self, xs: &[f32], ys: &[f32], zs: &[f32], ws: &[f32], out: &mut [f32]) {
        vm::eval_slices(&self.tape, &mut self.batch, [xs, ys, zs, ws], 0.0, out);
    }

    pub fn eval_point(&mut self, p: [f32; 4]) -> f32 {
        vm::eval_point(&self.tape, &mut self.one, p, [0.0; 4], 0.0)[0]
    }

    /// Instructions and registers of the tape, for the report.
    pub fn size(&self) -> (usize, usize) {
        (self.tape.code.len(), self.tape.regs)
    }
}
