//! The builtin constants and functions: maths, shapes, operations, lattices and materials,
//! with their parameters, defaults and allowed ranges.

use super::eval::{ArgVal, Checker, MAX_SHAPE_DEPTH};
use super::ops;
use super::types::Type;
use super::value::*;
use crate::diagnostic::Diagnostic;
use crate::source::Span;
use std::rc::Rc;

/// Every builtin function name (for lookup and "did you mean").
pub const NAMES: &[&str] = &[
    "sin",
    "cos",
    "tan",
    "asin",
    "acos",
    "atan",
    "atan2",
    "sqrt",
    "abs",
    "floor",
    "ceil",
    "round",
    "fract",
    "sign",
    "exp",
    "log",
    "pow",
    "min",
    "max",
    "clamp",
    "mix",
    "length",
    "dot",
    "normalize",
    "vec4",
    "len",
    "rgb",
    "hsv",
    "hypersphere",
    "halfspace",
    "hyperbox",
    "spherinder",
    "cubinder",
    "duocylinder",
    "cell5",
    "cell16",
    "cell24",
    "union",
    "intersect",
    "subtract",
    "onion",
    "translate",
    "rotate",
    "scale",
    "symmetry",
    "tile",
    "d4",
    "grid",
    "d4_cell",
    "lattice_cell",
    "diffuse",
    "light",
    "mirror",
    "glass",
    "shiny",
    "fog",
    "pi",
    "tau",
    "inf",
    "air",
    "t",
    "xy",
    "xz",
    "xw",
    "yz",
    "yw",
    "zw",
];

const CONSTANTS: &[&str] = &[
    "pi", "tau", "inf", "air", "t", "xy", "xz", "xw", "yz", "yw", "zw",
];

pub fn is_function(name: &str) -> bool {
    NAMES.contains(&name) && !CONSTANTS.contains(&name)
}

pub fn intern(name: &str) -> &'static str {
    NAMES.iter().find(|n| **n == name).copied().unwrap_or("?")
}

pub fn constant(ck: &mut Checker, name: &str) -> Option<Value> {
    Some(match name {
        "pi" => Value::Num(std::f64::consts::PI),
        "tau" => Value::Num(std::f64::consts::TAU),
        "inf" => Value::Num(f64::INFINITY),
        "air" => Value::Material(Rc::new(Material {
            kind: MaterialKind::Air,
            params: vec![],
        })),
        "t" => ck.field(FieldOp::Input(Input::T), Type::Num),
        _ => {
            return Plane::ALL
                .iter()
                .find(|(n, _)| *n == name)
                .map(|(_, p)| Value::Plane(*p));
        }
    })
}

/// Bound arguments of one builtin call, with typed accessors that report errors.
struct Args<'c, 'a> {
    ck: &'c mut Checker<'a>,
    fname: &'static str,
    names: &'static [&'static str],
    slots: Vec<Option<ArgVal>>,
    span: Span,
    ok: bool,
}

