//! Shapes with typed parameters: a primitive or an operation over child shapes. Parameters
//! are constants or fields of the frame variable `t` (a custom distance's of `p` too).

use super::field::{DEP_P, Fields, Param};
use super::lattice::Lattice;
use crate::math::Plane;
use crate::math::plane::rotate;
use std::rc::Rc;

/// A number parameter: a constant, or a field of `t` (and of `p` in a custom distance).
pub type Num = Param<f64>;
/// A `vec4` parameter: a constant, or a field of `t`.
pub type Vector = Param<[f64; 4]>;

/// Plane rotations applied in order; angles are constants or fields of `t`.
pub type Rotation = Vec<(Plane, Num)>;

/// The regular polytopes, by their number of cells.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Polytope {
    /// The 5-cell (4-simplex), `cell5`.
    Cell5,
    /// The 16-cell (4D cross-polytope), `cell16`.
    Cell16,
    /// The 24-cell, `cell24`.
    Cell24,
}

impl Polytope {
    /// Its circumradius grown with its distance, the largest of its facet distances: growing
    /// that by `grow` scales the polytope by `1 + grow / inradius`, so the vertices move out
    /// by `grow` times circumradius over inradius (4, 2 and the square root of 2).
    fn circumradius(self, r: f64, grow: f64) -> f64 {
        let per_grow = match self {
            Polytope::Cell5 => 4.0,
            Polytope::Cell16 => 2.0,
            Polytope::Cell24 => std::f64::consts::SQRT_2,
        };
        r + per_grow * grow
    }
}

/// What a shape node is: a primitive with its parameters, or an operation on child shapes.
/// Sizes are in world units.
#[derive(Clone, Debug, PartialEq)]
pub enum ShapeKind {
    /// The 4D ball around the origin.
    Hypersphere {
        /// Radius in world units.
        radius: Num,
    },
    /// Everything on the inner side of a hyperplane: `dot(p, normalize(normal)) <= offset`.
    Halfspace {
        /// Direction out of the solid (normalised when evaluated).
        normal: Vector,
        /// Signed distance of the boundary from the origin along `normal`.
        offset: Num,
    },
    /// A box centred on the origin, its edges and corners optionally rounded.
    Hyperbox {
        /// Half-extent along each axis.
        half: Vector,
        /// Rounding radius of edges and corners; the outer extents stay `half`.
        radius: Num,
    },
    /// A ball in xyz times an interval in w.
    Spherinder {
        /// Radius of the ball in xyz.
        radius: Num,
        /// Half-length in w.
        height: Num,
    },
    /// A disk in xy times an interval in both z and w.
    Cubinder {
        /// Radius of the disk in xy.
        radius: Num,
        /// Half-length in z and in w.
        height: Num,
    },
    /// A disk in xy times a disk in zw.
    Duocylinder {
        /// Radius of the disk in xy.
        radius1: Num,
        /// Radius of the disk in zw.
        radius2: Num,
    },
    /// A regular polytope centred on the origin.
    Polytope {
        /// Which polytope.
        cells: Polytope,
        /// Circumradius in world units.
        radius: Num,
    },
    /// `sdf |p| ...`: the distance is a field of `p` (and `t`).
    Custom {
        /// The signed distance at `p`, a field expression.
        distance: Num,
    },
    /// Everything in any of the shapes.
    Union {
        /// The shapes, at least one.
        shapes: Vec<Rc<Shape>>,
        /// Blend distance; 0 is a sharp union.
        smooth: Num,
    },
    /// Only what is in all of the shapes.
    Intersect {
        /// The shapes, at least one.
        shapes: Vec<Rc<Shape>>,
        /// Blend distance; 0 is a sharp intersection.
        smooth: Num,
    },
    /// `shape` with `cut` removed.
    Subtract {
        /// The shape cut from.
        shape: Rc<Shape>,
        /// What is removed.
        cut: Rc<Shape>,
        /// Blend distance; 0 is a sharp cut.
        smooth: Num,
    },
    /// A shell centred on the surface of `shape` (distance `|d| - thickness / 2`).
    Onion {
        /// The shape whose surface the shell follows.
        shape: Rc<Shape>,
        /// Total thickness of the shell.
        thickness: Num,
    },
    /// `shape` grown with rounded edges (distance `d - radius`).
    Round {
        /// The shape grown.
        shape: Rc<Shape>,
        /// How far it grows.
        radius: Num,
    },
    /// `shape` moved.
    Translate {
        /// The shape moved.
        shape: Rc<Shape>,
        /// The displacement.
        offset: Vector,
    },
    /// `shape` rotated about the origin.
    Rotate {
        /// The shape rotated.
        shape: Rc<Shape>,
        /// The plane rotations, applied in order.
        rotation: Rotation,
    },
    /// `shape` scaled uniformly about the origin, its distance corrected.
    Scale {
        /// The shape scaled.
        shape: Rc<Shape>,
        /// The scale factor, positive.
        factor: Num,
    },
    /// A mirror: the half of `shape` where `dot(p, normal) >= 0` reflected to the other side.
    Symmetry {
        /// The shape mirrored.
        shape: Rc<Shape>,
        /// The mirror hyperplane's normal, through the origin, pointing at the half kept.
        normal: Vector,
    },
    /// `shape` repeated at every point of a lattice, one copy per cell.
    Tile {
        /// The shape repeated, centred on each lattice point.
        shape: Rc<Shape>,
        /// Where the copies go.
        lattice: Lattice,
    },
}

