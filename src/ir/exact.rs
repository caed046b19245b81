//! Distances that rays can meet exactly: where a cell's scene distance is the smallest of a
//! few planes and spheres (halfspaces, the faces of a box seen from inside, a hypersphere
//! alone, the cut bound of what is far), the marcher intersects each in `f64` instead of
//! stepping towards it. A ray grazing a plane or a large sphere would otherwise take
//! thousands of steps, each a little shorter than the gap it closes.

use super::{Bin, Graph, Id, Node, Un, Var};

/// One piece of a distance, on object `object`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Piece {
    pub form: Form,
    pub object: f64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Form {
    /// `g . p + c`
    Plane { g: [f64; 4], c: f64 },
    /// `sign (|A p + b| - r)`, with the rows of `A` in `rows`: a hypersphere (or, seen from
    /// inside, its complement) of a linear image of the point (`first` solves any `A`; the
    /// pieces of cells have orthonormal rows, so that the value is a distance).
    Ball {
        rows: [[f64; 4]; 4],
        b: [f64; 4],
        r: f64,
        sign: f64,
    },
}

fn dot(a: [f64; 4], b: [f64; 4]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
}

impl Form {
    /// The distance at `p`.
    pub fn value(&self, p: [f64; 4]) -> f64 {
        match *self {
            Form::Plane { g, c } => dot(g, p) + c,
            Form::Ball { rows, b, r, sign } => {
                let u: [f64; 4] = std::array::from_fn(|i| dot(rows[i], p) + b[i]);
                sign * (dot(u, u).sqrt() - r)
            }
        }
    }

    /// The first `t >= 0` at which the ray from `p` along `d` reaches the surface, coming
    /// from where the distance is positive.
    pub fn first(&self, p: [f64; 4], d: [f64; 4]) -> Option<f64> {
        match *self {
            Form::Plane { g, c } => {
                let rate = dot(g, d);
                (rate < 0.0).then(|| ((dot(g, p) + c) / -rate).max(0.0))
            }
            Form::Ball { rows, b, r, .. } => {
                // |u + t w| = r: a quadratic in t, solved without cancellation.
                let u: [f64; 4] = std::array::from_fn(|i| dot(rows[i], p) + b[i]);
                let w: [f64; 4] = std::array::from_fn(|i| dot(rows[i], d));
                let (a, half_b) = (dot(w, w), dot(u, w));
                let norm = dot(u, u).sqrt();
                let c = (norm - r) * (norm + r);
                let disc = half_b * half_b - a * c;
                if r <= 0.0 || a == 0.0 || disc < 0.0 {
                    return None;
                }
                let q = -(half_b + disc.sqrt().copysign(half_b));
                let (t0, t1) = (q / a, if q != 0.0 { c / q } else { 0.0 });
                let (t0, t1) = (t0.min(t1), t0.max(t1));
                [t0, t1].into_iter().find(|t| *t >= 0.0)
            }
        }
    }

    /// The same form plus `k`.
    fn plus(self, k: f64) -> Form {
        match self {
            Form::Plane { g, c } => Form::Plane { g, c: c + k },
            Form::Ball { rows, b, r, sign } => Form::Ball {
                rows,
                b,
                r: r - sign * k,
                sign,
            },
        }
    }

    /// The form times `-1`.
    fn neg(self) -> Form {
        match self {
            Form::Plane { g, c } => Form::Plane {
                g: g.map(|x| -x),
                c: -c,
            },
            Form::Ball { rows, b, r, sign } => Form::Ball {
                rows,
                b,
                r,
                sign: -sign,
            },
        }
    }
}

/// Most pieces worth intersecting one by one.
const MAX_PIECES: usize = 8;

/// The scene's distance `dist` with nearest object `near` as the smallest of a few pieces,
/// when it is one.
pub fn pieces(g: &Graph, dist: Id, near: Id) -> Option<Vec<Piece>> {
    let (exact, rest) = split(g, dist, near)?;
    (rest.is_empty() && exact.len() <= MAX_PIECES).then_some(exact)
}

/// Objects of a running min, as (object index, distance).
pub type Members = Vec<(usize, Id)>;

/// The scene's distance `dist` with nearest object `near`, where it is a running min over
/// objects some of which are a few planes and spheres: their pieces, and the other objects
/// (object index, distance). None unless both kinds are there.
pub fn partition(g: &Graph, dist: Id, near: Id) -> Option<(Vec<Piece>, Members)> {
    let (exact, rest) = split(g, dist, near)?;
    let surface = |p: &Piece| !matches!(p.form, Form::Plane { g, .. } if g == [0.0; 4]);
    (exact.iter().any(surface) && !rest.is_empty() && exact.len() <= MAX_PIECES)
        .then_some((exact, rest))
}

