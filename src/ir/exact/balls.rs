//! A cell's pieces, with the moved hyperspheres among them (balls seen from outside whose rows
//! are the identity's: most of a union's) also laid out a coordinate at a time. Meeting those
//! is one loop without branches, which the compiler runs two balls at a time, with the same
//! arithmetic, in the same order, as `Form::meet` (so the same bits).

use super::{Form, Meeting, Piece, roots, wide};
use std::ops::Deref;

/// Balls met in one pass of the loop.
const CHUNK: usize = 8;

/// The pieces of a cell, in the objects' order (which settles ties), and their moved balls.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Pieces {
    list: Vec<Piece>,
    /// Apart, so that a cell without them stays as small as it was.
    moved: Option<Box<Moved>>,
}

/// The moved balls among a cell's pieces.
#[derive(Clone, Debug, Default, PartialEq)]
struct Moved {
    /// Whether each piece is one of them, in order.
    is: Vec<bool>,
    /// Their offsets `b` (their centres negated), coordinate by coordinate, and radii.
    b: [Vec<f64>; 4],
    r: Vec<f64>,
}

impl From<Vec<Piece>> for Pieces {
    fn from(list: Vec<Piece>) -> Pieces {
        let is_moved = |p: &Piece| matches!(&p.form, Form::Ball { rows, sign, .. } if rows.identity() && *sign == 1.0);
        // One ball alone is met as fast by `Form::meet`.
        let moved = (list.iter().filter(|p| is_moved(p)).count() > 1).then(|| {
            let mut moved = Moved {
                is: list.iter().map(is_moved).collect(),
                ..Moved::default()
            };
            for p in &list {
                if let (true, Form::Ball { b, r, .. }) = (is_moved(p), &p.form) {
                    (0..4).for_each(|i| moved.b[i].push(b[i]));
                    moved.r.push(*r);
                }
            }
            Box::new(moved)
        });
        Pieces { list, moved }
    }
}

impl Deref for Pieces {
    type Target = [Piece];

    fn deref(&self) -> &[Piece] {
        &self.list
    }
}

impl Pieces {
    /// Whether some piece is of object `object`.
    pub fn of(&self, object: usize) -> bool {
        self.list.iter().any(|p| p.object == object as f64)
    }

    /// Whether some pieces are moved balls, which `meetings` meets together.
    pub fn has_moved(&self) -> bool {
        self.moved.is_some()
    }

    /// How the ray from `p` along `d` meets each piece (`Form::meet`), in order.
    #[inline(always)]
    pub fn meetings(&self, p: [f64; 4], d: [f64; 4], reach: (f64, usize)) -> Meetings<'_> {
        Meetings {
            pieces: self,
            ray: (p, d, reach),
            i: 0,
            k: 0,
            value: [0.0; CHUNK],
            first: [0.0; CHUNK],
        }
    }
}

/// The meetings of a ray with a cell's pieces (`Pieces::meetings`): the `i`th piece next, the
/// `k`th moved ball, whose chunk of `CHUNK` is met at its first.
pub struct Meetings<'a> {
    pieces: &'a Pieces,
    ray: ([f64; 4], [f64; 4], (f64, usize)),
    i: usize,
    k: usize,
    value: [f64; CHUNK],
    first: [f64; CHUNK],
}

impl<'a> Iterator for Meetings<'a> {
    type Item = (&'a Piece, Meeting);

    #[inline(always)]
    fn next(&mut self) -> Option<(&'a Piece, Meeting)> {
        let (p, d, reach) = self.ray;
        let piece = self.pieces.list.get(self.i)?;
        let m = match self.pieces.moved.as_deref() {
            Some(moved) if moved.is[self.i] => {
                let at = self.k % CHUNK;
                if at == 0 {
                    let to = moved.r.len().min(self.k + CHUNK);
                    moved.meet(p, d, self.k..to, &mut self.value, &mut self.first);
                }
                self.k += 1;
                Meeting {
                    value: self.value[at],
                    first: (self.first[at] < f64::INFINITY).then_some(self.first[at]),
                    clear: f64::INFINITY,
                    cells: 0,
                }
            }
            _ => piece.form.meet(p, d, reach),
        };
        self.i += 1;
        Some((piece, m))
    }
}

impl Moved {
    /// The balls' values and first roots ahead (infinity: none) in `range`, as `Form::meet`
    /// and `ball_roots` compute them for a ball of sign 1 and the identity's rows.
    fn meet(
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
            *value = uu.sqrt() - r;
            let (meets, lo, hi) = roots(a, half_b, uu, r);
            *first = match (meets & !wide(a, half_b, uu, r), lo >= 0.0, hi >= 0.0) {
                (true, true, _) => lo,
                (true, false, true) => hi,
                _ => f64::INFINITY,
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::IDENTITY;
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
                rows: rows.into(),
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
            let got: Vec<(f64, Meeting)> =
                pieces.meetings(p, d, (10.0, 64)).map(|(piece, m)| (piece.object, m)).collect();
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
