//! Where a piece cannot stop a ray: a convex set in which its value is positive. A segment
//! between two points of the set stays in it, so it meets no surface of the piece: a shadow
//! ray from inside a room's hollow towards a lamp in the same hollow need not meet the room.

use super::{Form, dot};

impl Form {
    /// A convex set where this form's value is positive, as a form `g` whose value is below
    /// zero just there and is, there, minus this form's: the hollow of a shell of a convex
    /// solid (`|f| - k`, where `f < -k`), the inside of a complement (a box or ball seen from
    /// inside, `-f`), the far side of a plane. None for the other forms: their positive side
    /// is not convex, or (`|f| + c`) no ray meets them anyway.
    pub fn free_region(&self) -> Option<Form> {
        let solid = |f: &Form| match f {
            Form::Plane { .. } => true,
            Form::Ball { sign, .. } | Form::Box { sign, .. } | Form::Hull { sign, .. } => {
                *sign > 0.0
            }
            Form::Abs { .. } | Form::Lattice(_) => false,
        };
        match self {
            Form::Abs { f, k } if *k >= 0.0 && solid(f) => Some(f.as_ref().clone().plus(*k)),
            Form::Plane { .. } => self.clone().neg(),
            f if !solid(f) => f.clone().neg().filter(solid),
            _ => None,
        }
    }

    /// Whether the ball of `radius` around `center` lies where this form, a `free_region`, is
    /// below `-margin` (a margin of its value, a distance where its rows are orthonormal): a
    /// sufficient test, from the rows' lengths, with a rounded box's sharp core and a linear
    /// image's Frobenius norm. False for forms `free_region` never gives.
    pub fn holds_ball(&self, center: [f64; 4], radius: f64, margin: f64) -> bool {
        let length = |v: [f64; 4]| dot(v, v).sqrt();
        let below = |v: f64| v < -margin;
        match self {
            Form::Plane { g, c } => below(dot(*g, center) + c + radius * length(*g)),
            Form::Hull { planes, sign } if *sign > 0.0 => {
                (planes.iter()).all(|(g, c)| below(dot(*g, center) + c + radius * length(*g)))
            }
            Form::Ball { rows, b, r, sign } if *sign > 0.0 => {
                let u = super::image(rows, b, center);
                let norm = rows.iter().map(|row| dot(*row, *row)).sum::<f64>().sqrt();
                below(length(u) + radius * norm - r)
            }
            Form::Box {
                rows,
                b,
                half,
                r,
                sign,
            } if *sign > 0.0 => {
                let u = super::image(rows, b, center);
                (0..4).all(|i| below(u[i].abs() + radius * length(rows[i]) - half[i] - r.min(0.0)))
            }
            _ => false,
        }
    }

    /// Whether this form, a `free_region`, is below `level` at `p`: `value(p) < level` but
    /// within rounding of the level, comparing squares where a value takes square roots
    /// (false for forms `free_region` never gives).
    #[inline]
    pub fn below(&self, p: [f64; 4], level: f64) -> bool {
        let under = |x: f64, top: f64| top > 0.0 && x < top * top;
        match self {
            Form::Plane { g, c } => dot(*g, p) + c < level,
            Form::Hull { planes, sign } if *sign > 0.0 => {
                (planes.iter()).all(|(g, c)| dot(*g, p) + c < level)
            }
            Form::Ball { rows, b, r, sign } if *sign > 0.0 => {
                let u = super::local(rows, b, p, p).0;
                under(dot(u, u), r + level)
            }
            Form::Box {
                rows,
                b,
                half,
                r,
                sign,
            } if *sign > 0.0 => {
                let u = super::local(rows, b, p, p).0;
                let q: [f64; 4] = std::array::from_fn(|i| u[i].abs() - half[i]);
                let top = r + level;
                // Inside the sharp box its distance is its largest `q`; outside, the length
                // of the positive ones.
                match q.iter().all(|&q| q <= 0.0) {
                    true => q.iter().all(|&q| q < top),
                    false => under(q.iter().map(|&q| q.max(0.0).powi(2)).sum(), top),
                }
            }
            _ => false,
        }
    }
}

/// Forms of every kind that has a free region, for tests here and of what uses them.
#[cfg(test)]
pub(crate) mod testing {
    use super::super::{IDENTITY, Rows};
    use super::*;

    pub fn unit(v: [f64; 4]) -> [f64; 4] {
        let n = dot(v, v).sqrt();
        v.map(|x| x / n)
    }

