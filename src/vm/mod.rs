//! The bytecode VM: tapes compiled from the optimised IR, run over packets of points.
//!
//! `Program` holds every tape one frame renders with: the scene (distance and nearest object),
//! the interior (for rays inside objects), each object's distance, and each object's material
//! map (selector, then every parameter). `compile` builds it.

pub mod cells;
pub mod escape;
pub mod exec;
pub mod grad;
mod print;
pub mod tape;

pub use exec::{Regs, run};
pub use grad::Dual;
pub use tape::{Instr, Tape};

use crate::ir::{SceneIr, Var};

/// Lanes per packet on the fast path.
pub const LANES: usize = 64;

#[derive(Clone, Debug)]
pub struct ObjectTapes {
    pub name: String,
    pub distance: Tape,
    /// Outputs: the selector, then each leaf's parameters in order.
    pub material: Tape,
}

#[derive(Clone, Debug)]
pub struct Program {
    /// The optimised IR the tapes were compiled from.
    pub ir: SceneIr,
    /// Outputs: distance to the nearest visible object, and its index (-1 for none).
    pub scene: Tape,
    /// Outputs: unsigned distance to the nearest surface (`min |d_i|`) and its object, for rays
    /// inside objects; `None` when no object can be entered.
    pub interior: Option<Tape>,
    pub objects: Vec<ObjectTapes>,
}

impl Program {
    pub fn tapes(&self) -> impl Iterator<Item = &Tape> {
        std::iter::once(&self.scene)
            .chain(&self.interior)
            .chain(self.objects.iter().flat_map(|o| [&o.distance, &o.material]))
    }
}

/// Evaluate a tape at one point (the `N = 1` path of the same interpreter); returns every
/// output.
pub fn eval_point(
    tape: &Tape,
    regs: &mut Regs<f32, 1>,
    p: [f32; 4],
    n: [f32; 4],
    t: f32,
) -> Vec<f32> {
    regs.fit(tape);
    regs.set_point(0, p, n);
    regs.set_time(t);
    run(tape, regs);
    tape.outputs.iter().map(|o| regs.get(*o)[0]).collect()
}

/// Evaluate output 0 of a tape over points in structure-of-arrays form, `LANES` at a time.
pub fn eval_slices(
    tape: &Tape,
    regs: &mut Regs<f32, LANES>,
    p: [&[f32]; 4],
    t: f32,
    out: &mut [f32],
) {
    regs.fit(tape);
    regs.set_time(t);
    let n = out.len();
    let mut start = 0;
    while start < n {
        let len = LANES.min(n - start);
        for (axis, xs) in p.iter().enumerate() {
            let lanes = regs.input(Var::POINT[axis].index());
            lanes[..len].copy_from_slice(&xs[start..start + len]);
        }
        run(tape, regs);
        out[start..start + len].copy_from_slice(&regs.get(tape.outputs[0])[..len]);
        start += len;
    }
}

/// Value and gradient (with respect to the point) of output 0 of a tape at each of up to `N`
/// points, in one forward-mode pass.
pub fn gradient<const N: usize>(
    tape: &Tape,
    regs: &mut Regs<Dual, N>,
    p: &[[f32; 4]],
    t: f32,
) -> Vec<Dual> {
    regs.fit(tape);
    for (lane, q) in p.iter().enumerate() {
        for (axis, x) in q.iter().enumerate() {
            regs.input(Var::POINT[axis].index())[lane] = Dual::var(*x, axis);
        }
        regs.input(Var::T.index())[lane] = Dual { v: t, g: [0.0; 4] };
    }
    run(tape, regs);
    regs.get(tape.outputs[0])[..p.len()].to_vec()
}
