//! A ball tiled over a lattice (`tile`), met exactly: the ray crosses the lattice's cells one
//! by one (the D4 lattice's are 24-cells, a grid's are boxes) and meets, in each, the copy of
//! the ball that the cell's point carries. Sphere tracing takes some twenty steps between two
//! spheres of the D4 packing, each as long as the distance to the nearest, and thousands along
//! the packing's channels.

use super::{Meeting, dot};
use crate::math::kernel::{d4, rep};

/// Which lattice, in lattice units (`Tiled::to`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tiling {
    /// Integer points with an even coordinate sum. A point's cell (the points nearer to it
    /// than to any other) is a 24-cell, bounded by the planes halfway to its 24 nearest
    /// neighbours.
    D4,
    /// Integer points with `|c_i| <= limit_i`. A point's cell is the unit box around it, open
    /// outward at the limits.
    Grid { limit: [f64; 4] },
}

/// The ball `|m (q - c) + off| - r` copied to every lattice point `c`, where `q = to p + at`
/// are `p`'s lattice coordinates: `m (q - c) + off` is the point relative to the copy at
/// `c`, and `m to` has orthonormal rows (a distance).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tiled {
    pub tiling: Tiling,
    pub to: [[f64; 4]; 4],
    pub at: [f64; 4],
    pub m: [[f64; 4]; 4],
    pub off: [f64; 4],
    pub r: f64,
    /// The copy's centre relative to its lattice point, in lattice coordinates, and how far
    /// the copy reaches from it along each axis per unit of radius (infinite where `m` is
    /// singular): the copy at `c` lies where `|x_i - c_i - centre_i| <= r stretch_i`.
    centre: [f64; 4],
    stretch: [f64; 4],
    /// Whether `to`, and `m`, are the identity: a tiling that is not turned or scaled moves
    /// coordinates only, and its products are skipped (they would be exact).
    identity: (bool, bool),
}

/// How far a lattice coordinate's windows (`Tiled::window`) are widened against rounding, in
/// lattice units, beside a relative part: a ray advanced to a window's edge is inside it.
const MARGIN: f64 = 1e-9;

/// The lattice cells a crossing (`Tiled::meet`) goes before it gives up, to start with: a ray
/// along one of the D4 packing's channels may meet no ball for a long way. The ray goes on
/// from where it stopped, and the marcher lets a ray that has taken many steps cross more
/// cells in each (`march`).
pub const CELLS: usize = 64;

/// The pairs of axes: a D4 point's 24 nearest neighbours are `±e_i ± e_j` for each.
const PAIRS: [(usize, usize); 6] = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)];

/// The steps to the neighbour behind each face, up to the sign of the ray's rate: a D4 cell's
/// twelve (`e_i + e_j`, then `e_i - e_j`, over `PAIRS`), then a box's four (`e_i`).
const STEPS: [[f64; 4]; 16] = {
    let mut steps = [[0.0; 4]; 16];
    let mut k = 0;
    while k < 6 {
        let (i, j) = PAIRS[k];
        steps[k][i] = 1.0;
        steps[k][j] = 1.0;
        steps[k + 6][i] = 1.0;
        steps[k + 6][j] = -1.0;
        steps[12 + k % 4][k % 4] = 1.0;
        k += 1;
    }
    steps
};

#[inline(always)]
fn apply(a: &[[f64; 4]; 4], v: [f64; 4]) -> [f64; 4] {
    std::array::from_fn(|i| dot(a[i], v))
}

impl Tiling {
    /// The lattice point whose cell holds `q` (the VM's `d4` and `rep`).
    #[inline(always)]
    pub fn nearest(&self, q: [f64; 4]) -> [f64; 4] {
        match self {
            Tiling::D4 => {
                let o = d4(q);
                std::array::from_fn(|i| o[4 + i])
            }
            Tiling::Grid { limit } => std::array::from_fn(|i| rep(q[i], limit[i])[1]),
        }
    }

