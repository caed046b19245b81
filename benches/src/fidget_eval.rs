//! The fidget contenders: a scene's generic formula built as a fidget expression and evaluated
//! with fidget's bulk (float-slice) evaluators, its interpreter (`VmFunction`, the function inside
//! `VmShape`) and its JIT (`JitFunction`, the function inside `JitShape`).
//!
//! fidget's shapes only know x, y and z; a fourth coordinate is a free variable (`Var::new()`),
//! and every variable, x, y and z included, is an input slot of the tape, found with
//! `tape.vars().get(&var)`. We call the raw `BulkEvaluator` with our own column slices in slot
//! order, which is what `ShapeBulkEval::eval_with_var_arrays` does after copying x, y, z and w
//! into scratch arrays; skipping that copy is the fast way. Tape and evaluator (with its
//! registers / output storage) are built once and reused for every call.

use crate::scenes::Scene;
use crate::workload::Points;
use fidget::context::{Context, Tree};
use fidget::eval::{BulkEvaluator, Function, MathFunction, Tape};
use fidget::var::Var;

type SliceTape<F> = <<F as Function>::FloatSliceEval as BulkEvaluator>::Tape;

/// The scene's distance as a fidget expression of x, y, z and a new variable w.
pub fn tree<S: Scene>(scene: &S) -> (Tree, Var) {
    let w = Var::new();
    let p = [Tree::x(), Tree::y(), Tree::z(), Tree::from(w)];
    (scene.dist(&p), w)
}

pub struct FidgetEval<F: Function> {
    tape: SliceTape<F>,
    eval: F::FloatSliceEval,
    /// Input slot of x, y, z, w (None where the expression does not use that coordinate).
    slots: [Option<usize>; 4],
    nvars: usize,
    /// Points per evaluator call.
    chunk: usize,
    /// Length of fidget's instruction tape.
    pub tape_len: usize,
}

impl<F: MathFunction> FidgetEval<F> {
    pub fn new<S: Scene>(scene: &S, chunk: usize) -> Self {
        let (tree, w) = tree(scene);
        let mut ctx = Context::new();
        let root = ctx.import(&tree);
        let f = F::new(&ctx, &[root]).expect("fidget rejected the expression");
        let tape = f.float_slice_tape(Default::default());
        let vars = tape.vars();
        let slots = [Var::X, Var::Y, Var::Z, w].map(|v| vars.get(&v));
        let nvars = vars.len();
        FidgetEval {
            tape,
            eval: F::new_float_slice_eval(),
            slots,
            nvars,
            chunk,
            tape_len: f.size(),
        }
    }

    pub fn eval(&mut self, pts: &Points, out: &mut [f32]) {
        let n = pts.len();
        let mut start = 0;
        while start < n {
            let end = (start + self.chunk).min(n);
            let cols = [&pts.xs, &pts.ys, &pts.zs, &pts.ws].map(|c| &c[start..end]);
            let mut args: [&[f32]; 4] = [&[]; 4];
            for (col, slot) in cols.iter().zip(self.slots) {
                if let Some(s) = slot {
                    args[s] = col;
                }
            }
            let r = self
                .eval
                .eval(&self.tape, &args[..self.nvars])
                .expect("fidget evaluation failed");
            out[start..end].copy_from_slice(&r[0]);
            start = end;
        }
    }
}
