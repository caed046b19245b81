//! Distances that rays can meet exactly: where a cell's scene distance is the smallest of a
//! few planes, spheres, boxes and polytopes (halfspaces, the faces of a box seen from inside, a
//! hypersphere alone, a turned and rounded hyperbox, the cut bound of what is far) or shells
//! of them (`|f| - k`: `onion`, and the unsigned distance that rays inside objects march
//! on), the marcher intersects each in `f64` instead of stepping towards it. A ray grazing a
//! plane or a large sphere would otherwise take thousands of steps, each a little shorter
//! than the gap it closes. A box, sharp or rounded, is met in closed form piece by piece of the
//! ray (`boxes`), and a ball tiled over a lattice cell by cell (`lattice`).

mod balls;
mod boxes;
mod cover;
mod free;
#[cfg(test)]
pub(crate) use free::testing;
mod lattice;

use super::{Bin, Graph, Id, K, Node, Un, Var};
use crate::math::lanes::{self, F4, Lane, each};
pub use balls::{Meetings, Pieces};
pub use cover::{Cover, cover};
pub use lattice::{CELLS, Tiled, Tiling};

/// One piece of a distance, on object `object`.
#[derive(Clone, Debug, PartialEq)]
pub struct Piece {
    pub form: Form,
    pub object: f64,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Form {
    /// `g . p + c`
    Plane { g: [f64; 4], c: f64 },
    /// `sign (|A p + b| - r)`, with the rows of `A` in `rows`: a hypersphere (or, seen from
    /// inside, its complement) of a linear image of the point (`first` solves any `A`; the
    /// pieces of cells have orthonormal rows, so that the value is a distance).
    Ball {
        rows: Rows,
        b: [f64; 4],
        r: f64,
        sign: f64,
    },
    /// `sign (box(A p + b) - r)`, `box` the distance to the sharp hyperbox of half-extents
    /// `half`: the box grown by `r` and rounded where `r > 0`, shrunk where it is negative,
    /// its complement where `sign` is `-1` (rows as for `Ball`).
    Box {
        rows: Rows,
        b: [f64; 4],
        half: [f64; 4],
        r: f64,
        sign: f64,
    },
    /// `sign max_i (g_i . p + c_i)`: a convex polytope (an intersection of halfspaces, the
    /// 16-cell's `sum |u_i|`, the 24-cell), or its complement where `sign` is `-1`. The value
    /// is the scene's own expression (outside the polytope, a bound of the distance only as
    /// good as the scene's: unit gradients make it one); the surface is met exactly.
    Hull {
        planes: Vec<([f64; 4], f64)>,
        sign: f64,
    },
    /// `|f| - k`, `f` a plane, ball, box or polytope (`k` may be negative: `|f| + c`, which
    /// no ray meets): a shell (`onion`), or seen from inside objects,
    /// where distances are unsigned. A ray meets the form on its own side of `f`.
    Abs { f: Box<Form>, k: f64 },
    /// A ball copied to every point of a lattice (`tile`): each point's copy in its cell.
    Lattice(Box<Tiled>),
}

/// The rows of a form's linear map `A`, and whether they are the identity's: most balls and
/// boxes are only moved, and comparing the sixteen entries at each meeting cost a tenth of
/// meeting a room's three pieces.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rows {
    a: [[f64; 4]; 4],
    identity: bool,
}

impl From<[[f64; 4]; 4]> for Rows {
    fn from(a: [[f64; 4]; 4]) -> Rows {
        Rows {
            a,
            identity: a == IDENTITY,
        }
    }
}

impl std::ops::Deref for Rows {
    type Target = [[f64; 4]; 4];
    fn deref(&self) -> &[[f64; 4]; 4] {
        &self.a
    }
}

impl Rows {
    /// Whether `A` is the identity.
    pub fn identity(&self) -> bool {
        self.identity
    }
}

/// The ray from `p` along `d` in a form's coordinates `A p + b` (the rows of `A` in `rows`).
/// Rows that are the identity's add and multiply nothing (exactly, as the products would).
#[inline(always)]
fn local(rows: &Rows, b: &[f64; 4], p: [f64; 4], d: [f64; 4]) -> ([f64; 4], [f64; 4]) {
    if rows.identity {
        (std::array::from_fn(|i| p[i] + b[i]), d)
    } else {
        (image(rows, b, p), std::array::from_fn(|i| dot(rows[i], d)))
    }
}

/// `A p + b` (the rows of `A` in `rows`), at one point or four.
#[inline(always)]
fn image<L: Lane>(rows: &Rows, b: &[f64; 4], p: [L; 4]) -> [L; 4] {
    each(|i| lanes::dot(rows[i].map(L::splat), p) + L::splat(b[i]))
}

pub(super) const IDENTITY: [[f64; 4]; 4] = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

#[inline(always)]
fn dot(a: [f64; 4], b: [f64; 4]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
}

/// How a ray goes with a form (`Form::reach`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reach {
    /// It starts outside the form and never reaches its surface.
    Missed,
    /// It starts inside the form or on it, or reaches its surface.
    Reached,
    /// A lattice crossing was given up before either showed.
    Unknown,
}

