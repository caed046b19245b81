//! Sphere tracing on the whole scene tape (the interior tape for rays inside objects),
//! `LANES` rays per run, a hit where the distance is below the epsilon (grown with the
//! coordinates as `f32` needs; where that exceeds the epsilon, the hit settles in `f64`,
//! `approach`). No cells and no exact shortcuts. With `Field::relax` (the
//! whole-tape marcher, `--marcher whole`) steps are over-relaxed and checked as the cells'
//! are (`unrelax`); without it (`--marcher plain`) each step is the distance itself: the
//! baseline the other marchers are timed and tested against. A ray sees the sky on the same
//! proof as there (`Escape::escapes`), retried as there (`retry`), a crawling ray leaps
//! as there (`crawl`), and a ray inside objects steps as carefully as there (`careful`).

use super::{
    Field, Hit, Limits, Marcher, Ray, State, Step, approach, careful, crawl, finish, retry, unrelax,
};
use crate::vm::escape::{Ahead, Proofs};

impl Marcher {
    pub(super) fn march_whole(
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
            // Rays proven clear of every object from where they start leave for the sky, and
            // rays that meet an exact unbounded object before the bounded objects' box, or
            // never reach that box, end there; the others that will reach it start there.
            self.active.retain(|&i| {
                let (k, r) = (i as usize, &rays[i as usize]);
                let st = &mut self.state[k];
                if !interior {
                    match look(field, r, 0.0, &mut self.proofs) {
                        Ok(end) => {
                            hits[k] = end;
                            return false;
                        }
                        Err(ahead) => {
                            // Nothing lies before the bounded objects' box: the ray starts
                            // there (a shadow ray from far along a floor, a camera far away).
                            if let Ahead::Meets { into, .. } = ahead {
                                if into >= r.tmax {
                                    hits[k] = Hit::Beyond;
                                    return false;
                                }
                                st.t = into;
                            }
                            st.ahead = ahead;
                        }
                    }
                }
                // Where they decide once the ray has left the box, no escape proof can
                // before.
                st.ahead != Ahead::Unknown || !escapes(field, r, st, &mut self.proofs)
            });
            while !self.active.is_empty() {
                self.next.clear();
                self.lanes.points.clear();
                (self.lanes.points).extend(self.active.iter().map(|&i| {
                    let (r, st) = (&rays[i as usize], &self.state[i as usize]);
                    (r.o + r.d * st.t).as_vec4()
                }));
                self.lanes.run(tape);
                self.evaluations += self.active.len() as u64;
                self.instructions += (self.active.len() * tape.code.len()) as u64;
                for (&i, &(d, near)) in self.active.iter().zip(&self.lanes.out) {
                    let (k, r) = (i as usize, &rays[i as usize]);
                    let st = &mut self.state[k];
                    let d = d as f64;
                    if d.is_nan() {
                        // NaN from a user's field ends the ray like a ray that ran out.
                        hits[k] = Hit::OutOfSteps;
                        continue;
                    }
                    let tol = field.escape.epsilon_at(r.o + r.d * st.t, limits.epsilon);
                    let step = if let Some(back) = unrelax(st, d) {
                        back
                    } else if interior {
                        careful(
                            field.escape,
                            st,
                            r,
                            (d, tol, f64::INFINITY, limits.epsilon),
                            &mut self.proofs,
                        )
                    } else if d < tol && near >= 0.0 {
                        if tol > limits.epsilon {
                            approach(
                                field.escape,
                                r,
                                st,
                                (d, near as usize),
                                (tol, limits.epsilon),
                                &mut self.proofs,
                            )
                        } else {
                            Step::Hit {
                                t: st.t,
                                object: near as usize,
                            }
                        }
                    } else if let Some(s) = crawl(field.escape, r, st, d, &mut self.proofs) {
                        s
                    } else {
                        // A relaxed step is only verified at the next point, so none may end
                        // the segment: the last step to `tmax` is a plain one.
                        let d = d.max(0.0);
                        let mut step = st.omega * d;
                        if st.t + step >= r.tmax {
                            step = d;
                        }
                        (st.radius, st.step) = (d, step);
                        Step::Advance(step)
                    };
                    finish(st, &mut self.next, k, r, step, limits, hits);
                    if self.next.last() == Some(&i) {
                        // Past the bounded objects' box, where the ray meets the exact
                        // unbounded ones is where it ends (the box is convex: it never
                        // comes back).
                        let end = match st.ahead {
                            Ahead::Meets { out, .. } if clear(st) < out => None,
                            Ahead::Meets { first, object, .. } => Some(end(r, first, object)),
                            Ahead::Inside => look(field, r, clear(st), &mut self.proofs)
                                .map_err(|ahead| st.ahead = ahead)
                                .ok(),
                            // Rays proven clear of every object from here on leave for the sky.
                            Ahead::Unknown => {
                                escapes(field, r, st, &mut self.proofs).then_some(Hit::Beyond)
                            }
                        };
                        if let Some(end) = end {
                            self.next.pop();
                            hits[k] = end;
                        }
                    }
                }
                std::mem::swap(&mut self.active, &mut self.next);
            }
        }
    }
}

/// Whether the ray, once it has gone far enough past its last try (`retry`), provably meets no
/// surface from where it is known to be clear (`clear`).
fn escapes(field: Field, r: &Ray, st: &mut State, proofs: &mut Proofs) -> bool {
    if st.t < st.escape_at {
        return false;
    }
    st.escape_at = retry(st.t);
    (field.escape).escapes(r.o + r.d * clear(st), r.d, r.interior, &mut st.keep, proofs)
}

/// Where the ray is known to be clear: a relaxed step is checked only at the next point, so
/// that is where the last step would have ended as a plain one.
fn clear(st: &State) -> f64 {
    st.t - (st.step - st.radius).max(0.0)
}

/// Where the exact unbounded objects end the ray from `t` along it (`Escape::ahead`): where
/// it meets them, if it does before the bounded objects' box or never meets that box; else
/// what they say, along the whole ray.
fn look(field: Field, r: &Ray, t: f64, proofs: &mut Proofs) -> Result<Hit, Ahead> {
    match field.escape.ahead(r.o + r.d * t, r.d, proofs) {
        Ahead::Meets {
            first,
            object,
            into,
            out,
        } if first <= into || out == 0.0 => Ok(end(r, t + first, object)),
        Ahead::Meets {
            first,
            object,
            into,
            out,
        } => Err(Ahead::Meets {
            first: t + first,
            object,
            into: t + into,
            out: t + out,
        }),
        other => Err(other),
    }
}

/// The end of a ray whose first meeting is `object` at `t` (infinity: none), if before `tmax`.
pub(super) fn end(r: &Ray, t: f64, object: usize) -> Hit {
    match t < r.tmax {
        true => Hit::Surface { t, object },
        false => Hit::Beyond,
    }
}
