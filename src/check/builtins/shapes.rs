//! Shape builtins: primitives and operations, `union`/`intersect` over any number of shapes,
//! the four forms of `rotate`, and the checks every shape node passes (no per-point
//! parameters, bounded depth, tiled shapes that fit their cell, intersections that can be empty).

use super::{Args, default_value};
use crate::check::context::{Checker, MAX_SHAPE_DEPTH};
use crate::check::value::*;
use crate::diagnostic::Diagnostic;
use crate::scene::builtins::ParamSpec;
use crate::scene::shape::{Polytope, distance};
use crate::source::Span;
use std::rc::Rc;

pub(super) fn build(a: &mut Args, name: &'static str, specs: &'static [ParamSpec]) -> Value {
    use ShapeKind as S;
    // The number parameters from `from` on, in the table's order.
    let nums = |a: &mut Args, from: usize| -> Vec<Param<f64>> {
        (from..specs.len()).map(|i| a.num(i, &specs[i])).collect()
    };
    let primitive = |a: &mut Args, kind: ShapeKind| {
        if !a.ok {
            return Value::Error;
        }
        make_shape(a.ck, kind, a.span)
    };
    match name {
        "hypersphere" | "cell5" | "cell16" | "cell24" => {
            let radius = nums(a, 0)[0];
            let kind = match name {
                "hypersphere" => S::Hypersphere { radius },
                "cell5" => S::Polytope {
                    cells: Polytope::Cell5,
                    radius,
                },
                "cell16" => S::Polytope {
                    cells: Polytope::Cell16,
                    radius,
                },
                _ => S::Polytope {
                    cells: Polytope::Cell24,
                    radius,
                },
            };
            primitive(a, kind)
        }
        "spherinder" | "cubinder" | "duocylinder" => {
            let [x, y] = nums(a, 0)[..] else {
                return Value::Error;
            };
            let kind = match name {
                "spherinder" => S::Spherinder {
                    radius: x,
                    height: y,
                },
                "cubinder" => S::Cubinder {
                    radius: x,
                    height: y,
                },
                _ => S::Duocylinder {
                    radius1: x,
                    radius2: y,
                },
            };
            primitive(a, kind)
        }
        "halfspace" => {
            let (n, nspan) = a.get(0, &specs[0]);
            let normal = match n {
                Value::Vec4(v) if v.iter().all(|x| *x == 0.0) => {
                    a.ok = false;
                    a.ck.error(
                        Diagnostic::error("E0301", "a halfspace needs a nonzero normal")
                            .label(nspan, "this vector is zero")
                            .help("the normal points out of the solid, e.g. `[0, 1, 0, 0]`"),
                    );
                    Param::Const([f64::NAN; 4])
                }
                Value::Vec4(v) => {
                    let len = v.iter().map(|x| x * x).sum::<f64>().sqrt();
                    Param::Const(v.map(|x| x / len))
                }
                other => other.vector().unwrap_or(Param::Const([f64::NAN; 4])),
            };
            let offset = a.get(1, &specs[1]).0.num();
            let offset = offset.unwrap_or(Param::Const(f64::NAN));
            primitive(a, S::Halfspace { normal, offset })
        }
        "hyperbox" => {
            // `half` may be one number for every axis.
            let (h, hspan) = a.get_or(0, Type::Unknown, default_value(&specs[0]));
            let half = match h {
                Value::Num(x) => Param::Const([x; 4]),
                Value::Vec4(v) => Param::Const(v),
                Value::Field(id, Type::Num | Type::Vec4) => Param::Field(id),
                Value::Error => Param::Const([f64::NAN; 4]),
                other => {
                    a.ok = false;
                    a.ck.expect(&other, &Type::Vec4, hspan, "argument `half` of `hyperbox`");
                    Param::Const([f64::NAN; 4])
                }
            };
            if let Param::Const(v) = &half
                && let Some(bad) = v.iter().find(|x| !specs[0].range.test(**x))
            {
                a.ok = false;
                a.ck.error(
                    Diagnostic::error("E0301", "`half` of `hyperbox` is out of range")
                        .label(
                            hspan,
                            format!(
                                "this has {}, but half-extents must be at least 0",
                                Num(*bad)
                            ),
                        )
                        .help("half-extents are distances from the centre to each face"),
                );
            }
            let radius = a.num(1, &specs[1]);
            primitive(a, S::Hyperbox { half, radius })
        }
        "subtract" => {
            let s = a.shape(0);
            let (cut, cspan) = a.get_or(1, Type::Unknown, None);
            let cut = match cut {
                Value::Shape(c) => Some(c),
                Value::List(_) => match flatten_shapes(a.ck, &cut, cspan) {
                    Some(cs) if cs.len() == 1 => Some(cs[0].clone()),
                    Some(cs) => {
                        let union = S::Union {
                            shapes: cs,
                            smooth: Param::Const(0.0),
                        };
                        match make_shape(a.ck, union, cspan) {
                            Value::Shape(u) => Some(u),
                            _ => None,
                        }
                    }
                    None => None,
                },
                Value::Error => None,
                other => {
                    a.ck.expect(&other, &Type::Shape, cspan, "argument `cut` of `subtract`");
                    None
                }
            };
            let smooth = a.num(2, &specs[2]);
            match (s, cut) {
                (Some(shape), Some(cut)) => primitive(a, S::Subtract { shape, cut, smooth }),
                _ => {
                    a.ok = false;
                    Value::Error
                }
            }
        }
        "onion" | "round" | "scale" => {
            let s = a.shape(0);
            let x = nums(a, 1)[0];
            let Some(shape) = s else {
                return Value::Error;
            };
            let kind = match name {
                "onion" => S::Onion {
                    shape,
                    thickness: x,
                },
                "round" => S::Round { shape, radius: x },
                _ => S::Scale { shape, factor: x },
            };
            primitive(a, kind)
        }
        "translate" | "symmetry" => {
            let s = a.shape(0);
            let v = a.get(1, &specs[1]).0.vector();
            let (Some(shape), Some(v)) = (s, v) else {
                return Value::Error;
            };
            let kind = if name == "translate" {
                S::Translate { shape, offset: v }
            } else {
                S::Symmetry { shape, normal: v }
            };
            primitive(a, kind)
        }
        "tile" => {
            let sspan = a.slots[0].as_ref().map_or(a.span, |s| s.span);
            let s = a.shape(0);
            let (l, lspan) = a.get(1, &specs[1]);
            let (Some(shape), Value::Lattice(lat)) = (s, l) else {
                return Value::Error;
            };
            check_fit(a.ck, &shape, &lat, lspan, sspan);
            primitive(
                a,
                S::Tile {
                    shape,
                    lattice: (*lat).clone(),
                },
            )
        }
        _ => Value::Error,
    }
}