/// What a ray meets of a form (`Form::meet`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Meeting {
    /// The distance at the ray's point.
    pub value: f64,
    /// The first `t` at which the ray reaches the surface, if it does before `clear`.
    pub first: Option<f64>,
    /// How far the ray is known to meet no surface of the form.
    pub clear: f64,
    /// Lattice cells crossed (0 but for a tiled ball): the work the meeting cost.
    pub cells: usize,
}

impl Form {
    /// Whether the ray from `p` along `d`, however far it goes, misses the form or reaches
    /// it, and the lattice cells that took: an escape proof's meeting of a cover's form
    /// (`cover`).
    pub fn reach(&self, p: [f64; 4], d: [f64; 4]) -> (Reach, usize) {
        let m = self.meet(p, d, (f64::INFINITY, CELLS));
        let reach = if m.value <= 0.0 || m.first.is_some() {
            Reach::Reached
        } else if m.clear == f64::INFINITY {
            Reach::Missed
        } else {
            Reach::Unknown
        };
        (reach, m.cells)
    }

    /// The distance at `p`.
    pub fn value(&self, p: [f64; 4]) -> f64 {
        match self {
            Form::Plane { g, c } => dot(*g, p) + c,
            Form::Ball { rows, b, r, sign } => {
                let u = image(rows, b, p);
                sign * (dot(u, u).sqrt() - r)
            }
            Form::Box {
                rows,
                b,
                half,
                r,
                sign,
            } => sign * boxes::value(image(rows, b, p), *half, *r),
            Form::Hull { planes, sign } => sign * hull_max(planes, p),
            Form::Abs { f, k } => f.value(p).abs() - k,
            Form::Lattice(t) => t.value(p),
        }
    }

    /// The sign of `value(p)`, 1 or -1 (either on the surface), at one point or four: a box's
    /// without the square root of its value, which the gradient of a shell of it would wait
    /// for; another form's lane by lane.
    #[inline(always)]
    fn side<L: Lane>(&self, p: [L; 4]) -> L {
        match self {
            Form::Box {
                rows,
                b,
                half,
                r,
                sign,
            } => L::splat(*sign) * boxes::sign(image(rows, b, p), *half, *r),
            _ => L::each(|l| match self.value(lanes::lane(p, l)) >= 0.0 {
                true => 1.0,
                false => -1.0,
            }),
        }
    }

    /// The gradient of the distance at `p` (one point or four), where it has one (none for a
    /// tiled ball): where two faces or planes tie (an edge, a ridge) that of the first, as the
    /// tapes' `max` takes.
    #[inline(always)]
    pub fn gradient<L: Lane>(&self, p: [L; 4]) -> Option<[L; 4]> {
        match self {
            // A shell holds a plane, ball, box or hull (`min_of_forms`): no recursion, so that
            // four points' gradients stay in the vector code they are called from.
            Form::Abs { f, .. } => {
                let s = f.side(p);
                Some(f.base_gradient(p)?.map(|x| s * x))
            }
            f => f.base_gradient(p),
        }
    }

    /// `gradient` of a form that is no shell.
    #[inline(always)]
    fn base_gradient<L: Lane>(&self, p: [L; 4]) -> Option<[L; 4]> {
        // `A^T v`: back from the form's coordinates.
        let back = |rows: &Rows, v: [L; 4]| match rows.identity {
            true => v,
            false => each(|j| {
                let term = |i: usize| L::splat(rows[i][j]) * v[i];
                term(0) + term(1) + term(2) + term(3)
            }),
        };
        let times = |s: f64, v: [L; 4]| v.map(|x| L::splat(s) * x);
        Some(match self {
            Form::Plane { g, .. } => g.map(L::splat),
            Form::Ball { rows, b, sign, .. } => {
                let u = image(rows, b, p);
                let n = lanes::dot(u, u).sqrt();
                back(rows, times(*sign, u).map(|x| x / n))
            }
            Form::Box {
                rows,
                b,
                half,
                sign,
                ..
            } => back(
                rows,
                times(*sign, boxes::gradient(image(rows, b, p), *half)),
            ),
            Form::Hull { planes, sign } => {
                let (mut top, mut g) = (L::splat(f64::NEG_INFINITY), [L::splat(0.0); 4]);
                for (n, c) in planes {
                    let v = lanes::dot(n.map(L::splat), p) + L::splat(*c);
                    let higher = v.gt(top);
                    top = L::select(higher, v, top);
                    g = each(|i| L::select(higher, L::splat(n[i]), g[i]));
                }
                times(*sign, g)
            }
            Form::Abs { .. } => unreachable!("a shell holds no shell"),
            Form::Lattice(_) => return None,
        })
    }

    /// Whether `meet` always finds the first point or says there is none: not for a tiled
    /// ball, whose crossing of its lattice may give up.
    pub fn closed(&self) -> bool {
        match self {
            Form::Abs { f, .. } => f.closed(),
            Form::Lattice(_) => false,
            Form::Plane { .. } | Form::Ball { .. } | Form::Box { .. } | Form::Hull { .. } => true,
        }
    }

