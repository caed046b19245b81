//! The builtin constants and functions: maths, shapes, operations, lattices, materials and
//! constructors. Parameters, defaults and ranges come from the scene's builtin table; this
//! file binds arguments to them, reports what is wrong, and builds typed scene values.

use super::eval::{ArgVal, Checker, MAX_SHAPE_DEPTH};
use super::ops;
use super::value::*;
use crate::diagnostic::Diagnostic;
use crate::scene::builtins::{self as table, ParamDefault, ParamSpec, SPECIAL};
use crate::scene::shape::{Polytope, distance};
use crate::source::Span;
use std::rc::Rc;

/// Every builtin name (for lookup and "did you mean").
pub fn names() -> impl Iterator<Item = &'static str> {
    (MathFn::ALL.iter().map(|(n, _)| *n))
        .chain(table::TABLE.iter().map(|b| b.name))
        .chain(SPECIAL)
        .chain(table::CONSTANTS)
}

pub fn is_function(name: &str) -> bool {
    names().any(|n| n == name) && !table::CONSTANTS.contains(&name)
}

pub fn intern(name: &str) -> &'static str {
    names().find(|n| *n == name).unwrap_or("?")
}

pub fn constant(ck: &mut Checker, name: &str) -> Option<Value> {
    Some(match name {
        "pi" => Value::Num(std::f64::consts::PI),
        "tau" => Value::Num(std::f64::consts::TAU),
        "inf" => Value::Num(f64::INFINITY),
        "air" => Value::Material(Rc::new(Material::Air)),
        "t" => ck.field(FieldOp::Input(Input::T), Type::Num),
        _ => {
            return Plane::ALL
                .iter()
                .find(|(n, _)| *n == name)
                .map(|(_, p)| Value::Plane(*p));
        }
    })
}

fn default_value(spec: &ParamSpec) -> Option<Value> {
    match spec.default {
        ParamDefault::Required => None,
        ParamDefault::Num(x) => Some(Value::Num(x)),
        ParamDefault::Vec4(v) => Some(Value::Vec4(v)),
        ParamDefault::Grey(x) => Some(Value::Color([x; 3])),
    }
}

/// Bound arguments of one builtin call, with typed accessors that report errors.
struct Args<'c, 'a> {
    ck: &'c mut Checker<'a>,
    fname: &'static str,
    names: Vec<&'static str>,
    slots: Vec<Option<ArgVal>>,
    span: Span,
    ok: bool,
}

impl Args<'_, '_> {
    /// The argument at `i`, converted to `want`, or `default`.
    fn get_or(&mut self, i: usize, want: Type, default: Option<Value>) -> (Value, Span) {
        let (v, span) = match (self.slots[i].take(), default) {
            (Some(a), _) => (a.value, a.span),
            (None, Some(d)) => (d, self.span),
            (None, None) => {
                self.ck.missing(self.fname, self.names[i], self.span);
                self.ok = false;
                return (Value::Error, self.span);
            }
        };
        let v = ops::coerce(self.ck, v, &want);
        let what = format!("argument `{}` of `{}`", self.names[i], self.fname);
        if !self.ck.expect(&v, &want, span, &what) {
            self.ok = false;
            return (Value::Error, span);
        }
        (v, span)
    }

    /// The argument at `i` as its table entry `spec` types and defaults it.
    fn get(&mut self, i: usize, spec: &ParamSpec) -> (Value, Span) {
        self.get_or(i, spec.ty.ty(), default_value(spec))
    }

    /// The argument at `i`, whose constant components must satisfy the entry's range.
    fn ranged(&mut self, i: usize, spec: &ParamSpec) -> Value {
        let (v, span) = self.get(i, spec);
        let comps: Vec<f64> = match &v {
            Value::Num(x) | Value::Angle(x) => vec![*x],
            Value::Vec4(a) => a.to_vec(),
            Value::Color(c) => c.to_vec(),
            _ => vec![],
        };
        if let Some(bad) = comps.iter().find(|x| !spec.range.test(**x)) {
            let shown = if matches!(v, Value::Angle(_)) {
                format!("{}deg", Num(bad.to_degrees()))
            } else {
                Num(*bad).to_string()
            };
            let rule = spec.range.rule();
            self.ck.error(
                Diagnostic::error(
                    "E0301",
                    format!("`{}` of `{}` is out of range", self.names[i], self.fname),
                )
                .label(span, format!("this is {shown}, but it must be {rule}"))
                .help(format!("choose a value that is {rule}")),
            );
            self.ok = false;
            return Value::Error;
        }
        v
    }

