//! The plain marcher (`--marcher plain`): sphere tracing on the whole scene tape (the interior
//! tape for rays inside objects), `LANES` rays per run, each step the distance itself, a hit
//! where it is below the epsilon (grown with the coordinates as `f32` needs). No cells, no
//! relaxation, no exact shortcuts: the baseline the cells' marcher is timed and tested
//! against. A ray sees the sky on the same proof as there (`Escape::escapes`), tried each time
//! it has gone twice as far.

use super::{Field, Hit, Limits, Marcher, Ray};
use crate::vm::cells::epsilon_at;

impl Marcher {
    pub(super) fn march_plain(
        &mut self,
        field: Field,
        rays: &[Ray],
        limits: Limits,
        hits: &mut [Hit],
    ) {
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
            while !self.active.is_empty() {
                // Rays proven clear of every object leave for the sky.
                self.active.retain(|&i| {
                    let (r, st) = (&rays[i as usize], &mut self.state[i as usize]);
                    if st.t < st.escape_at {
                        return true;
                    }
                    st.escape_at = 2.0 * st.t + 1.0;
                    !field.escape.escapes(
                        r.o + r.d * st.t,
                        r.d,
                        interior,
                        &mut st.keep,
                        &mut self.proofs,
                    )
                });
                self.next.clear();
                self.lanes.points.clear();
                (self.lanes.points).extend(self.active.iter().map(|&i| {
                    let (r, st) = (&rays[i as usize], &self.state[i as usize]);
                    (r.o + r.d * st.t).as_vec4()
                }));
                self.lanes.run(tape);
                self.evaluations += self.active.len() as u64;
                self.instructions += (self.active.len() * tape.code.len()) as u64;
                {
                    for (&i, &(d, near)) in self.active.iter().zip(&self.lanes.out) {
                        let (k, r) = (i as usize, &rays[i as usize]);
                        let st = &mut self.state[k];
                        let d = d as f64;
                        if d.is_nan() {
                            // NaN from a user's field ends the ray like a ray that ran out.
                            hits[k] = Hit::OutOfSteps;
                            continue;
                        }
                        if d < epsilon_at(r.o + r.d * st.t, limits.epsilon) && near >= 0.0 {
                            hits[k] = if st.t < r.tmax {
                                Hit::Surface {
                                    t: st.t,
                                    object: near as usize,
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