    /// What the ray from `p` along `d` meets: the first `t >= 0` at which it reaches the
    /// surface, coming from where the distance is positive, if it does before `clear`, how far
    /// it is known to meet none: infinity but for a tiled ball, where it is at least `limit`
    /// unless its crossing gave up before, after `cells` of its lattice's cells (`Tiled::meet`).
    #[inline(always)]
    pub fn meet(&self, p: [f64; 4], d: [f64; 4], reach: (f64, usize)) -> Meeting {
        match self {
            // `|f| + c` stays at least `c`: no surface.
            Form::Abs { k, .. } if *k < 0.0 => Meeting {
                value: self.value(p),
                first: None,
                clear: f64::INFINITY,
                cells: 0,
            },
            Form::Abs { f, k } => f.meet_side(p, d, Some(*k)),
            Form::Lattice(t) => t.meet(p, d, reach),
            _ => self.meet_side(p, d, None),
        }
    }

    /// What up to four rays meet (`meet` lane by lane, with no first meeting as NaN). Balls
    /// and boxes and their shells meet them together in the lanes of vectors, with branches
    /// only where all four pass a ball wide or every ray is done with a box before a rounded
    /// box's last steps; planes lane by lane, the other forms one by one. One ray alone meets
    /// a box the same way, in four lanes of the same ray, and a ball with the same code.
    #[inline(always)]
    pub fn meet_lanes(&self, rays: &Rays) -> Lanes {
        let (f, shell) = match self {
            Form::Abs { f, k } if *k >= 0.0 => (&**f, Some(*k)),
            f => (f, None),
        };
        let mut out = Lanes {
            value: [f64::NAN; 4],
            first: [f64::NAN; 4],
            clear: [f64::INFINITY; 4],
            cells: [0; 4],
        };
        match f {
            Form::Plane { g, c } => {
                for l in 0..4 {
                    let (p, d) = (lane(&rays.p, l), lane(&rays.d, l));
                    (out.value[l], out.first[l]) = plane_met(*g, *c, p, d, shell);
                }
            }
            Form::Ball { rows, b, r, sign } => {
                let (u, w) = rays.local(rows, b);
                let (u, w) = (each(|i| F4(u[i])), each(|i| F4(w[i])));
                let (value, first) = ball_met(u, w, *r, *sign, shell);
                (out.value, out.first) = (value.0, first.0);
            }
            Form::Box {
                rows,
                b,
                half,
                r,
                sign,
            } => {
                let (u, w) = rays.local(rows, b);
                let form = (*half, *r, *sign);
                (out.value, out.first) = boxes::meet_lanes((&u, &w), form, shell, rays.live);
            }
            _ => {
                for l in 0..rays.live {
                    let (p, d, reach) = rays.ray(l);
                    let m = self.meet(p, d, reach);
                    (out.value[l], out.clear[l], out.cells[l]) = (m.value, m.clear, m.cells);
                    out.first[l] = m.first.unwrap_or(f64::NAN);
                }
            }
        }
        out
    }

    /// `meet` for a plane, ball or box `f`, or with `shell` `Some(k)`, for `|f| - k`: on the
    /// side of `f` the ray starts on, `f - k` or `-f - k`.
    #[inline(always)]
    fn meet_side(&self, p: [f64; 4], d: [f64; 4], shell: Option<f64>) -> Meeting {
        let (value, first) = match self {
            Form::Plane { g, c } => {
                let (value, first) = plane_met(*g, *c, p, d, shell);
                (value, (!first.is_nan()).then_some(first))
            }
            Form::Ball { rows, b, r, sign } => {
                let (u, w) = local(rows, b, p, d);
                let (value, first) = ball_met(u, w, *r, *sign, shell);
                (value, (!first.is_nan()).then_some(first))
            }
            Form::Box {
                rows,
                b,
                half,
                r,
                sign,
            } => {
                let rays = Rays::new(&[(p, d, (f64::INFINITY, 0))]);
                let (u, w) = rays.local(rows, b);
                let (value, first) = boxes::meet_lanes((&u, &w), (*half, *r, *sign), shell, 1);
                (value[0], (!first[0].is_nan()).then_some(first[0]))
            }
            Form::Hull { planes, sign } => {
                let (s, k) = side(sign * hull_max(planes, p), shell);
                // s f - k = sign' max_i (g_i . p + c_i - sign' k)
                let sign = s * sign;
                let shift = -sign * k;
                let (mut enter, mut leave) = (f64::NEG_INFINITY, f64::INFINITY);
                let mut most = f64::NEG_INFINITY;
                for (g, c) in planes {
                    let (a, rate) = (dot(*g, p) + c + shift, dot(*g, d));
                    most = most.max(a);
                    // Cyrus-Beck: the ray is inside every halfspace `a + rate t <= 0` between
                    // the last entry and the first exit.
                    if rate < 0.0 {
                        enter = enter.max(a / -rate);
                    } else if rate > 0.0 {
                        leave = leave.min(-a / rate);
                    } else if a > 0.0 {
                        (enter, leave) = (f64::INFINITY, f64::NEG_INFINITY);
                    }
                }
                let value = sign * most;
                let first = if value <= 0.0 {
                    Some(0.0)
                } else if sign > 0.0 {
                    (enter <= leave && leave >= 0.0).then(|| enter.max(0.0))
                } else {
                    // An unbounded polytope may hold the ray for good.
                    leave.is_finite().then(|| leave.max(0.0))
                };
                (value, first)
            }
            Form::Abs { .. } | Form::Lattice(_) => unreachable!("meet takes these"),
        };
        Meeting {
            value,
            first,
            clear: f64::INFINITY,
            cells: 0,
        }
    }