    /// A ranged compile-time constant.
    fn constant(&mut self, i: usize, spec: &ParamSpec) -> Value {
        let span = self.slots[i].as_ref().map_or(self.span, |a| a.span);
        let v = self.ranged(i, spec);
        let what = format!("`{}` of `{}`", self.names[i], self.fname);
        if !self.ck.require_const(&v, span, &what) {
            self.ok = false;
            return Value::Error;
        }
        v
    }

    /// A ranged number parameter (constant or field).
    fn num(&mut self, i: usize, spec: &ParamSpec) -> Param<f64> {
        let v = self.ranged(i, spec);
        v.num().unwrap_or(Param::Const(f64::NAN))
    }

    /// A shape argument.
    fn shape(&mut self, i: usize) -> Option<Rc<Shape>> {
        match self.get_or(i, Type::Shape, None).0 {
            Value::Shape(s) => Some(s),
            _ => {
                self.ok = false;
                None
            }
        }
    }
}

pub fn call(ck: &mut Checker, name: &'static str, args: Vec<ArgVal>, span: Span) -> Value {
    if let Some(f) = MathFn::from_name(name)
        && !(name == "round" && args.first().is_some_and(|a| a.value.ty() == Type::Shape))
    {
        return ops::math(ck, f, name, args, span);
    }
    match name {
        "union" | "intersect" => return combine(ck, name, args, span),
        "rotate" => return rotate(ck, args, span),
        _ => {}
    }
    let Some(builtin) = table::find(name) else {
        return Value::Error;
    };
    let names = builtin.names();
    let Some(slots) = ck.bind(name, &names, args, span) else {
        return Value::Error;
    };
    let mut a = Args {
        ck,
        fname: name,
        names,
        slots,
        span,
        ok: true,
    };
    let out = build(&mut a, name, builtin.params);
    if a.ok { out } else { Value::Error }
}