impl Args<'_, '_> {
    /// The argument at `i`, converted to `want`, or the default.
    fn get(&mut self, i: usize, want: Type, default: Option<Value>) -> (Value, Span) {
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

    /// A value whose constant components must satisfy `test`, described as `rule`.
    fn ranged(
        &mut self,
        i: usize,
        want: Type,
        default: Option<Value>,
        test: fn(f64) -> bool,
        rule: &str,
    ) -> Value {
        let (v, span) = self.get(i, want, default);
        let comps: Vec<f64> = match &v {
            Value::Num(x) | Value::Angle(x) => vec![*x],
            Value::Vec4(a) => a.to_vec(),
            Value::Color(c) => c.to_vec(),
            _ => vec![],
        };
        if let Some(bad) = comps.iter().find(|x| !test(**x)) {
            let shown = if matches!(v, Value::Angle(_)) {
                format!("{}deg", Num(bad.to_degrees()))
            } else {
                Num(*bad).to_string()
            };
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

    /// A compile-time constant.
    fn constant(
        &mut self,
        i: usize,
        want: Type,
        default: Option<Value>,
        test: fn(f64) -> bool,
        rule: &str,
    ) -> Value {
        let span = self.slots[i].as_ref().map_or(self.span, |a| a.span);
        let v = self.ranged(i, want, default, test, rule);
        let what = format!("`{}` of `{}`", self.names[i], self.fname);
        if !self.ck.require_const(&v, span, &what) {
            self.ok = false;
            return Value::Error;
        }
        v
    }
}

fn nonneg(x: f64) -> bool {
    x >= 0.0
}
fn positive(x: f64) -> bool {
    x > 0.0
}
fn unit(x: f64) -> bool {
    (0.0..=1.0).contains(&x)
}
fn any(_: f64) -> bool {
    true
}

fn grey(x: f64) -> Option<Value> {
    Some(Value::Color([x, x, x]))
}
fn num(x: f64) -> Option<Value> {
    Some(Value::Num(x))
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
    let names: &'static [&'static str] = match name {
        "vec4" => &["x", "y", "z", "w"],
        "len" => &["list"],
        "rgb" => &["r", "g", "b"],
        "hsv" => &["h", "s", "v"],
        "hypersphere" | "cell5" | "cell16" | "cell24" => &["radius"],
        "halfspace" => &["normal", "offset"],
        "hyperbox" => &["half", "radius"],
        "spherinder" | "cubinder" => &["radius", "height"],
        "duocylinder" => &["radius1", "radius2"],
        "subtract" => &["shape", "cut", "smooth"],
        "onion" => &["shape", "thickness"],
        "round" => &["shape", "radius"],
        "translate" => &["shape", "offset"],
        "scale" => &["shape", "factor"],
        "symmetry" => &["shape", "normal"],
        "tile" => &["shape", "lattice"],
        "d4" => &["scale"],
        "grid" => &["spacing", "limit"],
        "d4_cell" => &["p", "scale"],
        "lattice_cell" => &["p", "lattice"],
        "diffuse" => &["albedo", "emission"],
        "light" => &["color", "intensity"],
        "mirror" => &["tint"],
        "glass" => &["ior", "tint", "extinction", "albedo"],
        "shiny" => &["roughness", "color"],
        "fog" => &["extinction", "albedo", "anisotropy"],
        _ => &[],
    };
    let Some(slots) = ck.bind(name, names, args, span) else {
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
    let out = build(&mut a, name);
    if a.ok { out } else { Value::Error }
}

fn build(a: &mut Args, name: &'static str) -> Value {
    use ShapeKind as S;
    let shape =
        |a: &mut Args, kind, params: Vec<(&'static str, Value)>, children: Vec<Rc<Shape>>| {
            if !a.ok {
                return Value::Error;
            }
            make_shape(a.ck, kind, params, children, a.span)
        };
    let material = |a: &Args, kind, params: Vec<(&'static str, Value)>| {
        if !a.ok {
            return Value::Error;
        }
        Value::Material(Rc::new(Material { kind, params }))
    };
    match name {
        "vec4" => {
            let xs: Vec<Value> = (0..4).map(|i| a.get(i, Type::Num, None).0).collect();
            if !a.ok {
                return Value::Error;
            }
            ops::make_vec4(a.ck, &xs)
        }
        "len" => {
            let (v, span) = a.get(0, Type::List(Box::new(Type::Unknown)), None);
            match v {
                Value::List(xs) => Value::Num(xs.len() as f64),
                Value::Error => Value::Error,
                _ => a.ck.error(
                    Diagnostic::error("E0201", "`len` takes a list").label(span, "not a list"),
                ),
            }
        }
        "rgb" => {
            let r = a.get(0, Type::Num, None).0;
            let g = a.get(1, Type::Num, Some(r.clone())).0;
            let b = a.get(2, Type::Num, Some(r.clone())).0;
            if !a.ok {
                return Value::Error;
            }
            ops::make_color(a.ck, &[r, g, b])
        }
        "hsv" => {
            let h = a.constant(0, Type::Angle, None, any, "any angle");
            let s = a.constant(1, Type::Num, num(1.0), unit, "between 0 and 1");
            let v = a.constant(2, Type::Num, num(1.0), nonneg, "at least 0");
            match (h, s, v) {
                (Value::Angle(h), Value::Num(s), Value::Num(v)) => Value::Color(crate::math::color::hsv(h, s, v)),
                _ => Value::Error,
            }
        }
        "hypersphere" => {
            let r = a.ranged(0, Type::Num, num(1.0), nonneg, "at least 0");
            shape(a, S::Hypersphere, vec![("radius", r)], vec![])
        }
        "cell5" | "cell16" | "cell24" => {
            let r = a.ranged(0, Type::Num, num(1.0), nonneg, "at least 0");
            let kind = match name {
                "cell5" => S::Cell5,
                "cell16" => S::Cell16,
                _ => S::Cell24,
            };
            shape(a, kind, vec![("radius", r)], vec![])
        }
        "halfspace" => {
            let (n, nspan) = a.get(0, Type::Vec4, Some(Value::Vec4([0.0, 1.0, 0.0, 0.0])));
            let n = match n {
                Value::Vec4(v) if v.iter().all(|x| *x == 0.0) => {
                    a.ok = false;
                    a.ck.error(
                        Diagnostic::error("E0301", "a halfspace needs a nonzero normal")
                            .label(nspan, "this vector is zero")
                            .help("the normal points out of the solid, e.g. `[0, 1, 0, 0]`"),
                    )
                }
                Value::Vec4(v) => {
                    let len = v.iter().map(|x| x * x).sum::<f64>().sqrt();
                    Value::Vec4(v.map(|x| x / len))
                }
                other => other,
            };
            let o = a.get(1, Type::Num, num(0.0)).0;
            shape(a, S::Halfspace, vec![("normal", n), ("offset", o)], vec![])
        }
        "hyperbox" => {
            let (h, hspan) = a.get(0, Type::Unknown, Some(Value::Vec4([1.0; 4])));
            let h = match h {
                Value::Num(x) => Value::Vec4([x; 4]),
                Value::Vec4(_) | Value::Error => h,
                Value::Field(_, Type::Num | Type::Vec4) => h,
                other => {
                    a.ok = false;
                    a.ck.expect(&other, &Type::Vec4, hspan, "argument `half` of `hyperbox`");
                    Value::Error
                }
            };
            if let Value::Vec4(v) = &h
                && let Some(bad) = v.iter().find(|x| **x < 0.0)
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
            let r = a.ranged(1, Type::Num, num(0.0), nonneg, "at least 0");
            shape(a, S::Hyperbox, vec![("half", h), ("radius", r)], vec![])
        }
        "spherinder" | "cubinder" => {
            let r = a.ranged(0, Type::Num, num(1.0), nonneg, "at least 0");
            let h = a.ranged(1, Type::Num, num(1.0), nonneg, "at least 0");
            let kind = if name == "spherinder" {
                S::Spherinder
            } else {
                S::Cubinder
            };
            shape(a, kind, vec![("radius", r), ("height", h)], vec![])
        }
        "duocylinder" => {
            let r1 = a.ranged(0, Type::Num, num(1.0), nonneg, "at least 0");
            let r2 = a.ranged(1, Type::Num, num(1.0), nonneg, "at least 0");
            shape(
                a,
                S::Duocylinder,
                vec![("radius1", r1), ("radius2", r2)],
                vec![],
            )
        }
        "subtract" => {
            let s = shape_arg(a, 0);
            let (cut, cspan) = a.get(1, Type::Unknown, None);
            let cut = match cut {
                Value::Shape(c) => Some(c),
                Value::List(_) => match flatten_shapes(a.ck, &cut, cspan) {
                    Some(cs) if cs.len() == 1 => Some(cs[0].clone()),
                    Some(cs) => match make_shape(
                        a.ck,
                        S::Union,
                        vec![("smooth", Value::Num(0.0))],
                        cs,
                        cspan,
                    ) {
                        Value::Shape(u) => Some(u),
                        _ => None,
                    },
                    None => None,
                },
                Value::Error => None,
                other => {
                    a.ck.expect(&other, &Type::Shape, cspan, "argument `cut` of `subtract`");
                    None
                }
            };
            let k = a.ranged(2, Type::Num, num(0.0), nonneg, "at least 0");
            match (s, cut) {
                (Some(s), Some(c)) => shape(a, S::Subtract, vec![("smooth", k)], vec![s, c]),
                _ => {
                    a.ok = false;
                    Value::Error
                }
            }
        }
        "onion" | "round" | "translate" | "scale" | "symmetry" => {
            let s = shape_arg(a, 0);
            let (kind, pname, v) = match name {
                "onion" => (
                    S::Onion,
                    "thickness",
                    a.ranged(1, Type::Num, None, nonneg, "at least 0"),
                ),
                "round" => (
                    S::Round,
                    "radius",
                    a.ranged(1, Type::Num, None, nonneg, "at least 0"),
                ),
                "translate" => (S::Translate, "offset", a.get(1, Type::Vec4, None).0),
                "scale" => (
                    S::Scale,
                    "factor",
                    a.ranged(1, Type::Num, None, positive, "greater than 0"),
                ),
                _ => (S::Symmetry, "normal", a.get(1, Type::Vec4, None).0),
            };
            match s {
                Some(s) => shape(a, kind, vec![(pname, v)], vec![s]),
                None => Value::Error,
            }
        }
        "tile" => {
            let s = shape_arg(a, 0);
            let (l, lspan) = a.get(1, Type::Lattice, None);
            let (Some(s), Value::Lattice(lat)) = (s, l) else {
                return Value::Error;
            };
            check_fit(a.ck, &s, &lat, lspan, a.span);
            shape(a, S::Tile, vec![("lattice", Value::Lattice(lat))], vec![s])
        }
        "d4" => match a.constant(0, Type::Num, num(1.0), positive, "greater than 0") {
            Value::Num(scale) => Value::Lattice(Rc::new(Lattice::D4 { scale })),
            _ => Value::Error,
        },
        "grid" => {
            let (sp, sspan) = a.get(0, Type::Unknown, None);
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
            a.ck.require_const(&sp_value(spacing), sspan, "`spacing` of `grid`");
            let limit = a.constant(
                1,
                Type::Vec4,
                Some(Value::Vec4([f64::INFINITY; 4])),
                nonneg,
                "at least 0",
            );
            match (spacing, limit) {
                (Some(spacing), Value::Vec4(limit)) => Value::Lattice(Rc::new(Lattice::Grid {
                    spacing,
                    limit: limit.map(f64::floor),
                })),
                _ => Value::Error,
            }
        }
        "d4_cell" | "lattice_cell" => {
            let p = a.get(0, Type::Vec4, None).0;
            let lat = if name == "d4_cell" {
                match a.constant(1, Type::Num, num(1.0), positive, "greater than 0") {
                    Value::Num(scale) => Lattice::D4 { scale },
                    _ => return Value::Error,
                }
            } else {
                match a.get(1, Type::Lattice, None).0 {
                    Value::Lattice(l) => (*l).clone(),
                    _ => return Value::Error,
                }
            };
            match p {
                Value::Vec4(v) => Value::Vec4(cell_of(&lat, v)),
                Value::Field(id, _) => a.ck.field(FieldOp::Cell(lat, id), Type::Vec4),
                _ => Value::Error,
            }
        }
        "diffuse" => {
            let albedo = a.ranged(0, Type::Color, grey(0.8), unit, "between 0 and 1");
            let emission = a.ranged(1, Type::Color, grey(0.0), nonneg, "at least 0");
            material(
                a,
                MaterialKind::Diffuse,
                vec![("albedo", albedo), ("emission", emission)],
            )
        }
        "light" => {
            let c = a.ranged(0, Type::Color, grey(1.0), nonneg, "at least 0");
            let i = a.ranged(1, Type::Num, num(1.0), nonneg, "at least 0");
            material(a, MaterialKind::Light, vec![("color", c), ("intensity", i)])
        }
        "mirror" => {
            let tint = a.ranged(0, Type::Color, grey(1.0), unit, "between 0 and 1");
            material(a, MaterialKind::Mirror, vec![("tint", tint)])
        }
        "glass" => {
            let ior = a.ranged(0, Type::Num, num(1.5), positive, "greater than 0");
            let tint = a.ranged(1, Type::Color, grey(1.0), unit, "between 0 and 1");
            let ext = a.ranged(2, Type::Num, num(0.0), nonneg, "at least 0");
            let albedo = a.ranged(3, Type::Color, grey(1.0), unit, "between 0 and 1");
            material(
                a,
                MaterialKind::Glass,
                vec![
                    ("ior", ior),
                    ("tint", tint),
                    ("extinction", ext),
                    ("albedo", albedo),
                ],
            )
        }
        "shiny" => {
            let r = a.ranged(0, Type::Num, num(0.3), unit, "between 0 and 1");
            let c = a.ranged(1, Type::Color, grey(0.9), unit, "between 0 and 1");
            material(a, MaterialKind::Shiny, vec![("roughness", r), ("color", c)])
        }
        "fog" => {
            let ext = a.ranged(0, Type::Num, num(0.1), nonneg, "at least 0");
            let albedo = a.ranged(1, Type::Color, grey(0.9), unit, "between 0 and 1");
            let g = a.ranged(
                2,
                Type::Num,
                num(0.0),
                |g| g > -1.0 && g < 1.0,
                "strictly between -1 and 1",
            );
            material(
                a,
                MaterialKind::Fog,
                vec![("extinction", ext), ("albedo", albedo), ("anisotropy", g)],
            )
        }
        _ => Value::Error,
    }
}

fn sp_value(spacing: Option<[f64; 4]>) -> Value {
    spacing.map_or(Value::Error, Value::Vec4)
}

fn shape_arg(a: &mut Args, i: usize) -> Option<Rc<Shape>> {
    match a.get(i, Type::Shape, None).0 {
        Value::Shape(s) => Some(s),
        _ => {
            a.ok = false;
            None
        }
    }
}

/// Build a shape node, checking that its parameters do not vary per point and bounding depth.
pub fn make_shape(
    ck: &mut Checker,
    kind: ShapeKind,
    params: Vec<(&'static str, Value)>,
    children: Vec<Rc<Shape>>,
    span: Span,
) -> Value {
    if kind != ShapeKind::Custom {
        for (name, v) in &params {
            let deps = ck.deps(v);
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
    if kind == ShapeKind::Rotate
        && let [child] = children.as_slice()
        && child.kind == ShapeKind::Rotate
        && let (Some(Value::Rotation(inner)), Some((_, Value::Rotation(outer)))) =
            (child.param("rotation"), params.first())
    {
        let merged: Vec<(Plane, Value)> = inner.iter().chain(outer.iter()).cloned().collect();
        let merged = vec![("rotation", Value::Rotation(Rc::new(merged)))];
        return make_shape(ck, kind, merged, child.children.clone(), span);
    }
    let depth = 1 + children.iter().map(|c| c.depth).max().unwrap_or(0);
    if depth > MAX_SHAPE_DEPTH {
        return ck.error(
            Diagnostic::error("E0402", "shape nested too deeply")
                .label(
                    span,
                    format!("this shape is more than {MAX_SHAPE_DEPTH} operations deep"),
                )
                .help("combine many shapes with one `union` of a list instead of nesting"),
        );
    }
    Value::Shape(Rc::new(Shape {
        kind,
        params,
        children,
        depth,
    }))
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
    let kind = if name == "union" {
        ShapeKind::Union
    } else {
        ShapeKind::Intersect
    };
    if shapes.len() == 1 {
        return Value::Shape(shapes.remove(0));
    }
    let v = make_shape(ck, kind, vec![("smooth", smooth)], shapes, span);
    if kind == ShapeKind::Intersect
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
        names,
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
        .map(|i| a.get(i, want(names[i]), None).0)
        .collect();
    if !a.ok {
        return Value::Error;
    }
    let n = vals.len();
    let step = match (&vals[n - 2], &vals[n - 1]) {
        (Value::Plane(p), angle) => vec![(*p, angle.clone())],
        (_, r @ Value::Rotation(_)) => return shape_rotation(ck, &vals[0], r.clone(), span),
        _ => return Value::Error,
    };
    match &vals[0] {
        Value::Rotation(r) if n == 3 => {
            Value::Rotation(Rc::new(r.iter().cloned().chain(step).collect()))
        }
        Value::Shape(_) => shape_rotation(ck, &vals[0], Value::Rotation(Rc::new(step)), span),
        _ => Value::Rotation(Rc::new(step)),
    }
}

fn shape_rotation(ck: &mut Checker, shape: &Value, rotation: Value, span: Span) -> Value {
    match shape {
        Value::Shape(s) => make_shape(
            ck,
            ShapeKind::Rotate,
            vec![("rotation", rotation)],
            vec![s.clone()],
            span,
        ),
        _ => Value::Error,
    }
}

/// The nearest lattice point (D4: Conway-Sloane decoder) in lattice units, or the grid cell.
pub fn cell_of(lat: &Lattice, p: [f64; 4]) -> [f64; 4] {
    match lat {
        Lattice::D4 { scale } => d4_nearest(p.map(|x| x / scale)),
        Lattice::Grid { spacing, limit } => {
            std::array::from_fn(|i| (p[i] / spacing[i]).round().clamp(-limit[i], limit[i]))
        }
    }
}

/// Conway and Sloane: round every coordinate; if the sum is odd, re-round the coordinate with
/// the largest rounding error the other way.
pub fn d4_nearest(p: [f64; 4]) -> [f64; 4] {
    let mut r = p.map(f64::round);
    let sum: f64 = r.iter().sum();
    if floor_is_odd(sum) {
        let (k, _) = (0..4)
            .map(|i| (i, (p[i] - r[i]).abs()))
            .fold(
                (0, -1.0),
                |best, cur| if cur.1 > best.1 { cur } else { best },
            );
        r[k] += if p[k] > r[k] { 1.0 } else { -1.0 };
    }
    r
}

fn floor_is_odd(x: f64) -> bool {
    ops::floor_mod(x, 2.0) == 1.0
}

/// A ball (centre, radius) containing the shape, when its parameters are constants.
pub fn bounds(s: &Shape) -> Option<([f64; 4], f64)> {
    let num = |n: &str| match s.param(n) {
        Some(Value::Num(x)) => Some(*x),
        _ => None,
    };
    let child = |i: usize| s.children.get(i).and_then(|c| bounds(c));
    let o = [0.0; 4];
    Some(match s.kind {
        ShapeKind::Hypersphere | ShapeKind::Cell5 | ShapeKind::Cell16 | ShapeKind::Cell24 => {
            (o, num("radius")?)
        }
        ShapeKind::Hyperbox => match s.param("half") {
            Some(Value::Vec4(h)) => (
                o,
                h.iter().map(|x| x * x).sum::<f64>().sqrt() + num("radius")?,
            ),
            _ => return None,
        },
        ShapeKind::Spherinder => (o, num("radius")?.hypot(num("height")?)),
        ShapeKind::Cubinder => (
            o,
            (num("radius")?.powi(2) + 2.0 * num("height")?.powi(2)).sqrt(),
        ),
        ShapeKind::Duocylinder => (o, num("radius1")?.hypot(num("radius2")?)),
        ShapeKind::Halfspace | ShapeKind::Custom | ShapeKind::Tile | ShapeKind::Symmetry => {
            return None;
        }
        ShapeKind::Union => {
            let bs: Vec<_> = (0..s.children.len()).map(child).collect::<Option<_>>()?;
            let k = num("smooth").unwrap_or(0.0);
            let c = bs[0].0;
            let r = bs
                .iter()
                .map(|(bc, br)| dist(c, *bc) + br)
                .fold(0.0, f64::max);
            (c, r + k)
        }
        ShapeKind::Intersect => {
            let bs: Vec<_> = (0..s.children.len()).filter_map(child).collect();
            *bs.iter().min_by(|a, b| a.1.total_cmp(&b.1))?
        }
        ShapeKind::Subtract => child(0)?,
        ShapeKind::Onion => {
            let (c, r) = child(0)?;
            (c, r + num("thickness")? / 2.0)
        }
        ShapeKind::Round => {
            let (c, r) = child(0)?;
            (c, r + num("radius")?)
        }
        ShapeKind::Translate => {
            let (c, r) = child(0)?;
            let Some(Value::Vec4(v)) = s.param("offset") else {
                return None;
            };
            (std::array::from_fn(|i| c[i] + v[i]), r)
        }
        ShapeKind::Rotate => {
            let (c, r) = child(0)?;
            if c != o {
                return None;
            }
            (o, r)
        }
        ShapeKind::Scale => {
            let (c, r) = child(0)?;
            let k = num("factor")?;
            (c.map(|x| x * k), r * k)
        }
    })
}

fn dist(a: [f64; 4], b: [f64; 4]) -> f64 {
    a.iter()
        .zip(&b)
        .map(|(x, y)| (x - y).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// An intersection of shapes whose bounding balls miss each other is empty.
fn provably_empty(s: &Shape) -> bool {
    let bs: Vec<_> = s.children.iter().filter_map(|c| bounds(c)).collect();
    bs.iter().enumerate().any(|(i, a)| {
        bs[i + 1..]
            .iter()
            .any(|b| dist(a.0, b.0) > a.1 + b.1 + num_smooth(s))
    })
}

fn num_smooth(s: &Shape) -> f64 {
    match s.param("smooth") {
        Some(Value::Num(k)) => *k,
        _ => 0.0,
    }
}

/// Warn when a tiled shape reaches outside the cell of its lattice point.
fn check_fit(ck: &mut Checker, s: &Shape, lat: &Lattice, lspan: Span, span: Span) {
    let Some((c, r)) = bounds(s) else { return };
    let reach = r + dist(c, [0.0; 4]);
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn d4_decoder_matches_brute_force() {
        let mut seed = 12345u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 20.0
        };
        for _ in 0..2000 {
            let p = [rnd(), rnd(), rnd(), rnd()];
            let got = d4_nearest(p);
            let mut best = f64::INFINITY;
            for m in 0..81usize {
                let q: [f64; 4] = std::array::from_fn(|i| {
                    p[i].round() + ((m / 3usize.pow(i as u32)) % 3) as f64 - 1.0
                });
                if (q.iter().sum::<f64>() as i64).rem_euclid(2) == 0 {
                    best = best.min(dist(p, q));
                }
            }
            assert!(
                (got.iter().sum::<f64>() as i64).rem_euclid(2) == 0,
                "{got:?} not in D4"
            );
            assert!(
                dist(p, got) <= best + 1e-12,
                "{p:?}: got {got:?} at {} but best is {best}",
                dist(p, got)
            );
        }
    }
}