    /// The same form plus `k`.
    fn plus(mut self, k: f64) -> Form {
        match &mut self {
            Form::Plane { c, .. } => *c += k,
            Form::Ball { r, sign, .. } | Form::Box { r, sign, .. } => *r -= *sign * k,
            Form::Hull { planes, sign } => planes.iter_mut().for_each(|(_, c)| *c += *sign * k),
            Form::Abs { k: j, .. } => *j -= k,
            Form::Lattice(t) => **t = t.grown(-k),
        }
        self
    }

    /// The form times `-1`: none for a tiled ball, whose inside is no lattice of cells to
    /// cross, nor a shell (`k - |f|` is met on no side of `f` alone).
    fn neg(mut self) -> Option<Form> {
        match &mut self {
            Form::Plane { g, c } => (*g, *c) = (g.map(|x| -x), -*c),
            Form::Ball { sign, .. } | Form::Box { sign, .. } | Form::Hull { sign, .. } => {
                *sign = -*sign
            }
            Form::Abs { .. } | Form::Lattice(_) => return None,
        }
        Some(self)
    }
}

/// The sign to take a form with where it is `v` (`f` or `-f`), and what to take off it: for a
/// shell `|f| - k` (`shell` `Some(k)`) on the side of `f` it is on, else `f` itself.
/// A select, not a branch (`Form::meet_lanes`).
#[inline(always)]
fn side<L: Lane>(v: L, shell: Option<f64>) -> (L, f64) {
    // `v >= 0` fails for NaN too, which takes the negative side.
    let s = match shell {
        Some(_) => L::select(v.ge(L::splat(0.0)), L::splat(1.0), L::splat(-1.0)),
        None => L::splat(1.0),
    };
    (s, shell.unwrap_or(0.0))
}

/// `Form::meet` for the plane `g . p + c`, or with `shell` `Some(k)`, for `|g . p + c| - k`:
/// the value and the first `t` (NaN: none), without branches (`Form::meet_lanes`).
#[inline(always)]
fn plane_met(g: [f64; 4], c: f64, p: [f64; 4], d: [f64; 4], shell: Option<f64>) -> (f64, f64) {
    let a = dot(g, p) + c;
    let (s, k) = side(a, shell);
    let value = s * a - k;
    let rate = s * dot(g, d);
    let first = match rate < 0.0 {
        true => (value / -rate).max(0.0),
        false => f64::NAN,
    };
    (value, first)
}

/// `plane_met` for the ball `sign (|u| - r)` met by the ray `u + t w` (in its coordinates),
/// one ray or four in lanes. Rays that all pass wide of it take a branch past the roots.
#[inline(always)]
fn ball_met<L: Lane>(u: [L; 4], w: [L; 4], r: f64, sign: f64, shell: Option<f64>) -> (L, L) {
    let n = lanes::dot(u, u).sqrt();
    let (s, k) = side(L::splat(sign) * (n - L::splat(r)), shell);
    // s f - k = sign' (|u| - r'), the ball grown or shrunk by `k`.
    let sign = s * L::splat(sign);
    let r = L::splat(r) + sign * L::splat(k);
    let (a, half_b, uu) = (lanes::dot(w, w), lanes::dot(u, w), lanes::dot(u, u));
    let nan = L::splat(f64::NAN);
    let wide = wide(a, half_b, uu, r);
    if L::all(wide) {
        return (sign * (n - r), nan);
    }
    let (meets, lo, hi) = roots(a, half_b, uu, r);
    let zero = L::splat(0.0);
    let ahead = L::select(lo.ge(zero), lo, L::select(hi.ge(zero), hi, nan));
    (sign * (n - r), L::select(meets & !wide, ahead, nan))
}

/// A ray to meet forms with: its point, direction and how far it looks (`Form::meet`'s
/// `reach`).
pub type Aimed = ([f64; 4], [f64; 4], (f64, usize));

/// Up to four rays met together (`Form::meet_lanes`): their points and directions coordinate
/// by coordinate (`p[i][lane]`), and how far each looks (`Form::meet`'s `reach`). The first
/// `live` lanes are the rays; the rest repeat the last, and their numbers are not used.
#[derive(Clone, Copy, Debug)]
pub struct Rays {
    p: boxes::Four,
    d: boxes::Four,
    reach: [(f64, usize); 4],
    live: usize,
}

impl Rays {
    /// The rays (one to four).
    #[inline(always)]
    pub fn new(rays: &[Aimed]) -> Rays {
        Rays::of(rays.len(), |l| rays[l])
    }

    /// The `live` rays (one to four) `ray(0)`, `ray(1)`, ...
    #[inline(always)]
    pub fn of(live: usize, ray: impl Fn(usize) -> Aimed) -> Rays {
        assert!((1..=4).contains(&live), "one to four rays");
        let rays: [Aimed; 4] = std::array::from_fn(|l| ray(l.min(live - 1)));
        Rays {
            p: std::array::from_fn(|i| std::array::from_fn(|l| rays[l].0[i])),
            d: std::array::from_fn(|i| std::array::from_fn(|l| rays[l].1[i])),
            reach: rays.map(|r| r.2),
            live,
        }
    }