fn build(a: &mut Args, name: &'static str, specs: &'static [ParamSpec]) -> Value {
    use ShapeKind as S;
    // The number parameters in the table's order (shapes have them first or only).
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
        "vec4" => {
            let xs: Vec<Value> = (0..4).map(|i| a.get(i, &specs[i]).0).collect();
            if !a.ok {
                return Value::Error;
            }
            ops::make_vec4(a.ck, &xs)
        }
        "len" => {
            let (v, span) = a.get_or(0, Type::List(Box::new(Type::Unknown)), None);
            match v {
                Value::List(xs) => Value::Num(xs.len() as f64),
                Value::Error => Value::Error,
                _ => a.ck.error(
                    Diagnostic::error("E0201", "`len` takes a list").label(span, "not a list"),
                ),
            }
        }
        "rgb" => {
            // `rgb(x)` is a grey: the missing channels default to the first.
            let r = a.get(0, &specs[0]).0;
            let g = a.get_or(1, Type::Num, Some(r.clone())).0;
            let b = a.get_or(2, Type::Num, Some(r.clone())).0;
            if !a.ok {
                return Value::Error;
            }
            ops::make_color(a.ck, &[r, g, b])
        }
        "hsv" => {
            let [h, s, v] = [0, 1, 2].map(|i| a.constant(i, &specs[i]));
            match (h, s, v) {
                (Value::Angle(h), Value::Num(s), Value::Num(v)) => {
                    Value::Color(crate::math::color::hsv(h, s, v))
                }
                _ => Value::Error,
            }
        }
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
            let s = a.shape(0);
            let (l, lspan) = a.get(1, &specs[1]);
            let (Some(shape), Value::Lattice(lat)) = (s, l) else {
                return Value::Error;
            };
            check_fit(a.ck, &shape, &lat, lspan, a.span);
            primitive(
                a,
                S::Tile {
                    shape,
                    lattice: (*lat).clone(),
                },
            )
        }
        "d4" => match a.constant(0, &specs[0]) {
            Value::Num(scale) => Value::Lattice(Rc::new(Lattice::D4 { scale })),
            _ => Value::Error,
        },
        "grid" => {
            let (sp, sspan) = a.get_or(0, Type::Unknown, None);
            let spacing = match sp {
                Value::Num(x) => Some([x; 4]),
                Value::Vec4(v) => Some(v),
                Value::Error => None,
                other => {
                    a.ck.expect(&other, &Type::Vec4, sspan, "argument `spacing` of `grid`");
                    None
                }
            };
            if let Some(s) = spacing
                && s.iter().any(|x| *x <= 0.0 || !x.is_finite())
            {
                a.ck.error(
                    Diagnostic::error("E0301", "`spacing` of `grid` is out of range")
                        .label(sspan, "every spacing must be greater than 0 and finite"),
                );
                return Value::Error;
            }
            let spacing_value = spacing.map_or(Value::Error, Value::Vec4);
            a.ck.require_const(&spacing_value, sspan, "`spacing` of `grid`");
            let limit = a.constant(1, &specs[1]);
            match (spacing, limit) {
                (Some(spacing), Value::Vec4(limit)) => Value::Lattice(Rc::new(Lattice::Grid {
                    spacing,
                    limit: limit.map(f64::floor),
                })),
                _ => Value::Error,
            }
        }
        "d4_cell" | "lattice_cell" => {
            let p = a.get(0, &specs[0]).0;
            let lat = if name == "d4_cell" {
                match a.constant(1, &specs[1]) {
                    Value::Num(scale) => Lattice::D4 { scale },
                    _ => return Value::Error,
                }
            } else {
                match a.get(1, &specs[1]).0 {
                    Value::Lattice(l) => (*l).clone(),
                    _ => return Value::Error,
                }
            };
            match p {
                Value::Vec4(v) => Value::Vec4(lat.cell_of(v)),
                Value::Field(id, _) => a.ck.field(FieldOp::Cell(lat, id), Type::Vec4),
                _ => Value::Error,
            }
        }
        _ => material(a, name, specs),
    }
}

/// A material call: every parameter ranged and typed by the table.
fn material(a: &mut Args, name: &str, specs: &'static [ParamSpec]) -> Value {
    let Some(kind) = MaterialKind::ALL.into_iter().find(|k| k.name() == name) else {
        return Value::Error;
    };
    let params: Vec<Slot<Param<f64>, Param<[f64; 3]>>> = (0..specs.len())
        .map(|i| {
            let v = a.ranged(i, &specs[i]);
            if specs[i].ty == table::ParamType::Color {
                Slot::Color(v.color().unwrap_or(Param::Const([f64::NAN; 3])))
            } else {
                Slot::Num(v.num().unwrap_or(Param::Const(f64::NAN)))
            }
        })
        .collect();
    if !a.ok {
        return Value::Error;
    }
    match Material::from_params(kind, params) {
        Some(m) => Value::Material(Rc::new(m)),
        None => Value::Error,
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
fn combine(ck: &mut Checker, name: &'static str, args: Vec<ArgVal>, span: Span) -> Value {
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
                let hint = super::suggest::did_you_mean(&n.name, ["smooth"]);
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
fn rotate(ck: &mut Checker, args: Vec<ArgVal>, span: Span) -> Value {
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

/// Warn when a tiled shape reaches outside the cell of its lattice point.
fn check_fit(ck: &mut Checker, s: &Shape, lat: &Lattice, lspan: Span, span: Span) {
    let Some((c, r)) = s.bounds() else { return };
    let reach = r + distance(c, [0.0; 4]);
    let room = lat.inradius();
    if reach > room * (1.0 + 1e-9) {
        ck.diags.push(
            Diagnostic::warning("W0002", "the tiled shape does not fit inside its lattice cell")
                .label(span, format!("this shape reaches {} from its cell's centre", Num(round4(reach))))
                .label(lspan, format!("but this lattice leaves only {} of room", Num(round4(room))))
                .note("distances across cell borders are then wrong, and marching can step through surfaces")
                .help("shrink the shape or space the lattice further apart"),
        );
    }
}

fn round4(x: f64) -> f64 {
    (x * 1e4).round() / 1e4
}