/// Build a shape node, checking that its parameters do not vary per point and bounding depth.
pub fn make_shape(ck: &mut Checker, kind: ShapeKind, span: Span) -> Value {
    if !matches!(kind, ShapeKind::Custom { .. }) {
        for (name, p) in kind.params() {
            let deps = p.deps(&ck.fields);
            if deps & (DEP_P | DEP_N) != 0 {
                return ck.error(
                    Diagnostic::error(
                        "E0208",
                        format!(
                            "`{name}` of `{}` cannot vary from point to point",
                            kind.name()
                        ),
                    )
                    .label(span, format!("`{name}` depends on {}", describe_deps(deps)))
                    .note("shape parameters are constants or depend on the frame variable `t` only")
                    .help("write a custom distance function with `sdf |p| ...` instead"),
                );
            }
        }
    }
    // Consecutive rotations merge into one node (one matrix later).
    if let ShapeKind::Rotate { shape, rotation } = &kind
        && let ShapeKind::Rotate {
            shape: inner_shape,
            rotation: inner,
        } = &shape.kind
    {
        let rotation = inner.iter().chain(rotation).cloned().collect();
        let shape = inner_shape.clone();
        return make_shape(ck, ShapeKind::Rotate { shape, rotation }, span);
    }
    let shape = Shape::new(kind);
    if shape.depth > MAX_SHAPE_DEPTH {
        return ck.error(
            Diagnostic::error("E0402", "shape nested too deeply")
                .label(
                    span,
                    format!("this shape is more than {MAX_SHAPE_DEPTH} operations deep"),
                )
                .help("combine many shapes with one `union` of a list instead of nesting"),
        );
    }
    Value::Shape(Rc::new(shape))
}

/// Shapes from a value that is a shape or a (nested) list of shapes.
fn flatten_shapes(ck: &mut Checker, v: &Value, span: Span) -> Option<Vec<Rc<Shape>>> {
    match v {
        Value::Shape(s) => Some(vec![s.clone()]),
        Value::List(xs) => {
            let mut out = vec![];
            for x in xs.iter() {
                out.extend(flatten_shapes(ck, x, span)?);
            }
            Some(out)
        }
        Value::Error => None,
        other => {
            ck.expect(
                other,
                &Type::Shape,
                span,
                "every part of a union or intersection",
            );
            None
        }
    }
}