/// The running min over objects at `dist` (nearest object `near`) split into the pieces of
/// the objects that are a few planes and spheres and the other objects; None where `dist` is
/// no such min.
fn split(g: &Graph, dist: Id, near: Id) -> Option<(Vec<Piece>, Members)> {
    let (mut exact, mut rest) = (vec![], vec![]);
    split_at(g, dist, near, &mut exact, &mut rest)?;
    // The running min starts at +infinity, which is no surface.
    exact.retain(|p| !matches!(p.form, Form::Plane { g, c } if g == [0.0; 4] && c.is_infinite()));
    Some((exact, rest))
}

/// `split` into `exact` and `rest`: the running min-with-id's `best` first, then its
/// member `d` of object `id`; where the min starts, the object is a constant (+infinity,
/// what the cut objects folded into, or the first object).
fn split_at(
    g: &Graph,
    dist: Id,
    near: Id,
    exact: &mut Vec<Piece>,
    rest: &mut Members,
) -> Option<()> {
    let (member, object) = match (g.get(dist), g.get(near)) {
        (Node::Proj(t, 0), Node::Proj(u, 1)) if t == u => match g.get(t) {
            Node::MinId(best, best_id, d, id) => {
                split_at(g, best, best_id, exact, rest)?;
                (d, id.get())
            }
            _ => return None,
        },
        _ => (dist, g.constant(near)?),
    };
    let mut forms = vec![];
    match min_of_forms(g, member, false, 0, &mut forms) {
        Some(()) => exact.extend(forms.into_iter().map(|form| Piece { form, object })),
        None if object >= 0.0 => rest.push((object as usize, member)),
        None => return None,
    }
    Some(())
}

/// `id` (negated when `neg`) as a min of forms, appended to `out`.
fn min_of_forms(g: &Graph, id: Id, neg: bool, depth: u32, out: &mut Vec<Form>) -> Option<()> {
    if depth > 16 || out.len() > MAX_PIECES {
        return None;
    }
    let signed = |f: Form| if neg { f.neg() } else { f };
    if let Some(f) = form(g, id) {
        out.push(signed(f));
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
        Node::Bin(op @ (Bin::Add | Bin::Sub), a, b) => {
            let (x, k) = match (g.constant(a), g.constant(b)) {
                (_, Some(k)) => (a, if op == Bin::Add { k } else { -k }),
                (Some(k), _) if op == Bin::Add => (b, k),
                _ => return None,
            };
            let from = out.len();
            min_of_forms(g, x, neg, depth + 1, out)?;
            let k = if neg { -k } else { k };
            for f in &mut out[from..] {
                *f = f.plus(k);
            }
            Some(())
        }
        _ => None,
    }
}

/// `id` as one plane or sphere, when it is one. A sphere's map must be orthonormal on the
/// rows it uses (a rotation, a projection onto some axes): then `|A p + b| - r` is a distance
/// bound like the others, which the marcher's steps rely on near the piece.
fn form(g: &Graph, id: Id) -> Option<Form> {
    if let Some((g, c)) = linear(g, id) {
        return Some(Form::Plane { g, c });
    }
    let Node::Length(v, r) = g.get(id) else {
        return None;
    };
    let mut rows = [[0.0; 4]; 4];
    let mut b = [0.0; 4];
    for i in 0..4 {
        (rows[i], b[i]) = linear(g, v[i])?;
        b[i] += r[i].get();
    }
    let used: Vec<&[f64; 4]> = rows.iter().filter(|r| **r != [0.0; 4]).collect();
    for (i, a) in used.iter().enumerate() {
        for (j, b) in used.iter().enumerate() {
            let want = if i == j { 1.0 } else { 0.0 };
            if (dot(**a, **b) - want).abs() > 1e-9 {
                return None;
            }
        }
    }
    Some(Form::Ball {
        rows,
        b,
        r: r[4].get(),
        sign: 1.0,
    })
}

/// `id` as an affine function of the point, `g . p + c`, when it is one.
pub fn linear(g: &Graph, id: Id) -> Option<([f64; 4], f64)> {
    linear_at(g, id, 8)
}

fn linear_at(g: &Graph, id: Id, depth: u32) -> Option<([f64; 4], f64)> {
    let depth = depth.checked_sub(1)?;
    let scaled = |(v, c): ([f64; 4], f64), k: f64| (v.map(|x| x * k), c * k);
    let sum = |(a, c): ([f64; 4], f64), (b, e): ([f64; 4], f64)| {
        (std::array::from_fn(|i| a[i] + b[i]), c + e)
    };
    let sub = |x: Id| linear_at(g, x, depth);
    Some(match g.get(id) {
        Node::Const(k) => ([0.0; 4], k.get()),
        Node::Var(v) if Var::POINT.contains(&v) => {
            let mut e = [0.0; 4];
            e[v.index()] = 1.0;
            (e, 0.0)
        }
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
