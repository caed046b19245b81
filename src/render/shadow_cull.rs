//! Shadow rays that meet fewer pieces. Where a frame's scene is a few exact pieces, a shadow
//! ray meets each of them before it can see its light. A piece whose free region (a convex
//! set where its value is positive: a room's hollow) holds the light's whole ball cannot be
//! met by a ray that leaves from inside that region before the ray is past the ball: the
//! segment between the two stays in the region. So such rays leave those pieces out: what
//! they see of the light comes out the same. Nor do they meet the light's own ball: where
//! a ray enters it is known in closed form (`SphereLight::enter`), so the ray goes that far
//! and sees the light if it meets nothing on the way.

use super::lights::SphereLight;
use crate::ir::exact::{Form, Pieces};
use glam::DVec4;

/// For shadow rays towards one light: the pieces left to meet (up to the light's ball), and
/// the free regions of those left out, which a ray must leave from for them to be.
pub struct ShadowCull {
    /// The frame's pieces less the light's own and those whose free region holds its ball.
    pub pieces: Pieces,
    regions: Vec<Form>,
}

impl ShadowCull {
    /// The cull for shadow rays towards `light` in a frame whose scene is `pieces` (the
    /// light's ball among them). `eps` is the marching epsilon: the region's value must be
    /// below `-eps` all over the ball, so that rounding in the meetings cannot bring the
    /// region's surface to the ball.
    pub fn of(pieces: &Pieces, light: &SphereLight, eps: f64) -> ShadowCull {
        let (center, radius) = (light.center.to_array(), light.radius);
        let (mut kept, mut regions) = (vec![], vec![]);
        for piece in pieces.iter().filter(|p| p.object != light.object as f64) {
            let free = (piece.form.free_region()).filter(|g| g.holds_ball(center, radius, eps));
            match free {
                Some(g) => regions.push(g),
                None => kept.push(piece.clone()),
            }
        }
        ShadowCull {
            pieces: Pieces::from(kept),
            regions,
        }
    }

    /// Whether a shadow ray from `o` may meet only `pieces`: `o` lies in every region left
    /// out, by twice the epsilon, so that the pieces' values there are well above it and the
    /// full meeting would not have ended the ray where it starts.
    pub fn holds(&self, o: DVec4, eps: f64) -> bool {
        let o = o.to_array();
        self.regions.iter().all(|g| g.below(o, -2.0 * eps))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ir::exact::testing::{form, unit};
    use crate::ir::exact::{Piece, Rows};
    use crate::render::march::{Hit, Limits, Marcher, Ray};
    use glam::DVec3;
    use rand::{Rng, SeedableRng};

    /// A solid ball of `radius` around `center`, on `object`.
    fn ball(center: [f64; 4], radius: f64, object: usize) -> Piece {
        let identity = std::array::from_fn(|i| std::array::from_fn(|j| (i == j) as u8 as f64));
        Piece {
            form: Form::Ball {
                rows: Rows::from(identity),
                b: center.map(|x| -x),
                r: radius,
                sign: 1.0,
            },
            object: object as f64,
        }
    }

    /// Shadow rays that meet only a cull's pieces, as far as they enter the light's ball, see
    /// the light where those meeting every piece do, at the same distance to a relative 1e-9
    /// (6.5e-11 at worst: where a ray grazes the ball, its entry is ill-conditioned, and the
    /// two closed forms may differ more; the distance only weighs the transmittance). Scenes
    /// of random forms with free regions (hollow boxes, balls and polytopes, their
    /// complements, planes), solid balls in the way and a light; rays from random points
    /// outside the ball towards random points on it (those from inside take the whole
    /// meeting in `march_shadows`).
    #[test]
    fn culled_shadow_rays_see_the_light_as_all_pieces_do() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(5);
        let uniform4 = |rng: &mut rand_pcg::Pcg64Mcg, r: f64| -> [f64; 4] {
            std::array::from_fn(|_| rng.random_range(-r..r))
        };
        let limits = Limits {
            epsilon: 1e-4,
            max_steps: 1000,
        };
        let (mut marcher, mut full, mut cut) = (Marcher::default(), vec![], vec![]);
        let (mut culls, mut seen, mut rays, mut worst) = (0, 0, 0, 0.0f64);
        for _ in 0..3000 {
            let mut list = vec![];
            for object in 0..rng.random_range(1..4) {
                let (a, v) = (uniform4(&mut rng, 1.0), uniform4(&mut rng, 1.0));
                let (s, turn) = (rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
                let turn = if rng.random_bool(0.5) { 0.0 } else { turn };
                list.push(Piece {
                    form: form(rng.random_range(0..9), a, v, s, turn),
                    object: object as f64,
                });
            }
            for _ in 0..rng.random_range(0..3) {
                let object = list.len();
                list.push(ball(
                    uniform4(&mut rng, 1.0),
                    rng.random_range(0.05..0.4),
                    object,
                ));
            }
            let (center, radius) = (uniform4(&mut rng, 0.5), rng.random_range(0.02..0.3));
            let light = SphereLight {
                center: DVec4::from_array(center),
                radius,
                radiance: DVec3::ONE,
                object: list.len() as u32,
            };
            list.push(ball(center, radius, list.len()));
            let pieces = Pieces::from(list);
            let cull = ShadowCull::of(&pieces, &light, limits.epsilon);
            culls += !cull.regions.is_empty() as usize;
            let origins: Vec<DVec4> = (0..40)
                .map(|_| DVec4::from_array(uniform4(&mut rng, 3.0)))
                .filter(|&o| cull.holds(o, limits.epsilon))
                .collect();
            let batch: Vec<Ray> = (origins.into_iter())
                .map(|o| {
                    let on = DVec4::from_array(unit(uniform4(&mut rng, 1.0)));
                    Ray {
                        o,
                        d: (light.center + on * light.radius - o).normalize(),
                        tmax: (light.center - o).length() + light.radius,
                        interior: false,
                    }
                })
                .collect();
            // As the integrator sends them: only rays from outside the ball that enter it;
            // culled, as far as that.
            let (batch, short): (Vec<Ray>, Vec<Ray>) = (batch.into_iter())
                .filter_map(|r| light.enter(r.o, r.d).filter(|&t| t > 0.0).map(|t| (r, t)))
                .map(|(r, tmax)| (r, Ray { tmax, ..r }))
                .unzip();
            rays += batch.len();
            marcher.meet(|_| &pieces, &batch, limits, &mut full);
            marcher.meet(|_| &cull.pieces, &short, limits, &mut cut);
            for ((a, b), r) in full.iter().zip(&cut).zip(&short) {
                let all = match *a {
                    Hit::Surface { t, object } if object == light.object as usize => Some(t),
                    _ => None,
                };
                let culled = (*b == Hit::Beyond).then_some(r.tmax);
                assert_eq!(all.is_some(), culled.is_some(), "{a:?} against {b:?}");
                if let (Some(x), Some(y)) = (all, culled) {
                    worst = worst.max((x - y).abs() / x.max(1e-300));
                    seen += 1;
                }
            }
        }
        assert!(
            culls > 300 && rays > 3000 && seen > 1000,
            "{culls} {rays} {seen}"
        );
        assert!(worst < 1e-9, "{worst:e}");
    }
}