    /// What a ray along `w` (in lattice units) needs to leave cells: worked out once per ray,
    /// since a crossing leaves a few cells per call and each face's rate is the same in all.
    #[inline(always)]
    fn exits(&self, w: [f64; 4]) -> Exits {
        // `t = (face - s x) * inv + far`: `inv = 1 / |rate|`, or 0 with `far` infinite where
        // the ray moves along a face or away from it, so that it is never met (the ray may lie
        // in the face's plane, where the quotient would be 0 / 0). Array by array, so that it
        // vectorises.
        let mut rate = [0.0; 12];
        let faces = match self {
            // The face towards the neighbour `c + n` is where `n . x = |n|^2 / 2 = 1`. Of the
            // four `±e_i ± e_j` of a pair of axes, the ray moves towards two: the signs of
            // `w_i + w_j` and of `w_i - w_j` say which.
            Tiling::D4 => {
                for (k, (i, j)) in PAIRS.into_iter().enumerate() {
                    (rate[k], rate[k + 6]) = (w[i] + w[j], w[i] - w[j]);
                }
                12
            }
            Tiling::Grid { .. } => {
                rate[..4].copy_from_slice(&w);
                4
            }
        };
        let inv = rate.map(|r| 1.0 / r.abs());
        Exits {
            sign: rate.map(|r| if r < 0.0 { -1.0 } else { 1.0 }),
            inv: std::array::from_fn(|k| if inv[k] < f64::INFINITY { inv[k] } else { 0.0 }),
            far: std::array::from_fn(|k| {
                if k < faces && inv[k] < f64::INFINITY {
                    0.0
                } else {
                    f64::INFINITY
                }
            }),
        }
    }

    /// Where the ray `x + t w` (lattice coordinates relative to the point `c`, from inside its
    /// cell; `exits` holds what depends on `w`) leaves the cell, and the step from `c` to the
    /// point of the cell it enters (infinity and zero if it never leaves).
    #[inline(always)]
    fn leave(&self, exits: &Exits, c: [f64; 4], x: [f64; 4]) -> (f64, [f64; 4]) {
        let Exits { sign, inv, far, .. } = exits;
        // Written without branches (a ray's faces are met in no order a predictor learns),
        // so that it vectorises.
        let mut t = [f64::INFINITY; 12];
        match self {
            Tiling::D4 => {
                for (k, (i, j)) in PAIRS.into_iter().enumerate() {
                    for (h, sj) in [(0, 1.0), (6, -1.0)] {
                        let y = x[i] + sj * x[j];
                        t[k + h] = (1.0 - sign[k + h] * y) * inv[k + h] + far[k + h];
                    }
                }
            }
            Tiling::Grid { limit } => {
                for i in 0..4 {
                    // Open outward at the limits: no face there.
                    let open = if c[i] * sign[i] >= limit[i] {
                        f64::INFINITY
                    } else {
                        0.0
                    };
                    t[i] = (0.5 - sign[i] * x[i]) * inv[i] + far[i] + open;
                }
            }
        }
        // The nearest face, and the first of the faces that near: a tree of `min`s and a
        // mask, not a chain of compares.
        let min = |a: f64, b: f64| if b < a { b } else { a };
        let m: [f64; 4] = std::array::from_fn(|i| min(min(t[i], t[i + 4]), t[i + 8]));
        let best = min(min(m[0], m[1]), min(m[2], m[3]));
        let mut n = [0.0; 4];
        if best < f64::INFINITY {
            let mask = (0..12).fold(0u32, |m, k| m | (((t[k] == best) as u32) << k));
            let k = mask.trailing_zeros() as usize;
            let step = match self {
                Tiling::D4 => STEPS[k],
                Tiling::Grid { .. } => STEPS[k + 12],
            };
            n = step.map(|v| v * sign[k]);
        }
        (best, n)
    }
}

/// The faces a ray can leave a cell through (`Tiling::exits`), each as the sign of the step
/// towards it, the inverse of the rate at which the ray closes on it, and infinity for a face
/// never met (else 0).
struct Exits {
    sign: [f64; 12],
    inv: [f64; 12],
    far: [f64; 12],
}

impl Tiled {
    /// The ball `|m (q - c) + off| - r` over `tiling`, where `q = to p + at`.
    pub fn new(
        tiling: Tiling,
        (to, at): ([[f64; 4]; 4], [f64; 4]),
        (m, off): ([[f64; 4]; 4], [f64; 4]),
        r: f64,
    ) -> Tiled {
        // The ball is `x = m^-1 (v - off)` over `|v| <= r`: centred at `-m^-1 off`, reaching
        // `r |row_i(m^-1)|` along axis `i`. (The transpose's inverse has those rows as columns.)
        // A singular `m` (a projection) reaches for ever: nothing is skipped.
        let inv = glam::DMat4::from_cols_array_2d(&m).inverse();
        let (centre, stretch) = match inv.to_cols_array().iter().all(|v| v.is_finite()) {
            true => (
                std::array::from_fn(|i| -inv.col(i).dot(glam::DVec4::from_array(off))),
                std::array::from_fn(|i| inv.col(i).length()),
            ),
            false => ([0.0; 4], [f64::INFINITY; 4]),
        };
        Tiled {
            tiling,
            to,
            at,
            m,
            off,
            r,
            centre,
            stretch,
            identity: (to == super::IDENTITY, m == super::IDENTITY),
        }
    }

    /// The ball grown by `k` (its rounding).
    pub fn grown(&self, k: f64) -> Tiled {
        Tiled {
            r: self.r + k,
            ..*self
        }
    }