/// `union(a, b, ..., smooth: k)` and `intersect(...)`: any number of shapes or lists of shapes.
pub(super) fn combine(
    ck: &mut Checker,
    name: &'static str,
    args: Vec<ArgVal>,
    span: Span,
) -> Value {
    let mut shapes = vec![];
    let mut smooth = Value::Num(0.0);
    let mut ok = true;
    for a in args {
        match &a.name {
            None => match flatten_shapes(ck, &a.value, a.span) {
                Some(s) => shapes.extend(s),
                None => ok = false,
            },
            Some(n) if n.name == "smooth" => {
                if let Value::Num(k) = a.value
                    && k < 0.0
                {
                    ck.error(
                        Diagnostic::error("E0301", format!("`smooth` of `{name}` is out of range"))
                            .label(
                                a.span,
                                format!("this is {}, but it must be at least 0", Num(k)),
                            ),
                    );
                    ok = false;
                }
                ok &= ck.expect(
                    &a.value,
                    &Type::Num,
                    a.span,
                    &format!("argument `smooth` of `{name}`"),
                );
                smooth = a.value.clone();
            }
            Some(n) => {
                let hint = crate::check::suggest::did_you_mean(&n.name, ["smooth"]);
                ck.error(
                    Diagnostic::error("E0203", format!("`{name}` has no parameter `{}`", n.name))
                        .label(n.span, "unknown argument name")
                        .note(format!(
                            "`{name}` takes shapes (or lists of shapes) and `smooth`"
                        ))
                        .maybe_help(hint),
                );
                ok = false;
            }
        }
    }
    if !ok {
        return Value::Error;
    }
    if shapes.is_empty() {
        return ck.error(
            Diagnostic::error("E0204", format!("`{name}` needs at least one shape"))
                .label(span, "no shapes given")
                .help(format!(
                    "pass shapes or a list of shapes, as in `{name}(a, b)`"
                )),
        );
    }
    if shapes.len() == 1 {
        return Value::Shape(shapes.remove(0));
    }
    let Some(smooth) = smooth.num() else {
        return Value::Error;
    };
    let union = name == "union";
    let kind = if union {
        ShapeKind::Union { shapes, smooth }
    } else {
        ShapeKind::Intersect { shapes, smooth }
    };
    let v = make_shape(ck, kind, span);
    if !union
        && let Value::Shape(s) = &v
        && provably_empty(s)
    {
        ck.diags.push(
            Diagnostic::warning("W0003", "this intersection is empty")
                .label(span, "the shapes intersected here do not overlap anywhere")
                .note("an object with this shape can never be seen")
                .help("check the sizes and positions of the intersected shapes"),
        );
    }
    v
}

/// rotate(shape, plane, angle) | rotate(shape, rotation) | rotate(plane, angle) | rotate(rotation, plane, angle)
pub(super) fn rotate(ck: &mut Checker, args: Vec<ArgVal>, span: Span) -> Value {
    let first = args.first().map(|a| a.value.ty());
    let second = args.get(1).map(|a| a.value.ty());
    let names: &'static [&'static str] = match (&first, &second) {
        (Some(Type::Shape), Some(Type::Rotation)) => &["shape", "rotation"],
        (Some(Type::Shape), _) => &["shape", "plane", "angle"],
        (Some(Type::Rotation), _) => &["rotation", "plane", "angle"],
        _ => &["plane", "angle"],
    };
    let Some(slots) = ck.bind("rotate", names, args, span) else {
        return Value::Error;
    };
    let mut a = Args {
        ck,
        fname: "rotate",
        names: names.to_vec(),
        slots,
        span,
        ok: true,
    };
    let want = |n: &str| match n {
        "shape" => Type::Shape,
        "rotation" => Type::Rotation,
        "plane" => Type::Plane,
        _ => Type::Angle,
    };
    let vals: Vec<Value> = (0..names.len())
        .map(|i| a.get_or(i, want(names[i]), None).0)
        .collect();
    if !a.ok {
        return Value::Error;
    }
    let n = vals.len();
    let step: Rotation = match (&vals[n - 2], &vals[n - 1]) {
        (Value::Plane(p), angle) => match angle.num() {
            Some(angle) => vec![(*p, angle)],
            None => return Value::Error,
        },
        (_, Value::Rotation(r)) => return shape_rotation(ck, &vals[0], r.to_vec(), span),
        _ => return Value::Error,
    };
    match &vals[0] {
        Value::Rotation(r) if n == 3 => {
            Value::Rotation(Rc::new(r.iter().cloned().chain(step).collect()))
        }
        Value::Shape(_) => shape_rotation(ck, &vals[0], step, span),
        _ => Value::Rotation(Rc::new(step)),
    }
}