    /// The rays in a form's coordinates `A p + b` (`local`, the same numbers), coordinate by
    /// coordinate: the identity's rows asked once for all four.
    #[inline(always)]
    fn local(&self, rows: &Rows, b: &[f64; 4]) -> (boxes::Four, boxes::Four) {
        let (p, d) = (&self.p, &self.d);
        if rows.identity {
            let u = each(|i| each(|l| p[i][l] + b[i]));
            return (u, *d);
        }
        let u = each(|i| {
            let m = &rows[i];
            each(|l| m[0] * p[0][l] + m[1] * p[1][l] + m[2] * p[2][l] + m[3] * p[3][l] + b[i])
        });
        let w = each(|i| {
            let m = &rows[i];
            each(|l| m[0] * d[0][l] + m[1] * d[1][l] + m[2] * d[2][l] + m[3] * d[3][l])
        });
        (u, w)
    }

    /// How many rays there are.
    pub fn live(&self) -> usize {
        self.live
    }

    /// Lane `l`'s ray.
    #[inline(always)]
    pub fn ray(&self, l: usize) -> Aimed {
        (lane(&self.p, l), lane(&self.d, l), self.reach[l])
    }
}

/// Lane `l` of four vectors held coordinate by coordinate.
#[inline(always)]
fn lane(x: &boxes::Four, l: usize) -> [f64; 4] {
    [x[0][l], x[1][l], x[2][l], x[3][l]]
}

/// What up to four rays meet of a form (`Form::meet_lanes`): `Meeting` lane by lane, with no
/// first meeting as NaN. The numbers of lanes past the rays mean nothing.
#[derive(Clone, Copy, Debug)]
pub struct Lanes {
    pub value: [f64; 4],
    pub first: [f64; 4],
    pub clear: [f64; 4],
    pub cells: [usize; 4],
}

/// Where the ray `u + t w` is within `r` of the origin: the roots of `|u + t w| = r`, a
/// quadratic in `t`, solved without cancellation, in order.
#[inline(always)]
fn ball_roots(u: [f64; 4], w: [f64; 4], r: f64) -> Option<(f64, f64)> {
    let (a, half_b, uu) = (dot(w, w), dot(u, w), dot(u, u));
    // Most copies of a tiled ball that a ray passes, it misses: a test without square roots
    // first.
    if wide(a, half_b, uu, r) {
        return None;
    }
    let (meets, lo, hi) = roots(a, half_b, uu, r);
    meets.then_some((lo, hi))
}

/// Whether the ray misses the ball by far more than the rounding of `roots` (`a = w . w`,
/// `half_b = u . w`, `uu = u . u`).
#[inline(always)]
fn wide<L: Lane>(a: L, half_b: L, uu: L, r: L) -> L::Mask {
    (half_b * half_b - a * (uu - r * r)).lt(L::splat(-1e-9) * a * (uu + r * r))
}

/// The roots of `|u + t w| = r` in order, without branches (for the moved balls' loop,
/// `balls`, and four rays in lanes): whether there are any (none where the ball is empty, the
/// direction zero, or the discriminant negative or NaN, from an infinite copy), and the two.
#[inline(always)]
fn roots<L: Lane>(a: L, half_b: L, uu: L, r: L) -> (L::Mask, L, L) {
    let zero = L::splat(0.0);
    let norm = uu.sqrt();
    let c = (norm - r) * (norm + r);
    let disc = half_b * half_b - a * c;
    let q = -(half_b + disc.sqrt().copysign(half_b));
    let (t0, t1) = (q / a, L::select(q.eq(zero), zero, c / q));
    let meets = !(r.le(zero) | a.eq(zero) | disc.lt(zero) | disc.is_nan());
    (meets, t0.min(t1), t0.max(t1))
}

/// Most pieces a cell meets one by one (each a few ns: a hypersphere 14). Cells of more than
/// `vm::cells::FEW_PIECES` still split while that shortens their tapes; this many are met where
/// splitting does not separate them.
pub const MAX_PIECES: usize = 64;

/// The scene's distance `dist` with nearest object `near` as the smallest of a few pieces,
/// when it is one.
pub fn pieces(g: &Graph, dist: Id, near: Id) -> Option<Vec<Piece>> {
    let (exact, rest) = split(g, dist, near, true)?;
    (rest.is_empty() && exact.len() <= MAX_PIECES).then_some(exact)
}

/// Objects of a running min, as (object index, distance).
pub type Members = Vec<(usize, Id)>;

/// The scene's distance `dist` with nearest object `near`, where it is a running min over
/// objects some of which are a few planes, spheres, boxes and polytopes: their pieces, and
/// the other objects (object index, distance). None unless both kinds are there.
pub fn partition(g: &Graph, dist: Id, near: Id) -> Option<(Vec<Piece>, Members)> {
    // A partial cell's pieces are met once, to the cell's side, as a ray enters it; a tiled
    // ball's crossing of its lattice may stop short of it, so tiled balls are the rest's.
    let (exact, rest) = split(g, dist, near, false)?;
    let surface = |p: &Piece| !matches!(p.form, Form::Plane { g, .. } if g == [0.0; 4]);
    (exact.iter().any(surface) && !rest.is_empty() && exact.len() <= MAX_PIECES)
        .then_some((exact, rest))
}