/// A shape and its nesting depth, bounded so that every recursive pass over shapes stays
/// shallow.
#[derive(Clone, Debug, PartialEq)]
pub struct Shape {
    /// The node.
    pub kind: ShapeKind,
    /// Nodes on the longest path down to a primitive, this one included (1 for a primitive).
    pub depth: u32,
}

/// A shape parameter, for the printer and for passes that treat parameters alike.
#[derive(Clone, Copy, Debug)]
pub enum ParamRef<'a> {
    /// A number.
    Num(&'a Num),
    /// A `vec4`.
    Vector(&'a Vector),
    /// A rotation.
    Rotation(&'a Rotation),
    /// A lattice (always constant).
    Lattice(&'a Lattice),
}

impl ParamRef<'_> {
    /// Which of `p`, `n`, `t` the parameter depends on.
    pub fn deps(&self, fields: &Fields) -> u8 {
        match self {
            ParamRef::Num(x) => x.deps(fields),
            ParamRef::Vector(v) => v.deps(fields),
            ParamRef::Rotation(r) => r.iter().fold(0, |d, (_, a)| d | a.deps(fields)),
            ParamRef::Lattice(_) => 0,
        }
    }
}

impl Shape {
    /// A node of `kind`, its depth worked out from its children.
    pub fn new(kind: ShapeKind) -> Shape {
        let depth = 1 + kind.children().iter().map(|c| c.depth).max().unwrap_or(0);
        Shape { kind, depth }
    }

    /// Which of `p`, `n`, `t` the shape depends on; a custom distance's own `p` is bound
    /// inside it, so it does not count.
    pub fn deps(&self, fields: &Fields) -> u8 {
        let own = (self.kind.params().iter()).fold(0, |d, (_, p)| d | p.deps(fields));
        let own = if matches!(self.kind, ShapeKind::Custom { .. }) {
            own & !DEP_P
        } else {
            own
        };
        (self.kind.children().iter()).fold(own, |d, c| d | c.deps(fields))
    }

    /// Whether the shape repeats some shape on a lattice (`tile`).
    pub fn tiled(&self) -> bool {
        matches!(self.kind, ShapeKind::Tile { .. })
            || self.kind.children().iter().any(|c| c.tiled())
    }

    /// A ball (centre, radius) containing the shape, when its parameters are constants.
    pub fn bounds(&self) -> Option<([f64; 4], f64)> {
        self.grown(0.0)
    }

    /// A ball containing the points where the shape's distance is at most `grow` (what
    /// `round` and `onion` make of it). Exact distances (spheres, boxes, extrusions) grow by
    /// `grow`; a polytope faster (`Polytope::circumradius`: `round(cell16(1), 0.5)` reaches
    /// 2, not 1.5).
    fn grown(&self, grow: f64) -> Option<([f64; 4], f64)> {
        use ShapeKind as S;
        let o = [0.0; 4];
        Some(match &self.kind {
            S::Hypersphere { radius } => (o, radius.constant()? + grow),
            S::Polytope { cells, radius } => (o, cells.circumradius(radius.constant()?, grow)),
            S::Hyperbox { half, radius } => {
                let h = half.constant()?;
                (o, length(h) + radius.constant()? + grow)
            }
            S::Spherinder { radius, height } => {
                (o, radius.constant()?.hypot(height.constant()?) + grow)
            }
            S::Cubinder { radius, height } => (
                o,
                (radius.constant()?.powi(2) + 2.0 * height.constant()?.powi(2)).sqrt() + grow,
            ),
            S::Duocylinder { radius1, radius2 } => {
                (o, radius1.constant()?.hypot(radius2.constant()?) + grow)
            }
            S::Halfspace { .. } | S::Custom { .. } => return None,
            // Every copy lies in the ball about its lattice point `spacing * k`, `|k_i| <=
            // limit_i`: all of them within the corner copy's reach of the centre one.
            S::Tile { shape, lattice } => match lattice {
                Lattice::Grid { spacing, limit } if limit.iter().all(|l| l.is_finite()) => {
                    let (c, r) = shape.grown(grow)?;
                    (
                        c,
                        r + length(std::array::from_fn(|i| spacing[i] * limit[i])),
                    )
                }
                _ => return None,
            },
            // The kept half and its mirror image: within the shape's ball about its centre
            // grown by how far the mirror moves that centre.
            S::Symmetry { shape, normal } => {
                let (c, r) = shape.grown(grow)?;
                let n = normal.constant()?;
                let nn: f64 = n.iter().map(|x| x * x).sum();
                if nn == 0.0 {
                    return None;
                }
                let off = (0..4).map(|i| c[i] * n[i]).sum::<f64>().abs() * 2.0 / nn.sqrt();
                (c, r + off)
            }
            // A blend that changes with `t` has no constant bound.
            S::Union { shapes, smooth } => {
                let g = grow + blend_depth(smooth.constant()?, shapes.len());
                let bs: Vec<_> = shapes.iter().map(|c| c.grown(g)).collect::<Option<_>>()?;
                let c = bs[0].0;
                let r = bs
                    .iter()
                    .map(|(bc, br)| distance(c, *bc) + br)
                    .fold(0.0, f64::max);
                (c, r)
            }
            // A smooth maximum is at least the maximum: the shape lies in every part.
            S::Intersect { shapes, .. } => {
                let bs: Vec<_> = shapes.iter().filter_map(|c| c.grown(grow)).collect();
                *bs.iter().min_by(|a, b| a.1.total_cmp(&b.1))?
            }
            S::Subtract { shape, .. } => shape.grown(grow)?,
            S::Onion { shape, thickness } => {
                shape.grown(grow + thickness.constant()?.abs() / 2.0)?
            }
            S::Round { shape, radius } => shape.grown(grow + radius.constant()?)?,
            S::Translate { shape, offset } => {
                let (c, r) = shape.grown(grow)?;
                let v = offset.constant()?;
                (std::array::from_fn(|i| c[i] + v[i]), r)
            }
            S::Rotate { shape, rotation } => {
                let (c, r) = shape.grown(grow)?;
                let angles: Option<Vec<(Plane, f64)>> = rotation
                    .iter()
                    .map(|(p, a)| Some((*p, a.constant()?)))
                    .collect();
                match angles {
                    Some(steps) => (rotate(c, steps), r),
                    // Turning with `t`: a ball about the origin holds every turn.
                    None => (o, length(c) + r),
                }
            }
            // `k d(p / k)` is at most `grow` where `d(p / k)` is at most `grow / k`.
            S::Scale { shape, factor } => {
                let k = factor.constant()?;
                if k <= 0.0 {
                    return None;
                }
                let (c, r) = shape.grown(grow / k)?;
                (c.map(|x| x * k), r * k)
            }
        })
    }
}

/// How far below the least of `n` distances their smooth union of blend `k` may reach, as
/// lowered: a chain of smooth minima, each at most `k / 4` below the least of its two
/// operands. A chain of `n` goes deeper: where the first `n` reach `D` below their least,
/// one more reaches `D + (k - D)^2 / (4k)` (three equal spheres of blend 1 reach 0.39, not
/// 0.25), which tends to `k`.
fn blend_depth(k: f64, n: usize) -> f64 {
    if k <= 0.0 {
        return 0.0;
    }
    (1..n).fold(0.0, |d, _| d + (k - d).powi(2) / (4.0 * k))
}

impl Shape {
    /// An upper bound on `v . x` over the points `x` where the shape's distance is at most
    /// `grow` (the shape itself at 0): its support function, exact for the primitives and under
    /// translations, rotations, scalings, unions and roundings of them, an upper bound through
    /// intersections, cuts, smoothing and symmetries. `None` when a parameter it needs is not a
    /// constant or the shape is unbounded.
    pub fn support(&self, v: [f64; 4], grow: f64) -> Option<f64> {
        use ShapeKind as S;
        let len = length(v);
        let a = v.map(f64::abs);
        Some(match &self.kind {
            S::Hypersphere { radius } => (radius.constant()? + grow) * len,
            S::Hyperbox { half, radius } => {
                // A box of half - r grown by r, as lowered.
                let (h, r) = (half.constant()?, radius.constant()?);
                (0..4).map(|i| a[i] * (h[i] - r).max(0.0)).sum::<f64>() + (r + grow) * len
            }
            S::Spherinder { radius, height } => {
                let (r, h) = (radius.constant()?, height.constant()?);
                r * length([v[0], v[1], v[2], 0.0]) + h * a[3] + grow * len
            }
            S::Cubinder { radius, height } => {
                let (r, h) = (radius.constant()?, height.constant()?);
                r * v[0].hypot(v[1]) + h * (a[2] + a[3]) + grow * len
            }
            S::Duocylinder { radius1, radius2 } => {
                let (r1, r2) = (radius1.constant()?, radius2.constant()?);
                r1 * v[0].hypot(v[1]) + r2 * v[2].hypot(v[3]) + grow * len
            }
            S::Polytope { cells, radius } => {
                let r = cells.circumradius(radius.constant()?, grow);
                match cells {
                    // Vertices +-r e_i.
                    Polytope::Cell16 => r * a.iter().cloned().fold(0.0, f64::max),
                    // Vertices r / sqrt(2) (+-1, +-1, 0, 0) permuted.
                    Polytope::Cell24 => {
                        let mut s = a;
                        s.sort_by(|x, y| y.total_cmp(x));
                        r * std::f64::consts::FRAC_1_SQRT_2 * (s[0] + s[1])
                    }
                    // Within the circumscribed ball.
                    Polytope::Cell5 => r * len,
                }
            }
            S::Halfspace { .. } | S::Custom { .. } | S::Tile { .. } => return None,
            S::Union { shapes, smooth } => {
                let g = grow + blend_depth(smooth.constant()?, shapes.len());
                let hs = shapes.iter().map(|c| c.support(v, g));
                hs.collect::<Option<Vec<_>>>()?
                    .into_iter()
                    .fold(f64::NEG_INFINITY, f64::max)
            }
            // A smooth maximum is at least the maximum: the shape lies in every part.
            S::Intersect { shapes, .. } => shapes
                .iter()
                .filter_map(|c| c.support(v, grow))
                .reduce(f64::min)?,
            S::Subtract { shape, .. } => shape.support(v, grow)?,
            S::Onion { shape, thickness } => {
                shape.support(v, grow + thickness.constant()?.abs() / 2.0)?
            }
            S::Round { shape, radius } => shape.support(v, grow + radius.constant()?)?,
            S::Translate { shape, offset } => {
                let o = offset.constant()?;
                shape.support(v, grow)? + (0..4).map(|i| v[i] * o[i]).sum::<f64>()
            }
            S::Rotate { shape, rotation } => {
                let angles: Option<Vec<(Plane, f64)>> = rotation
                    .iter()
                    .map(|(p, a)| Some((*p, a.constant()?)))
                    .collect();
                match angles {
                    // The points turned by R: v . R x = (R^-1 v) . x.
                    Some(steps) => {
                        let back = rotate(v, steps.into_iter().rev().map(|(p, a)| (p, -a)));
                        shape.support(back, grow)?
                    }
                    // Turning with `t`: a ball about the origin holds every turn.
                    None => {
                        let r = (0..4)
                            .map(|i| {
                                let mut e = [0.0; 4];
                                e[i] = 1.0;
                                let up = shape.support(e, grow)?;
                                e[i] = -1.0;
                                Some(up.max(shape.support(e, grow)?).max(0.0))
                            })
                            .collect::<Option<Vec<f64>>>()?;
                        let ball = length([r[0], r[1], r[2], r[3]]);
                        let rb = shape
                            .bounds()
                            .filter(|(c, _)| *c == [0.0; 4] && grow == 0.0);
                        rb.map_or(ball, |(_, rb)| ball.min(rb)) * len
                    }
                }
            }
            S::Scale { shape, factor } => {
                let k = factor.constant()?;
                if k <= 0.0 {
                    return None;
                }
                k * shape.support(v, grow / k)?
            }
            S::Symmetry { shape, normal } => {
                // The reflected half lies in the mirror image of the shape.
                let n = normal.constant()?;
                let nn: f64 = n.iter().map(|x| x * x).sum();
                if nn == 0.0 {
                    return None;
                }
                let d = (0..4).map(|i| v[i] * n[i]).sum::<f64>() * 2.0 / nn;
                let m = std::array::from_fn(|i| v[i] - d * n[i]);
                shape.support(v, grow)?.max(shape.support(m, grow)?)
            }
        })
    }
}

impl ShapeKind {
    /// The builtin's name.
    pub fn name(&self) -> &'static str {
        use ShapeKind as S;
        match self {
            S::Hypersphere { .. } => "hypersphere",
            S::Halfspace { .. } => "halfspace",
            S::Hyperbox { .. } => "hyperbox",
            S::Spherinder { .. } => "spherinder",
            S::Cubinder { .. } => "cubinder",
            S::Duocylinder { .. } => "duocylinder",
            S::Polytope { cells, .. } => match cells {
                Polytope::Cell5 => "cell5",
                Polytope::Cell16 => "cell16",
                Polytope::Cell24 => "cell24",
            },
            S::Custom { .. } => "sdf",
            S::Union { .. } => "union",
            S::Intersect { .. } => "intersect",
            S::Subtract { .. } => "subtract",
            S::Onion { .. } => "onion",
            S::Round { .. } => "round",
            S::Translate { .. } => "translate",
            S::Rotate { .. } => "rotate",
            S::Scale { .. } => "scale",
            S::Symmetry { .. } => "symmetry",
            S::Tile { .. } => "tile",
        }
    }

    /// The parameters other than child shapes, by name, in the order they are written.
    pub fn params(&self) -> Vec<(&'static str, ParamRef<'_>)> {
        use ParamRef as P;
        use ShapeKind as S;
        match self {
            S::Hypersphere { radius } | S::Polytope { radius, .. } => {
                vec![("radius", P::Num(radius))]
            }
            S::Halfspace { normal, offset } => {
                vec![("normal", P::Vector(normal)), ("offset", P::Num(offset))]
            }
            S::Hyperbox { half, radius } => {
                vec![("half", P::Vector(half)), ("radius", P::Num(radius))]
            }
            S::Spherinder { radius, height } | S::Cubinder { radius, height } => {
                vec![("radius", P::Num(radius)), ("height", P::Num(height))]
            }
            S::Duocylinder { radius1, radius2 } => {
                vec![("radius1", P::Num(radius1)), ("radius2", P::Num(radius2))]
            }
            S::Custom { distance } => vec![("distance", P::Num(distance))],
            S::Union { smooth, .. } | S::Intersect { smooth, .. } | S::Subtract { smooth, .. } => {
                vec![("smooth", P::Num(smooth))]
            }
            S::Onion { thickness, .. } => vec![("thickness", P::Num(thickness))],
            S::Round { radius, .. } => vec![("radius", P::Num(radius))],
            S::Translate { offset, .. } => vec![("offset", P::Vector(offset))],
            S::Rotate { rotation, .. } => vec![("rotation", P::Rotation(rotation))],
            S::Scale { factor, .. } => vec![("factor", P::Num(factor))],
            S::Symmetry { normal, .. } => vec![("normal", P::Vector(normal))],
            S::Tile { lattice, .. } => vec![("lattice", P::Lattice(lattice))],
        }
    }

    /// The child shapes an operation applies to, in order; none for a primitive.
    pub fn children(&self) -> Vec<&Rc<Shape>> {
        use ShapeKind as S;
        match self {
            S::Union { shapes, .. } | S::Intersect { shapes, .. } => shapes.iter().collect(),
            S::Subtract { shape, cut, .. } => vec![shape, cut],
            S::Onion { shape, .. }
            | S::Round { shape, .. }
            | S::Translate { shape, .. }
            | S::Rotate { shape, .. }
            | S::Scale { shape, .. }
            | S::Symmetry { shape, .. }
            | S::Tile { shape, .. } => vec![shape],
            _ => vec![],
        }
    }
}

fn length(v: [f64; 4]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// The Euclidean distance between two points in 4D.
pub fn distance(a: [f64; 4], b: [f64; 4]) -> f64 {
    length(std::array::from_fn(|i| a[i] - b[i]))
}
