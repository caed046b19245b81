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

/// The ball `|rows p + b - m c| - r` copied to every lattice point `c`, where `p`'s lattice
/// coordinates are `to p + at`: `m (q - c) + (b - m at)` is the point relative to the copy
/// at `c`, and `rows = m to`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tiled {
    pub tiling: Tiling,
    pub to: [[f64; 4]; 4],
    pub at: [f64; 4],
    pub m: [[f64; 4]; 4],
    pub rows: [[f64; 4]; 4],
    pub b: [f64; 4],
    pub r: f64,
}

/// The lattice cells a crossing (`Tiled::meet`) goes before it gives up, to start with: a ray
/// along one of the D4 packing's channels may meet no ball for a long way. The ray goes on
/// from where it stopped, and the marcher lets a ray that has taken many steps cross more
/// cells in each (`march`).
pub const CELLS: usize = 64;

/// The pairs of axes: a D4 point's 24 nearest neighbours are `±e_i ± e_j` for each.
const PAIRS: [(usize, usize); 6] = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)];

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

    /// Where the ray `x + t w` (lattice coordinates relative to the point `c`, from inside its
    /// cell) leaves the cell, and the step from `c` to the point of the cell it enters
    /// (infinity and zero if it never leaves).
    #[inline(always)]
    fn leave(&self, c: [f64; 4], x: [f64; 4], w: [f64; 4]) -> (f64, [f64; 4]) {
        let mut out = (f64::INFINITY, [0.0; 4]);
        match self {
            Tiling::D4 => {
                // The face towards the neighbour `c + n` is where `n . x = |n|^2 / 2 = 1`. Of
                // the four `±e_i ± e_j` of a pair of axes, the ray moves towards two: the
                // signs of `w_i + w_j` and of `w_i - w_j` say which. Written without branches
                // (a ray's faces are met in no order a predictor learns), so it vectorises.
                let mut t = [0.0; 12];
                let mut s = [0.0; 12];
                for (k, (i, j)) in PAIRS.into_iter().enumerate() {
                    for (h, sj) in [(0, 1.0), (6, -1.0)] {
                        let rate = w[i] + sj * w[j];
                        let sign = if rate < 0.0 { -1.0 } else { 1.0 };
                        s[k + h] = sign;
                        // A face the ray moves along (or away from) is never met; the ray
                        // may lie in its plane, where the quotient would be 0 / 0.
                        let num = 1.0 - sign * (x[i] + sj * x[j]);
                        t[k + h] = if rate != 0.0 {
                            num / (sign * rate)
                        } else {
                            f64::INFINITY
                        };
                    }
                }
                let mut best = 0;
                for k in 1..12 {
                    best = if t[k] < t[best] { k } else { best };
                }
                let ((i, j), sj) = (PAIRS[best % 6], if best < 6 { 1.0 } else { -1.0 });
                if t[best] < f64::INFINITY {
                    out.0 = t[best];
                    (out.1[i], out.1[j]) = (s[best], s[best] * sj);
                }
            }
            Tiling::Grid { limit } => {
                for i in 0..4 {
                    let (face, s) = match w[i] {
                        r if r > 0.0 && c[i] < limit[i] => (0.5, 1.0),
                        r if r < 0.0 && c[i] > -limit[i] => (-0.5, -1.0),
                        _ => continue,
                    };
                    let t = (face - x[i]) / w[i];
                    if t < out.0 {
                        let mut n = [0.0; 4];
                        n[i] = s;
                        out = (t, n);
                    }
                }
            }
        }
        out
    }
}

impl Tiled {
    /// The lattice coordinates of `p`.
    #[inline(always)]
    fn lattice(&self, p: [f64; 4]) -> [f64; 4] {
        let q = apply(&self.to, p);
        std::array::from_fn(|i| q[i] + self.at[i])
    }

    /// `p` relative to the copy at lattice point `c`, given `u = rows p + b`.
    #[inline(always)]
    fn local(&self, u: [f64; 4], c: [f64; 4]) -> [f64; 4] {
        let mc = apply(&self.m, c);
        std::array::from_fn(|i| u[i] - mc[i])
    }

    /// `rows p + b`.
    #[inline(always)]
    fn image(&self, p: [f64; 4]) -> [f64; 4] {
        let u = apply(&self.rows, p);
        std::array::from_fn(|i| u[i] + self.b[i])
    }

    /// The tiled ball's distance at `p`: to the copy of the cell `p` is in.
    pub fn value(&self, p: [f64; 4]) -> f64 {
        let c = self.tiling.nearest(self.lattice(p));
        let u = self.local(self.image(p), c);
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
        let w = apply(&self.to, d);
        let (u, along) = (self.image(p), apply(&self.rows, d));
        let mut c = self.tiling.nearest(q);
        let here = self.local(u, c);
        let value = dot(here, here).sqrt() - self.r;
        let mut from = 0.0;
        let meeting = |first, clear, cells| Meeting {
            value,
            first,
            clear,
            cells,
        };
        for k in 0..cells {
            if from > limit {
                return meeting(None, from, k);
            }
            let x = std::array::from_fn(|i| q[i] - c[i]);
            let (to, n) = self.tiling.leave(c, x, w);
            let to = to.max(from);
            if let Some((t0, t1)) = super::ball_roots(self.local(u, c), along, self.r) {
                let t = t0.max(from);
                if t <= t1.min(to) {
                    return meeting(Some(t), t, k + 1);
                }
            }
            // A grid's end cell, left along no axis: nothing more to meet.
            if to == f64::INFINITY {
                return meeting(None, to, k + 1);
            }
            from = to;
            c = std::array::from_fn(|i| c[i] + n[i]);
        }
        meeting(None, from, cells)
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
        let (t, n) = Tiling::D4.leave(c, x, [3e-4, -3e-4, 1.0, 0.0]);
        assert!(t.is_finite() && t > 0.0, "{t}");
        assert_eq!(n.iter().map(|v| v * v).sum::<f64>(), 2.0);
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
                let (t, n) = tiling.leave(c, x, w);
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