/// The running min over objects at `dist` (nearest object `near`) split into the pieces of
/// the objects that are a few planes, spheres, boxes and polytopes (and, when `open`, tiled
/// balls, whose meeting may stop short: `Form::closed`) and the other objects; None where
/// `dist` is no such min. Objects whose pieces would make more than `MAX_PIECES` are the
/// rest's, those of fewest pieces taken first: a floor and a lamp stay exact beside a union
/// of many boxes. The pieces keep the objects' order, which settles ties.
fn split(g: &Graph, dist: Id, near: Id, open: bool) -> Option<(Vec<Piece>, Members)> {
    let mut members = vec![];
    split_at(g, (dist, near), open, &mut members)?;
    // The running min starts at +infinity, which is no surface.
    // (Not `-inf`, a field that is inside everywhere, which every ray meets where it starts.)
    let start =
        |f: &Form| matches!(f, Form::Plane { g, c } if *g == [0.0; 4] && *c == f64::INFINITY);
    for (_, _, forms) in &mut members {
        if let Some(forms) = forms {
            forms.retain(|f| !start(f));
        }
    }
    // A constant object (`object < 0`: the start, what the cut objects folded into) must be
    // exact; of the others, those of fewest pieces first.
    let mut order: Vec<usize> = (0..members.len()).collect();
    order.sort_by_key(|&i| {
        let (object, _, forms) = &members[i];
        (*object >= 0.0, forms.as_ref().map_or(usize::MAX, Vec::len))
    });
    let mut exact_ones = vec![false; members.len()];
    let mut count = 0;
    for i in order {
        match &members[i] {
            (object, _, Some(forms)) if *object < 0.0 || count + forms.len() <= MAX_PIECES => {
                count += forms.len();
                exact_ones[i] = true;
            }
            (object, ..) if *object >= 0.0 => {}
            _ => return None,
        }
    }
    let (mut exact, mut rest) = (vec![], vec![]);
    for ((object, member, forms), exact_one) in members.into_iter().zip(exact_ones) {
        match forms {
            Some(forms) if exact_one => {
                exact.extend(forms.into_iter().map(|form| Piece { form, object }))
            }
            _ => rest.push((object as usize, member)),
        }
    }
    Some((exact, rest))
}

/// The members of the running min-with-id at `dist` (nearest object `near`): its `best`
/// first, then its member `d` of object `id`; where the min starts, the object is a constant
/// (+infinity, what the cut objects folded into, or the first object). Each as (object,
/// distance, its forms where it is a min of them, all closed unless `open`).
fn split_at(
    g: &Graph,
    (dist, near): (Id, Id),
    open: bool,
    members: &mut Vec<(f64, Id, Option<Vec<Form>>)>,
) -> Option<()> {
    let (member, object) = match (g.get(dist), g.get(near)) {
        (Node::Proj(t, 0), Node::Proj(u, 1)) if t == u => match g.get(t) {
            Node::MinId(best, best_id, d, id) => {
                split_at(g, (best, best_id), open, members)?;
                (d, id.get())
            }
            _ => return None,
        },
        _ => (dist, g.constant(near)?),
    };
    let mut forms = vec![];
    let exact = min_of_forms(g, member, false, 0, &mut forms).is_some()
        && (open || forms.iter().all(Form::closed));
    members.push((object, member, exact.then_some(forms)));
    Some(())
}

/// `id` (negated when `neg`) as a min of forms, appended to `out`.
fn min_of_forms(g: &Graph, id: Id, neg: bool, depth: u32, out: &mut Vec<Form>) -> Option<()> {
    if depth > 16 || out.len() > MAX_PIECES {
        return None;
    }
    let signed = |f: Form| if neg { f.neg() } else { Some(f) };
    if let Some(f) = form(g, id) {
        out.push(signed(f)?);
        return Some(());
    }
    match g.get(id) {
        Node::Bin(Bin::Min, a, b) if !neg => {
            min_of_forms(g, a, neg, depth + 1, out)?;
            min_of_forms(g, b, neg, depth + 1, out)
        }
        // -max(a, b) = min(-a, -b)
        Node::Bin(Bin::Max, a, b) if neg => {
            min_of_forms(g, a, neg, depth + 1, out)?;
            min_of_forms(g, b, neg, depth + 1, out)
        }
        Node::Un(Un::Neg, a) => min_of_forms(g, a, !neg, depth + 1, out),
        // The largest of planes, or a sum of such with positive weights: a convex polytope.
        Node::Bin(Bin::Max, ..) | Node::Affine(..) if !neg => {
            let planes = convex(g, id, 0)?;
            out.push(Form::Hull { planes, sign: 1.0 });
            Some(())
        }
        // An unsigned distance, or a shell: of one plane, ball or box.
        Node::Un(Un::Abs, a) if !neg => {
            let mut inner = vec![];
            min_of_forms(g, a, false, depth + 1, &mut inner)?;
            match inner.pop() {
                Some(
                    f @ (Form::Plane { .. }
                    | Form::Ball { .. }
                    | Form::Box { .. }
                    | Form::Hull { .. }),
                ) if inner.is_empty() => {
                    out.push(Form::Abs {
                        f: Box::new(f),
                        k: 0.0,
                    });
                    Some(())
                }
                _ => None,
            }
        }
        Node::Bin(op @ (Bin::Add | Bin::Sub), a, b) => {
            let (x, k) = offset(g, op, a, b)?;
            let from = out.len();
            min_of_forms(g, x, neg, depth + 1, out)?;
            let k = if neg { -k } else { k };
            for f in &mut out[from..] {
                *f = f.clone().plus(k);
            }
            Some(())
        }
        _ => None,
    }
}