    /// A form of every kind `free_region` takes, from the numbers drawn.
    pub fn form(kind: u8, a: [f64; 4], v: [f64; 4], s: f64, turn: f64) -> Form {
        let (c, sn) = (turn.cos(), turn.sin());
        let rows = Rows::from(if turn == 0.0 {
            IDENTITY
        } else {
            [
                [c, -sn, 0.0, 0.0],
                [sn, c, 0.0, 0.0],
                [0.0, 0.0, 1.0, 0.0],
                [0.0, 0.0, 0.0, 1.0],
            ]
        });
        let half = v.map(|x| x.abs() + 0.5);
        let boxed = |r: f64, sign: f64| Form::Box {
            rows,
            b: a,
            half,
            r,
            sign,
        };
        let ball = |sign: f64| Form::Ball {
            rows,
            b: a,
            r: 2.0 + s.abs(),
            sign,
        };
        let hull = |sign: f64| Form::Hull {
            planes: (0..4)
                .map(|i| {
                    let mut g = [0.0; 4];
                    g[i] = 1.0;
                    (
                        unit([g[0] + v[1], g[1], g[2] + v[3], g[3] + 0.1]),
                        -1.5 - v[i].abs(),
                    )
                })
                .collect(),
            sign,
        };
        let shell = |f: Form| Form::Abs {
            f: Box::new(f),
            k: 0.05 + 0.2 * s.abs(),
        };
        match kind % 9 {
            0 => Form::Plane { g: unit(v), c: s },
            1 => shell(boxed(0.0, 1.0)),
            2 => shell(boxed(0.3 * s.abs(), 1.0)),
            3 => shell(ball(1.0)),
            4 => shell(hull(1.0)),
            5 => boxed(0.4 * s, -1.0),
            6 => ball(-1.0),
            7 => hull(-1.0),
            _ => shell(Form::Plane { g: unit(v), c: s }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{IDENTITY, Rows};
    use super::testing::{form, unit};
    use super::*;
    use proptest::prelude::*;

    /// Forms of every kind with a free region (`testing::form`).
    fn forms() -> impl Strategy<Value = Form> {
        let coordinates = || prop::array::uniform4(-1.0..1.0f64);
        let turn = prop_oneof![Just(0.0), -1.0..1.0f64];
        (0u8..9, coordinates(), coordinates(), -1.0..1.0f64, turn)
            .prop_map(|(kind, a, v, s, turn)| form(kind, a, v, s, turn))
    }

    proptest! {
        /// Where `holds_ball` says a ball lies in a form's free region, the form's value is
        /// above the margin at points all over the ball, and the free region's value there is
        /// minus the form's; and the forms free regions are asked of have one.
        #[test]
        fn a_held_ball_is_free_of_the_form(
            f in forms(),
            center in prop::array::uniform4(-3.0..3.0f64),
            radius in 0.0..1.5f64,
            ways in prop::collection::vec(prop::array::uniform4(-1.0..1.0f64), 64),
        ) {
            let free = f.free_region().expect("every drawn form has a free region");
            if free.holds_ball(center, radius, 1e-9) {
                for w in ways {
                    let p: [f64; 4] = std::array::from_fn(|i| center[i] + radius * unit(w)[i]);
                    let (value, g) = (f.value(p), free.value(p));
                    prop_assert!(value > 1e-9, "{f:?} at {p:?}: {value}");
                    prop_assert!((value + g).abs() <= 1e-12 * (1.0 + value.abs()), "{value} {g}");
                }
            }
        }
    }

    proptest! {
        /// `below` is `value < level` at points inside, outside and near every free region,
        /// but within rounding of the level.
        #[test]
        fn below_is_the_values(
            f in forms(),
            p in prop::array::uniform4(-4.0..4.0f64),
            level in -1.0..0.5f64,
        ) {
            let free = f.free_region().expect("a free region");
            let value = free.value(p);
            if (value - level).abs() > 1e-12 {
                prop_assert_eq!(free.below(p, level), value < level, "{:?} {}", free, value);
            }
        }
    }

    /// A room's hollow holds a lamp under its ceiling, not one in its wall; a solid ball, a
    /// shell of a complement and a tiled ball have no free region.
    #[test]
    fn a_room_holds_its_lamp() {
        let room = Form::Abs {
            f: Box::new(Form::Box {
                rows: Rows::from(IDENTITY),
                b: [0.0, 0.0, 2.0, 0.0],
                half: [2.0, 1.5, 4.0, 2.0],
                r: 0.0,
                sign: 1.0,
            }),
            k: 0.1,
        };
        let free = room.free_region().expect("a shell of a box has a hollow");
        assert!(free.holds_ball([0.0, 0.95, -2.5, 0.0], 0.4, 1e-9));
        assert!(!free.holds_ball([0.0, 1.2, -2.5, 0.0], 0.4, 1e-9));
        let ball = Form::Ball {
            rows: Rows::from(IDENTITY),
            b: [0.0; 4],
            r: 1.0,
            sign: 1.0,
        };
        assert_eq!(ball.free_region(), None);
        let hollow_outside = Form::Abs {
            f: Box::new(ball.clone().neg().expect("a ball negates")),
            k: 0.1,
        };
        assert_eq!(hollow_outside.free_region(), None);
        assert!(ball.neg().and_then(|b| b.free_region()).is_some());
    }
}
