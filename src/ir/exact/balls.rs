//! A cell's pieces, with the moved hyperspheres among them (balls seen from outside whose rows
//! are the identity's: most of a union's) also laid out a coordinate at a time. Meeting those
//! is one loop without branches, which the compiler runs two balls at a time, with the same
//! arithmetic, in the same order, as `Form::meet` (so the same bits).

use super::{Form, IDENTITY, Meeting, Piece};
use std::ops::Deref;

/// Balls met in one pass of the loop.
const CHUNK: usize = 8;

/// The pieces of a cell, in the objects' order (which settles ties), and their moved balls.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Pieces {
    list: Vec<Piece>,
    /// Whether each piece is one of the moved balls, in order.
    moved: Vec<bool>,
    /// The moved balls' offsets `b` (their centres negated), coordinate by coordinate, and
    /// their radii.
    b: [Vec<f64>; 4],
    r: Vec<f64>,
}

impl From<Vec<Piece>> for Pieces {
    fn from(list: Vec<Piece>) -> Pieces {
        let is_moved = |p: &Piece| matches!(&p.form, Form::Ball { rows, sign, .. } if *rows == IDENTITY && *sign == 1.0);
        // One ball alone is met as fast by `Form::meet`.
        let many = list.iter().filter(|p| is_moved(p)).count() > 1;
        let moved: Vec<bool> = list.iter().map(|p| many && is_moved(p)).collect();
        let mut pieces = Pieces {
            list: vec![],
            moved,
            b: Default::default(),
            r: vec![],
        };
        for (p, _) in list.iter().zip(&pieces.moved).filter(|(_, m)| **m) {
            if let Form::Ball { b, r, .. } = &p.form {
                (0..4).for_each(|i| pieces.b[i].push(b[i]));
                pieces.r.push(*r);
            }
        }
        pieces.list = list;
        pieces
    }
}

impl Deref for Pieces {
    type Target = [Piece];

    fn deref(&self) -> &[Piece] {
        &self.list
    }
}

impl Pieces {
    /// How the ray from `p` along `d` meets each piece (`Form::meet`), in order.
    #[inline(always)]
    pub fn meet_each(
        &self,
        p: [f64; 4],
        d: [f64; 4],
        reach: (f64, usize),
        mut each: impl FnMut(&Piece, Meeting),
    ) {
        // Eight balls at a time: buffers for all of them cost more to clear than one ball
        // to meet.
        let (mut value, mut first) = ([0.0; CHUNK], [0.0; CHUNK]);
        let mut k = 0;
        for (piece, &moved) in self.list.iter().zip(&self.moved) {
            let m = if moved {
                let at = k % CHUNK;
                if at == 0 {
                    let to = self.r.len().min(k + CHUNK);
                    self.meet_moved(p, d, k..to, &mut value, &mut first);
                }
                k += 1;
                Meeting {
                    value: value[at],
                    first: (first[at] < f64::INFINITY).then_some(first[at]),
                    clear: f64::INFINITY,
                    cells: 0,
                }
            } else {
                piece.form.meet(p, d, reach)
            };
            each(piece, m);
        }
    }