/// `a op b` (`op` an addition or subtraction) as `x + k`, where one side is a constant `k`
/// (for a subtraction, the second).
fn offset(g: &Graph, op: Bin, a: Id, b: Id) -> Option<(Id, f64)> {
    match (g.constant(a), g.constant(b)) {
        (_, Some(k)) => Some((a, if op == Bin::Add { k } else { -k })),
        (Some(k), _) if op == Bin::Add => Some((b, k)),
        _ => None,
    }
}

/// The most planes a polytope may have: a 24-cell's 24, and a few more.
const MAX_PLANES: usize = 32;

/// `max_i (g_i . p + c_i)`.
#[inline(always)]
fn hull_max(planes: &[([f64; 4], f64)], p: [f64; 4]) -> f64 {
    (planes.iter()).fold(f64::NEG_INFINITY, |m, (g, c)| m.max(dot(*g, p) + c))
}

/// `id` as the largest of a few planes, when it is a convex piecewise-linear function of the
/// point built from planes by `max`, `|x|` of a plane (`max(x, -x)`), sums and positive
/// weights (`a + b` is the largest of the sums of their planes, pair by pair).
fn convex(g: &Graph, id: Id, depth: u32) -> Option<Vec<([f64; 4], f64)>> {
    if depth > 12 {
        return None;
    }
    if let Some(plane) = linear(g, id) {
        return Some(vec![plane]);
    }
    let scaled = |planes: Vec<([f64; 4], f64)>, k: f64| {
        (k >= 0.0).then(|| {
            planes
                .into_iter()
                .map(|(v, c)| (v.map(|x| x * k), c * k))
                .collect()
        })
    };
    let sum = |a: Vec<([f64; 4], f64)>, b: Vec<([f64; 4], f64)>| {
        (a.len() * b.len() <= MAX_PLANES).then(|| {
            (a.iter())
                .flat_map(|(u, c)| {
                    b.iter()
                        .map(move |(v, e)| (std::array::from_fn(|i| u[i] + v[i]), c + e))
                })
                .collect::<Vec<([f64; 4], f64)>>()
        })
    };
    let planes = match g.get(id) {
        Node::Bin(Bin::Max, a, b) => {
            let mut planes = convex(g, a, depth + 1)?;
            planes.extend(convex(g, b, depth + 1)?);
            planes
        }
        Node::Un(Un::Abs, a) => {
            let (v, c) = linear(g, a)?;
            vec![(v, c), (v.map(|x| -x), -c)]
        }
        Node::Bin(Bin::Add, a, b) => sum(convex(g, a, depth + 1)?, convex(g, b, depth + 1)?)?,
        Node::Bin(Bin::Mul, a, b) => match (g.constant(a), g.constant(b)) {
            (Some(k), _) => scaled(convex(g, b, depth + 1)?, k)?,
            (_, Some(k)) => scaled(convex(g, a, depth + 1)?, k)?,
            _ => return None,
        },
        Node::Bin(Bin::Sub, a, b) => {
            let k = g.constant(b)?;
            (convex(g, a, depth + 1)?.into_iter())
                .map(|(v, c)| (v, c - k))
                .collect()
        }
        Node::Affine(v, r) => {
            let mut planes = vec![([0.0; 4], r[4].get())];
            for i in 0..4 {
                let k = r[i].get();
                if k != 0.0 {
                    planes = sum(planes, scaled(convex(g, v[i], depth + 1)?, k)?)?;
                }
            }
            planes
        }
        _ => return None,
    };
    (planes.len() <= MAX_PLANES
        && planes
            .iter()
            .flat_map(|(v, c)| v.iter().chain([c]))
            .all(|x| x.is_finite()))
    .then_some(planes)
}

