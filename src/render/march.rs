//! Sphere tracing, a wavefront at a time: every ray of a batch steps through the batched VM,
//! `LANES` rays per tape run, and the packets are refilled from the rays still marching after
//! each step, so no lane idles on a ray that has finished.

use crate::vm::{LANES, Regs, Tape, run};
use glam::DVec4;

/// A ray segment to march: from `o` along the unit direction `d` up to `tmax`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub o: DVec4,
    pub d: DVec4,
    pub tmax: f64,
    /// The ray may be inside an object: march on the unsigned distance to every surface.
    pub interior: bool,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Hit {
    /// Within the marching epsilon of `object`'s surface, `t` along the ray.
    Surface { t: f64, object: usize },
    /// Nothing before `tmax`.
    Beyond,
    /// The step limit ran out first.
    OutOfSteps,
}

/// The marching settings of a render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    pub epsilon: f64,
    pub max_steps: u32,
}

/// The distance below which a point counts as on a surface. f32 cannot resolve distances
/// below a few ulps of the coordinates, so far from the origin the epsilon grows with them.
pub fn epsilon_at(p: DVec4, epsilon: f64) -> f64 {
    epsilon.max(p.abs().max_element() * (1.0 / (1u64 << 21) as f64))
}

/// Per-thread scratch space of the marcher.
pub struct Marcher {
    regs: Regs<f32, LANES>,
    t: Vec<f64>,
    steps: Vec<u32>,
    active: Vec<u32>,
    next: Vec<u32>,
    /// Tape evaluations (one per ray per step), for the statistics.
    pub evaluations: u64,
}

impl Default for Marcher {
    fn default() -> Self {
        Marcher {
            regs: Regs { r: vec![] },
            t: vec![],
            steps: vec![],
            active: vec![],
            next: vec![],
            evaluations: 0,
        }
    }
}

impl Marcher {
    /// March every ray; `hits[i]` receives ray `i`'s result. Rays with `interior` set use the
    /// `interior` tape, the others `scene` (both output a distance, then an object index).
    pub fn march(
        &mut self,
        scene: &Tape,
        interior: Option<&Tape>,
        t_frame: f32,
        rays: &[Ray],
        limits: Limits,
        hits: &mut Vec<Hit>,
    ) {
        hits.clear();
        hits.resize(rays.len(), Hit::Beyond);
        self.t.clear();
        self.t.resize(rays.len(), 0.0);
        self.steps.clear();
        self.steps.resize(rays.len(), 0);
        for (tape, class) in [(Some(scene), false), (interior, true)] {
            let Some(tape) = tape else { continue };
            self.active.clear();
            self.active
                .extend((0..rays.len() as u32).filter(|&i| rays[i as usize].interior == class));
            if self.active.is_empty() {
                continue;
            }
            self.regs.fit(tape);
            *self.regs.input(crate::ir::Var::T.index()) = [t_frame; LANES];
            while !self.active.is_empty() {
                self.next.clear();
                for chunk in self.active.chunks(LANES) {
                    for (lane, &i) in chunk.iter().enumerate() {
                        let r = &rays[i as usize];
                        let p = (r.o + r.d * self.t[i as usize]).as_vec4();
                        for axis in 0..4 {
                            self.regs.input(axis)[lane] = p[axis];
                        }
                    }
                    run(tape, &mut self.regs);
                    self.evaluations += chunk.len() as u64;
                    let dist = self.regs.get(tape.outputs[0]);
                    let near = self.regs.get(tape.outputs[1]);
                    for (lane, &i) in chunk.iter().enumerate() {
                        let (r, k) = (&rays[i as usize], i as usize);
                        let d = dist[lane] as f64;
                        let p = r.o + r.d * self.t[k];
                        if d < epsilon_at(p, limits.epsilon) && near[lane] >= 0.0 {
                            hits[k] = Hit::Surface {
                                t: self.t[k],
                                object: near[lane] as usize,
                            };
                            continue;
                        }
                        // NaN from a user's field ends the ray like a ray that ran out.
                        if d.is_nan() {
                            hits[k] = Hit::OutOfSteps;
                            continue;
                        }
                        self.t[k] += d;
                        self.steps[k] += 1;
                        if self.t[k] >= r.tmax {
                            hits[k] = Hit::Beyond;
                        } else if self.steps[k] >= limits.max_steps {
                            hits[k] = Hit::OutOfSteps;
                        } else {
                            self.next.push(i);
                        }
                    }
                }
                std::mem::swap(&mut self.active, &mut self.next);
            }
        }
    }
}
