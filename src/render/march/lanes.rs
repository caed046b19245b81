//! Distances at a batch of points on one tape, in runs as wide as the batch needs: full runs of
//! `LANES` and, for what is left, runs of `NARROW`. A run costs its width whatever it holds, and
//! the cells' marcher groups rays by cell, so most groups are small: on a custom field spread
//! over many cells, running each group `LANES` wide made every evaluation 11 times dearer.

use crate::vm::{LANES, Regs, Tape, run};
use glam::Vec4;

/// The narrow runs' width: one AVX2 vector of `f32`.
const NARROW: usize = 8;

/// Register files of both widths, and the batch's points and results.
pub struct Lanes {
    wide: Regs<f32, LANES>,
    narrow: Regs<f32, NARROW>,
    /// The points to evaluate, local to the tape.
    pub points: Vec<Vec4>,
    /// Distance and nearest object at each point (the tape's two outputs).
    pub out: Vec<(f32, f32)>,
}

impl Default for Lanes {
    fn default() -> Self {
        Lanes {
            wide: Regs { r: vec![] },
            narrow: Regs { r: vec![] },
            points: vec![],
            out: vec![],
        }
    }
}

impl Lanes {
    /// Evaluate `tape` at every point of `points` into `out`.
    pub fn run(&mut self, tape: &Tape) {
        self.out.clear();
        let n = self.points.len();
        // Runs of `LANES` while they are at least half full, narrow ones for the rest.
        let wide = if n % LANES > LANES / 2 {
            n
        } else {
            n - n % LANES
        };
        if wide > 0 {
            evaluate(&mut self.wide, tape, &self.points[..wide], &mut self.out);
        }
        if wide < n {
            evaluate(&mut self.narrow, tape, &self.points[wide..], &mut self.out);
        }
    }
}

fn evaluate<const N: usize>(
    regs: &mut Regs<f32, N>,
    tape: &Tape,
    points: &[Vec4],
    out: &mut Vec<(f32, f32)>,
) {
    regs.fit(tape);
    let (dist, near) = (tape.outputs[0], tape.outputs[1]);
    for chunk in points.chunks(N) {
        for (lane, p) in chunk.iter().enumerate() {
            for axis in 0..4 {
                regs.input(axis)[lane] = p[axis];
            }
        }
        run(tape, regs);
        let (d, o) = (regs.get(dist), regs.get(near));
        out.extend((0..chunk.len()).map(|lane| (d[lane], o[lane])));
    }
}
