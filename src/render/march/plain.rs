//! The plain marcher (`--marcher plain`): sphere tracing on the whole scene tape (the interior
//! tape for rays inside objects), `LANES` rays per run, each step the distance itself, a hit
//! where it is below the epsilon (grown with the coordinates as `f32` needs). No cells, no
//! relaxation, no exact shortcuts: the baseline the cells' marcher is timed and tested
//! against. A ray sees the sky on the same proof as there (`Escape::escapes`), tried each time
//! it has gone twice as far.

use super::{Field, Hit, Limits, Marcher, Ray, State};
use crate::vm::cells::epsilon_at;
use crate::vm::{LANES, run};

impl Marcher {
    pub(super) fn march_plain(
        &mut self,
        field: Field,
        rays: &[Ray],
        limits: Limits,
        hits: &mut Vec<Hit>,
    ) {
        hits.clear();
        hits.resize(rays.len(), Hit::Beyond);
        self.state.clear();
        self.state.resize(rays.len(), State::default());
        let unbounded = field.escape.unbounded();
        for st in &mut self.state {
            st.keep = unbounded;
        }
        for interior in [false, true] {
            let tape = match interior {
                true => field.interior.unwrap_or(field.scene),
                false => field.scene,
            };
            self.active.clear();
            (self.active)
                .extend((0..rays.len() as u32).filter(|&i| rays[i as usize].interior == interior));
            if self.active.is_empty() {
                continue;
            }
            self.regs.fit(tape);
            while !self.active.is_empty() {
                // Rays proven clear of every object leave for the sky.
                self.active.retain(|&i| {
                    let (r, st) = (&rays[i as usize], &mut self.state[i as usize]);
                    if st.t < st.escape_at {
                        return true;
                    }
                    st.escape_at = 2.0 * st.t + 1.0;
                    !field
                        .escape
                        .escapes(r.o + r.d * st.t, r.d, interior, &mut st.keep)
                });
                self.next.clear();
                for chunk in self.active.chunks(LANES) {
                    for (lane, &i) in chunk.iter().enumerate() {
                        let (r, st) = (&rays[i as usize], &self.state[i as usize]);
                        let p = (r.o + r.d * st.t).as_vec4();
                        for axis in 0..4 {
                            self.regs.input(axis)[lane] = p[axis];
                        }
                    }
                    run(tape, &mut self.regs);
                    self.evaluations += chunk.len() as u64;
                    self.instructions += (chunk.len() * tape.code.len()) as u64;
                    let (dist, near) = (
                        self.regs.get(tape.outputs[0]),
                        self.regs.get(tape.outputs[1]),
                    );
                    for (lane, &i) in chunk.iter().enumerate() {
                        let (k, r) = (i as usize, &rays[i as usize]);
                        let st = &mut self.state[k];
                        let d = dist[lane] as f64;
                        if d.is_nan() {
                            // NaN from a user's field ends the ray like a ray that ran out.
                            hits[k] = Hit::OutOfSteps;
                            continue;
                        }
                        if d < epsilon_at(r.o + r.d * st.t, limits.epsilon) && near[lane] >= 0.0 {
                            hits[k] = if st.t < r.tmax {
                                Hit::Surface {
                                    t: st.t,
                                    object: near[lane] as usize,
                                }
                            } else {
                                Hit::Beyond
                            };
                            continue;
                        }
                        st.t += d.max(0.0);
                        st.steps += 1;
                        if st.t >= r.tmax {
                            hits[k] = Hit::Beyond;
                        } else if st.steps >= limits.max_steps {
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