    /// The first `t >= 0` at which lattice coordinate `i` of the ray `q + t w` is within
    /// reach of a copy of the ball (of some lattice point's `c_i`), or infinity: a ray that
    /// keeps a coordinate between the copies' (a slice at `w = 0.3` of small spheres at
    /// integer `w`) meets none, and one that crosses such gaps meets none in them.
    #[inline(always)]
    fn window(&self, i: usize, q: f64, w: f64) -> f64 {
        let half = self.r * self.stretch[i] + MARGIN * (1.0 + q.abs());
        let (lo, hi) = (self.centre[i] - half, self.centre[i] + half);
        let limit = match self.tiling {
            Tiling::D4 => f64::INFINITY,
            Tiling::Grid { limit } => limit[i],
        };
        // Copies that overlap along the axis leave no gaps (checked first: the D4 packing's
        // do); else the lattice values whose copies reach `q` now are `c` in `[q - hi, q - lo]`.
        let gaps = hi - lo < 1.0; // false where NaN (an infinite stretch)
        if !gaps || (q - hi).ceil().max(-limit) <= (q - lo).floor().min(limit) {
            return 0.0;
        }
        // Else the next one ahead, if there is one.
        let (c, edge) = match w {
            w if w > 0.0 => ((q - lo).ceil().max(-limit), lo),
            w if w < 0.0 => ((q - hi).floor().min(limit), hi),
            _ => return f64::INFINITY,
        };
        match c.abs() <= limit {
            true => (c + edge - q) / w,
            false => f64::INFINITY,
        }
    }

    /// The lattice coordinates of `p`.
    #[inline(always)]
    fn lattice(&self, p: [f64; 4]) -> [f64; 4] {
        let q = self.times_to(p);
        std::array::from_fn(|i| q[i] + self.at[i])
    }

    /// `to v`.
    #[inline(always)]
    fn times_to(&self, v: [f64; 4]) -> [f64; 4] {
        match self.identity.0 {
            true => v,
            false => apply(&self.to, v),
        }
    }

    /// `m x`.
    #[inline(always)]
    fn times_m(&self, x: [f64; 4]) -> [f64; 4] {
        match self.identity.1 {
            true => x,
            false => apply(&self.m, x),
        }
    }

    /// The point relative to its copy, from its lattice coordinates relative to the copy's
    /// lattice point: small numbers, whatever the distance from the origin.
    #[inline(always)]
    fn local(&self, x: [f64; 4]) -> [f64; 4] {
        let u = self.times_m(x);
        std::array::from_fn(|i| u[i] + self.off[i])
    }

    /// The tiled ball's distance at `p`: to the copy of the cell `p` is in.
    pub fn value(&self, p: [f64; 4]) -> f64 {
        let q = self.lattice(p);
        let c = self.tiling.nearest(q);
        let u = self.local(std::array::from_fn(|i| q[i] - c[i]));
        dot(u, u).sqrt() - self.r
    }

    /// The distance at `p`, and the first `t` in `[0, limit]` at which the ray from `p` along
    /// `d` is in the copy of the ball of the cell it is in, if there is one, else how far it is
    /// clear of every copy: at least `limit`, or less where it gave up after crossing `cells`
    /// cells.
    pub fn meet(&self, p: [f64; 4], d: [f64; 4], (limit, cells): (f64, usize)) -> Meeting {
        // With AVX2 and FMA where the CPU has them: `round` inline (`nearest`), not a C
        // library call, and wider vectors for the faces' quotients.
        crate::wide!(self.cross(p, d, (limit, cells)))
    }