/// `id` as one plane, sphere or box, or a sphere tiled over a lattice, when it is one. A sphere's
/// map must be orthonormal on the rows it uses (a rotation, a projection onto some axes):
/// then `|A p + b| - r` is a distance bound like the others, which the marcher's steps rely
/// on near the piece.
fn form(g: &Graph, id: Id) -> Option<Form> {
    if let Some((g, c)) = linear(g, id) {
        return Some(Form::Plane { g, c });
    }
    if let Node::BoxDist(v, k) = g.get(id) {
        let k = k.map(K::get);
        let mut rows = [[0.0; 4]; 4];
        let mut b = [0.0; 4];
        for i in 0..4 {
            (rows[i], b[i]) = linear(g, v[i])?;
            b[i] += k[i];
        }
        let half = [k[4], k[5], k[6], k[7]];
        let finite = rows
            .iter()
            .flatten()
            .chain(&b)
            .chain(&half)
            .all(|x| x.is_finite());
        let sized = half.iter().all(|h| *h >= 0.0);
        return (finite && sized && k[8].is_finite() && orthonormal(&rows)).then_some(Form::Box {
            rows: rows.into(),
            b,
            half,
            r: k[8],
            sign: 1.0,
        });
    }
    let Node::Length(v, r) = g.get(id) else {
        return None;
    };
    let ball = |leaf: &mut dyn FnMut(Id) -> Option<usize>| {
        let mut rows = [[0.0; 4]; 4];
        let mut b = [0.0; 4];
        for i in 0..4 {
            (rows[i], b[i]) = linear_in(g, v[i], leaf, 8)?;
            b[i] += r[i].get();
        }
        Some((rows, b))
    };
    let r = r[4].get();
    if let Some((rows, b)) = ball(&mut |id| point(g, id)) {
        return orthonormal(&rows).then_some(Form::Ball {
            rows: rows.into(),
            b,
            r,
            sign: 1.0,
        });
    }
    // A length of a lattice's offsets: the offset from the nearest D4 point, or from the
    // cells of up to four repetitions (a grid), in the order first met.
    let mut tuples: Vec<Id> = vec![];
    let (m, off) = ball(&mut |id| {
        let Node::Proj(t, k) = g.get(id) else {
            return None;
        };
        let known = tuples.iter().position(|&u| u == t);
        match (g.get(t), known) {
            (Node::D4(_), Some(_)) if k < 4 => Some(k as usize),
            (Node::D4(_), None) if k < 4 && tuples.is_empty() => {
                tuples.push(t);
                Some(k as usize)
            }
            (Node::Rep(..), Some(i)) if k == 0 => Some(i),
            (Node::Rep(..), None) if k == 0 && tuples.len() < 4 => {
                tuples.push(t);
                (tuples.iter().all(|&u| matches!(g.get(u), Node::Rep(..))))
                    .then_some(tuples.len() - 1)
            }
            _ => None,
        }
    })?;
    let (mut to, mut at) = ([[0.0; 4]; 4], [0.0; 4]);
    let tiling = match g.get(*tuples.first()?) {
        Node::D4(w) => {
            for k in 0..4 {
                (to[k], at[k]) = linear(g, w[k])?;
            }
            Tiling::D4
        }
        _ => {
            let mut limit = [0.0; 4];
            for (k, &t) in tuples.iter().enumerate() {
                let Node::Rep(x, l) = g.get(t) else {
                    return None;
                };
                ((to[k], at[k]), limit[k]) = (linear(g, x)?, l.get());
            }
            Tiling::Grid { limit }
        }
    };
    let rows: [[f64; 4]; 4] =
        std::array::from_fn(|i| std::array::from_fn(|j| (0..4).map(|k| m[i][k] * to[k][j]).sum()));
    (orthonormal(&rows) && [to, m].iter().flatten().flatten().all(|x| x.is_finite())).then_some(
        Form::Lattice(Box::new(Tiled::new(tiling, (to, at), (m, off), r))),
    )
}

/// Whether the rows that are not zero are orthonormal.
fn orthonormal(rows: &[[f64; 4]; 4]) -> bool {
    let used: Vec<&[f64; 4]> = rows.iter().filter(|r| **r != [0.0; 4]).collect();
    (used.iter().enumerate()).all(|(i, a)| {
        (used.iter().enumerate()).all(|(j, b)| {
            let want = if i == j { 1.0 } else { 0.0 };
            (dot(**a, **b) - want).abs() <= 1e-9
        })
    })
}

/// The coordinate of the point that `id` is, if it is one.
fn point(g: &Graph, id: Id) -> Option<usize> {
    match g.get(id) {
        Node::Var(v) if Var::POINT.contains(&v) => Some(v.index()),
        _ => None,
    }
}

/// `id` as an affine function of the point, `g . p + c`, when it is one.
pub fn linear(g: &Graph, id: Id) -> Option<([f64; 4], f64)> {
    linear_in(g, id, &mut |x| point(g, x), 8)
}

/// `id` as an affine function `g . v + c` of four variables, the nodes for which `leaf` gives
/// an index.
fn linear_in(
    g: &Graph,
    id: Id,
    leaf: &mut dyn FnMut(Id) -> Option<usize>,
    depth: u32,
) -> Option<([f64; 4], f64)> {
    let depth = depth.checked_sub(1)?;
    let scaled = |(v, c): ([f64; 4], f64), k: f64| (v.map(|x| x * k), c * k);
    let sum = |(a, c): ([f64; 4], f64), (b, e): ([f64; 4], f64)| {
        (std::array::from_fn(|i| a[i] + b[i]), c + e)
    };
    if let Some(i) = leaf(id) {
        let mut e = [0.0; 4];
        e[i] = 1.0;
        return Some((e, 0.0));
    }
    let mut sub = |x: Id| linear_in(g, x, leaf, depth);
    Some(match g.get(id) {
        Node::Const(k) => ([0.0; 4], k.get()),
        Node::Affine(v, r) => (0..4).try_fold(([0.0; 4], r[4].get()), |acc, i| {
            Some(sum(acc, scaled(sub(v[i])?, r[i].get())))
        })?,
        Node::Bin(Bin::Add, a, b) => sum(sub(a)?, sub(b)?),
        Node::Bin(Bin::Sub, a, b) => sum(sub(a)?, scaled(sub(b)?, -1.0)),
        Node::Bin(Bin::Mul, a, b) => match (g.constant(a), g.constant(b)) {
            (Some(k), _) => scaled(sub(b)?, k),
            (_, Some(k)) => scaled(sub(a)?, k),
            _ => return None,
        },
        Node::Un(Un::Neg, a) => scaled(sub(a)?, -1.0),
        _ => return None,
    })
}