    /// The moved balls' values and first roots ahead (infinity: none), as `Form::meet` and
    /// `ball_roots` compute them for a ball of sign 1 and the identity's rows.
    fn meet_moved(
        &self,
        p: [f64; 4],
        d: [f64; 4],
        range: std::ops::Range<usize>,
        value: &mut [f64; CHUNK],
        first: &mut [f64; CHUNK],
    ) {
        let a = d[0] * d[0] + d[1] * d[1] + d[2] * d[2] + d[3] * d[3];
        let [b0, b1, b2, b3] = self.b.each_ref().map(|b| &b[range.clone()]);
        let r = &self.r[range];
        let balls = (b0.iter().zip(b1).zip(b2).zip(b3).zip(r)).zip(value.iter_mut().zip(first));
        for (((((b0, b1), b2), b3), &r), (value, first)) in balls {
            let u = [p[0] + b0, p[1] + b1, p[2] + b2, p[3] + b3];
            let uu = u[0] * u[0] + u[1] * u[1] + u[2] * u[2] + u[3] * u[3];
            let half_b = u[0] * d[0] + u[1] * d[1] + u[2] * d[2] + u[3] * d[3];
            let norm = uu.sqrt();
            *value = norm - r;
            let wide = half_b * half_b - a * (uu - r * r) < -1e-9 * a * (uu + r * r);
            let c = (norm - r) * (norm + r);
            let disc = half_b * half_b - a * c;
            let q = -(half_b + disc.sqrt().copysign(half_b));
            let (t0, t1) = (q / a, if q != 0.0 { c / q } else { 0.0 });
            let (lo, hi) = (t0.min(t1), t0.max(t1));
            let none = wide || r <= 0.0 || a == 0.0 || disc < 0.0 || disc.is_nan();
            *first = match (none, lo >= 0.0, hi >= 0.0) {
                (false, true, _) => lo,
                (false, false, true) => hi,
                _ => f64::INFINITY,
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn ball(c: [f64; 4], r: f64, sign: f64, object: f64) -> Piece {
        let rows = if object == 3.0 {
            // A turned one, which `Form::meet` meets in the cell's loop.
            [
                [0.6, 0.8, 0.0, 0.0],
                [-0.8, 0.6, 0.0, 0.0],
                [0.0, 0.0, 1.0, 0.0],
                [0.0, 0.0, 0.0, 1.0],
            ]
        } else {
            IDENTITY
        };
        Piece {
            form: Form::Ball {
                rows,
                b: c.map(|x| -x),
                r,
                sign,
            },
            object,
        }
    }

    proptest! {
        /// The moved balls' pass gives every piece's meeting to the bit, as `Form::meet` does,
        /// beside a plane, a turned ball and a complement, for rays from anywhere (inside
        /// balls, on their surfaces, grazing them).
        #[test]
        fn moved_balls_meet_as_their_forms_do(
            balls in prop::collection::vec(
                (prop::array::uniform4(-3.0..3.0f64), 0.0..1.5f64, 0..5u8),
                1..20,
            ),
            p in prop::array::uniform4(-4.0..4.0f64),
            d in prop::array::uniform4(-1.0..1.0f64),
            on in 0..3u8,
        ) {
            let mut list: Vec<Piece> = (balls.iter().enumerate())
                .map(|(i, (c, r, kind))| match kind {
                    0 => ball(*c, *r, -1.0, i as f64),
                    1 => Piece { form: Form::Plane { g: [0.0, 1.0, 0.0, 0.0], c: c[0] }, object: 9.0 },
                    _ => ball(*c, *r, 1.0, i as f64),
                })
                .collect();
            list.push(ball([0.5; 4], 0.7, 1.0, 3.0));
            // Rays from a ball's surface, or along a tangent.
            let (mut p, mut d) = (p, d);
            if let (1.., Form::Ball { b, r, .. }) = (on, &list[0].form) {
                let len = p.iter().map(|x| x * x).sum::<f64>().sqrt().max(1e-9);
                p = std::array::from_fn(|i| -b[i] + p[i] / len * r);
                if on == 2 {
                    d = [-p[1] - b[1], p[0] + b[0], 0.0, 0.0];
                }
            }
            let pieces = Pieces::from(list.clone());
            let mut got = vec![];
            pieces.meet_each(p, d, (10.0, 64), |piece, m| got.push((piece.object, m)));
            prop_assert_eq!(got.len(), list.len());
            for (piece, (object, m)) in list.iter().zip(got) {
                let want = piece.form.meet(p, d, (10.0, 64));
                prop_assert_eq!(object, piece.object);
                prop_assert_eq!(m.value.to_bits(), want.value.to_bits());
                prop_assert_eq!(m.first.map(f64::to_bits), want.first.map(f64::to_bits));
                prop_assert_eq!((m.clear, m.cells), (want.clear, want.cells));
            }
        }
    }
}