fn shape_rotation(ck: &mut Checker, shape: &Value, rotation: Rotation, span: Span) -> Value {
    match shape {
        Value::Shape(s) => make_shape(
            ck,
            ShapeKind::Rotate {
                shape: s.clone(),
                rotation,
            },
            span,
        ),
        _ => Value::Error,
    }
}

/// An intersection of shapes whose bounding balls miss each other is empty.
fn provably_empty(s: &Shape) -> bool {
    let ShapeKind::Intersect { shapes, smooth } = &s.kind else {
        return false;
    };
    let k = smooth.constant().unwrap_or(0.0);
    let bs: Vec<_> = shapes.iter().filter_map(|c| c.bounds()).collect();
    bs.iter().enumerate().any(|(i, a)| {
        bs[i + 1..]
            .iter()
            .any(|b| distance(a.0, b.0) > a.1 + b.1 + k)
    })
}

/// Warn when a tiled shape reaches outside the cell of its lattice point. The cells are
/// polytopes, so the shape stays inside exactly when its support in each facet's direction is
/// at most the facet's: for a grid, half the spacing along each repeated axis; for D4, the
/// 24-cell `|x_i| + |x_j| <= scale`, whose facets face the 24 nearest neighbours.
fn check_fit(ck: &mut Checker, s: &Shape, lat: &Lattice, lspan: Span, span: Span) {
    const AXES: [&str; 4] = ["x", "y", "z", "w"];
    // (direction towards a neighbour, its facet's distance from the centre, the direction's name)
    let mut facets: Vec<([f64; 4], f64, String)> = Vec::new();
    match lat {
        Lattice::Grid { spacing, limit } => {
            for i in (0..4).filter(|&i| limit[i] >= 1.0) {
                for sign in [1.0, -1.0] {
                    let mut v = [0.0; 4];
                    v[i] = sign;
                    let name = format!("{}{}", if sign > 0.0 { "+" } else { "-" }, AXES[i]);
                    facets.push((v, spacing[i] / 2.0, name));
                }
            }
        }
        Lattice::D4 { scale } => {
            for i in 0..4 {
                for j in i + 1..4 {
                    for (si, sj) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
                        let mut v = [0.0; 4];
                        v[i] = si;
                        v[j] = sj;
                        let n = v.map(|x| x * std::f64::consts::FRAC_1_SQRT_2);
                        let at: Vec<String> = v
                            .iter()
                            .map(|x| Num(round4(x * scale)).to_string())
                            .collect();
                        let name = format!("[{}]", at.join(", "));
                        facets.push((n, scale * std::f64::consts::FRAC_1_SQRT_2, name));
                    }
                }
            }
        }
    }
    // The facet the shape overshoots most, if any.
    let worst = facets
        .into_iter()
        .filter_map(|(v, room, name)| Some((s.support(v, 0.0)?, room, name)))
        .filter(|(reach, room, _)| *reach > room * (1.0 + 1e-9) + 1e-12)
        .reduce(|a, b| if b.0 - b.1 > a.0 - a.1 { b } else { a });
    let Some((reach, room, name)) = worst else {
        return;
    };
    let towards = match lat {
        Lattice::Grid { .. } => format!("along {name}"),
        Lattice::D4 { .. } => format!("towards the neighbour at {name}"),
    };
    ck.diags.push(
        Diagnostic::warning(
            "W0002",
            "the tiled shape does not fit inside its lattice cell",
        )
        .label(
            span,
            format!(
                "this shape reaches {} from its cell's centre {towards}",
                Num(round4(reach))
            ),
        )
        .label(
            lspan,
            format!(
                "but this lattice leaves only {} of room that way",
                Num(round4(room))
            ),
        )
        .note(
            "distances across cell borders are then wrong, and marching can step through surfaces",
        )
        .help("shrink the shape or space the lattice further apart"),
    );
}

fn round4(x: f64) -> f64 {
    (x * 1e4).round() / 1e4
}