    #[inline(always)]
    fn cross(&self, p: [f64; 4], d: [f64; 4], (limit, cells): (f64, usize)) -> Meeting {
        let q = self.lattice(p);
        let w = self.times_to(d);
        let (exits, along) = (self.tiling.exits(w), self.times_m(w));
        let mut c = self.tiling.nearest(q);
        let mut x: [f64; 4] = std::array::from_fn(|i| q[i] - c[i]);
        let here = self.local(x);
        let value = dot(here, here).sqrt() - self.r;
        let meeting = |first, clear, cells| Meeting {
            value,
            first,
            clear,
            cells,
        };
        // No copy is met before every coordinate is within reach of one: the crossing starts
        // there, from the point it is at (not from `q`, which may be far behind: the roots
        // of a copy seen from afar have no digits left), and its times are offset by `skip`.
        let skip = (0..4).fold(0.0, |t: f64, i| t.max(self.window(i, q[i], w[i])));
        // (A coordinate that stays between copies for ever meets none, whatever the limit:
        // advanced to infinity, the crossing would run on NaN coordinates.)
        if skip > limit || skip == f64::INFINITY {
            return meeting(None, skip, 0);
        }
        if skip > 0.0 {
            let q = std::array::from_fn(|i| q[i] + skip * w[i]);
            c = self.tiling.nearest(q);
            x = std::array::from_fn(|i| q[i] - c[i]);
        }
        let shifted =
            |t: Option<f64>, clear: f64, cells| meeting(t.map(|t| t + skip), clear + skip, cells);
        let limit = limit - skip;
        let mut from = 0.0;
        for k in 0..cells {
            if from > limit {
                return shifted(None, from, k);
            }
            let (to, n) = self.tiling.leave(&exits, c, x);
            let to = to.max(from);
            if let Some((t0, t1)) = super::ball_roots(self.local(x), along, self.r) {
                let t = t0.max(from);
                if t <= t1.min(to) {
                    return shifted(Some(t), t, k + 1);
                }
            }
            // A grid's end cell, left along no axis: nothing more to meet.
            if to == f64::INFINITY {
                return shifted(None, to, k + 1);
            }
            from = to;
            // Integer steps: `x` stays `q - c` to within a rounding.
            c = std::array::from_fn(|i| c[i] + n[i]);
            x = std::array::from_fn(|i| x[i] - n[i]);
        }
        shifted(None, from, cells)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ray in the plane of a face (here `x + y = 1`, which holds the point and the
    /// direction) still leaves the cell through another: 0 / 0 there once made it stay
    /// for ever, and the D4 packing's channel rays end at infinity.
    #[test]
    fn rays_along_a_face_still_leave() {
        let (c, x) = ([0.0; 4], [0.5, 0.5, 0.0, 0.2]);
        let tiling = Tiling::D4;
        let (t, n) = tiling.leave(&tiling.exits([3e-4, -3e-4, 1.0, 0.0]), c, x);
        assert!(t.is_finite() && t > 0.0, "{t}");
        assert_eq!(n.iter().map(|v| v * v).sum::<f64>(), 2.0);
    }

    /// A ray that keeps a coordinate between the copies' reach for ever (here `w = 0.5`, the
    /// balls of radius 0.2 at integer `w`) meets none of them, looking however far: at once,
    /// crossing no cell, not after a crossing run on coordinates advanced to infinity.
    #[test]
    fn a_ray_between_the_copies_meets_none_at_any_length() {
        let identity = std::array::from_fn(|i| std::array::from_fn(|j| (i == j) as u8 as f64));
        let tiled = Tiled::new(
            Tiling::Grid {
                limit: [3.0, 3.0, 3.0, 3.0],
            },
            (identity, [0.0; 4]),
            (identity, [0.0; 4]),
            0.2,
        );
        let (p, d) = ([-10.0, 0.1, 0.0, 0.5], [1.0, 0.0, 0.0, 0.0]);
        for limit in [10.0, f64::INFINITY] {
            let m = tiled.meet(p, d, (limit, CELLS));
            assert_eq!(m.first, None, "{limit}: {m:?}");
            assert_eq!((m.clear, m.cells), (f64::INFINITY, 0), "{limit}: {m:?}");
        }
    }

    /// The neighbour a ray enters is the lattice point nearest to it just past the face, and
    /// it stays in each cell up to the face: checked on random rays against `nearest`.
    #[test]
    fn rays_cross_cells_into_their_nearest_points() {
        let mut seed = 7u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for tiling in [
            Tiling::D4,
            Tiling::Grid {
                limit: [2.0, 1.0, 3.0, 0.0],
            },
        ] {
            for _ in 0..2000 {
                let q: [f64; 4] = std::array::from_fn(|_| 10.0 * rnd());
                let w: [f64; 4] = std::array::from_fn(|_| rnd());
                let c = tiling.nearest(q);
                let x = std::array::from_fn(|i| q[i] - c[i]);
                let (t, n) = tiling.leave(&tiling.exits(w), c, x);
                let at = |t: f64| std::array::from_fn(|i| q[i] + t * w[i]);
                // A D4 cell is bounded: every ray leaves it.
                assert!(t.is_finite() || tiling != Tiling::D4, "{q:?} {w:?}");
                if t.is_infinite() {
                    assert_eq!(tiling.nearest(at(1e3)), c, "{tiling:?} {q:?} {w:?}");
                    continue;
                }
                assert!(t >= -1e-12, "{tiling:?}: leaves at {t}");
                assert_eq!(tiling.nearest(at(t * 0.999)), c, "{tiling:?} {q:?} {w:?}");
                let next: [f64; 4] = std::array::from_fn(|i| c[i] + n[i]);
                assert_eq!(tiling.nearest(at(t + 1e-9)), next, "{tiling:?} {q:?} {w:?}");
            }
        }
    }
}
