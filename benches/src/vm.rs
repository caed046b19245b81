//! The project VM's slot in the benchmark: compile a `.4ds` source through the whole pipeline
//! (check, lower, optimise, emit), then evaluate the scene tape over slices of points (batched,
//! 64 lanes) or at one point (the same interpreter with one lane), or each point on the tape of
//! its cell, as the marcher does (`VmCells`).

use glam::DVec4;
use hyperslice::Compilation;
use hyperslice::compile::{Compiled, Frames};
use hyperslice::render::frame::{Build, FrameScene};
use hyperslice::render::march::MarcherKind;
use hyperslice::scene::Scene;
use hyperslice::vm::{self, LANES, Regs, Tape};

pub struct VmScene {
    tape: Tape,
    batch: Regs<f32, LANES>,
    one: Regs<f32, 1>,
}

impl VmScene {
    /// Compiles a scene; panics with the diagnostics if it fails.
    pub fn compile(source: &str) -> VmScene {
        let scene = checked(source);
        // The scene tape with `t` folded in, as the renderer runs it per frame.
        let tape = Compiled::new(&scene).program(Some(0.0)).scene;
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

/// The checked scene of a source; panics with the diagnostics if it has errors.
fn checked(source: &str) -> Scene {
    let c = Compilation::from_source("bench.4ds", source);
    match c.scene {
        Some(scene) if !c.has_errors() => scene,
        _ => panic!("{}", c.render_diagnostics(false)),
    }
}

/// The scene's first frame as the renderer marches it: each point is evaluated on the pruned
/// tape of the cell that holds it (`vm::cells`), runs of points in one cell together, 64 lanes
/// at a time. Cells are built when a point first reaches them (in the warm-up run). A cell's
/// tape is exact where the distance is below its reach, a lower bound of at least the reach
/// elsewhere; outside the cells' cube, the distance is also cut to the cube (`Cells::gap`).
pub struct VmCells {
    frame: FrameScene,
    batch: Regs<f32, LANES>,
    /// Below this, each point of the last run has the exact distance.
    pub reach: Vec<f32>,
}

impl VmCells {
    pub fn compile(source: &str) -> VmCells {
        let scene = checked(source);
        let frames = Frames::new(&scene);
        let frame = frames.at(0.0, Build::marcher(MarcherKind::Cells));
        VmCells {
            batch: Regs::new(&frame.scene),
            frame,
            reach: vec![],
        }
    }

    pub fn eval(&mut self, pts: &crate::workload::Points, out: &mut [f32]) {
        let cells = (self.frame.cells.as_ref()).expect("a frame built with cells");
        self.reach.resize(pts.len(), 0.0);
        let mut path = cells.path();
        let mut i = 0;
        while i < pts.len() {
            let at = |k: usize| DVec4::from_array(pts.get(k).map(f64::from));
            let cell = cells.locate(&mut path, at(i));
            // The run of points in this cell, up to one batch.
            let mut end = i + 1;
            while end < pts.len() && end - i < LANES && cell.contains(at(end)) {
                end += 1;
            }
            self.batch.fit(&cell.scene);
            for (lane, k) in (i..end).enumerate() {
                let local = (at(k) - cell.origin).as_vec4();
                for axis in 0..4 {
                    self.batch.input(axis)[lane] = local[axis];
                }
            }
            vm::run(&cell.scene, &mut self.batch);
            let d = self.batch.get(cell.scene.outputs[0]);
            for (lane, k) in (i..end).enumerate() {
                (out[k], self.reach[k]) = if cells.is_outside(cell) {
                    (d[lane].min(cells.gap(at(k)) as f32), 0.0)
                } else {
                    (d[lane], cell.reach as f32)
                };
            }
            i = end;
        }
    }
}
