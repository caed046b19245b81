//! The builtin table: every builtin shape, operation, lattice, material and constructor with
//! its parameters, their types, defaults and allowed ranges. The checker binds and checks
//! arguments from it, the renderer takes its fallbacks from it, and a test keeps the tables
//! of `docs/language.md` in step with it.

use super::types::Type;

/// What a parameter may be, besides its type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Range {
    /// No restriction.
    Any,
    /// At least 0.
    NonNegative,
    /// Greater than 0.
    Positive,
    /// Between 0 and 1, both included.
    Unit,
    /// Strictly between -1 and 1.
    OpenSigned,
}

impl Range {
    /// Whether `x` obeys the rule.
    pub fn test(self, x: f64) -> bool {
        match self {
            Range::Any => true,
            Range::NonNegative => x >= 0.0,
            Range::Positive => x > 0.0,
            Range::Unit => (0.0..=1.0).contains(&x),
            Range::OpenSigned => x > -1.0 && x < 1.0,
        }
    }

    /// The rule as the diagnostics state it.
    pub fn rule(self) -> &'static str {
        match self {
            Range::Any => "any value",
            Range::NonNegative => "at least 0",
            Range::Positive => "greater than 0",
            Range::Unit => "between 0 and 1",
            Range::OpenSigned => "strictly between -1 and 1",
        }
    }
}

/// A parameter's default.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ParamDefault {
    /// The argument must be given.
    Required,
    /// A number.
    Num(f64),
    /// A `vec4`.
    Vec4([f64; 4]),
    /// A grey colour.
    Grey(f64),
}

impl ParamDefault {
    /// The default as a number (a grey's level), for renderer fallbacks.
    pub fn num(self) -> f64 {
        match self {
            ParamDefault::Num(x) | ParamDefault::Grey(x) => x,
            ParamDefault::Vec4(v) => v[0],
            ParamDefault::Required => 0.0,
        }
    }
}

/// A parameter's type (the subset of [`Type`] builtins take, so the table can be a constant).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamType {
    /// `num`
    Num,
    /// `angle`
    Angle,
    /// `vec4`
    Vec4,
    /// `color`
    Color,
    /// `shape`
    Shape,
    /// `lattice`
    Lattice,
    /// A list of anything.
    List,
}

impl ParamType {
    /// The language type the parameter has.
    pub fn ty(self) -> Type {
        match self {
            ParamType::Num => Type::Num,
            ParamType::Angle => Type::Angle,
            ParamType::Vec4 => Type::Vec4,
            ParamType::Color => Type::Color,
            ParamType::Shape => Type::Shape,
            ParamType::Lattice => Type::Lattice,
            ParamType::List => Type::List(Box::new(Type::Unknown)),
        }
    }
}

#[derive(Debug, PartialEq)]
/// One parameter of a builtin: its name, type, default and allowed range.
pub struct ParamSpec {
    /// The name, as named arguments write it.
    pub name: &'static str,
    /// Its type.
    pub ty: ParamType,
    /// Its default, or `Required`.
    pub default: ParamDefault,
    /// What values beyond the type it accepts; each component of a constant is checked.
    pub range: Range,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
/// What a builtin makes, which decides where it may be used.
pub enum Kind {
    /// A primitive shape (`hypersphere`, ...).
    Shape,
    /// An operation on shapes (`union`, `translate`, ...).
    Operation,
    /// A lattice for `tile` (`d4`, `grid`).
    Lattice,
    /// A material (`diffuse`, `glass`, ...).
    Material,
    /// A value constructor (`rgb`, `vec4`, ...).
    Constructor,
}

#[derive(Debug, PartialEq)]
/// One builtin: its name, what it makes and its parameters in positional order.
pub struct Builtin {
    /// The name it is called by.
    pub name: &'static str,
    /// What it makes.
    pub kind: Kind,
    /// Its parameters, in positional order.
    pub params: &'static [ParamSpec],
}

impl Builtin {
    /// The parameter names, in order.
    pub fn names(&self) -> Vec<&'static str> {
        self.params.iter().map(|p| p.name).collect()
    }
}

const fn p(name: &'static str, ty: ParamType, default: ParamDefault, range: Range) -> ParamSpec {
    ParamSpec {
        name,
        ty,
        default,
        range,
    }
}

use ParamDefault::{Grey, Num as N, Required, Vec4 as V};
use Range::{Any, NonNegative as NonNeg, OpenSigned, Positive, Unit};

const RADIUS: ParamSpec = p("radius", ParamType::Num, N(1.0), NonNeg);
const SHAPE: ParamSpec = p("shape", ParamType::Shape, Required, Any);

/// Every builtin taking named parameters. `union`, `intersect` (any number of shapes) and
/// `rotate` (four call forms) bind their arguments themselves; the maths functions are
/// [`MathFn`](super::field::MathFn).
pub const TABLE: &[Builtin] = &[
    b("hypersphere", Kind::Shape, &[RADIUS]),
    b(
        "halfspace",
        Kind::Shape,
        &[
            p("normal", ParamType::Vec4, V([0.0, 1.0, 0.0, 0.0]), Any),
            p("offset", ParamType::Num, N(0.0), Any),
        ],
    ),
    b(
        "hyperbox",
        Kind::Shape,
        &[
            p("half", ParamType::Vec4, V([1.0; 4]), NonNeg),
            p("radius", ParamType::Num, N(0.0), NonNeg),
        ],
    ),
    b(
        "spherinder",
        Kind::Shape,
        &[RADIUS, p("height", ParamType::Num, N(1.0), NonNeg)],
    ),
    b(
        "cubinder",
        Kind::Shape,
        &[RADIUS, p("height", ParamType::Num, N(1.0), NonNeg)],
    ),
    b(
        "duocylinder",
        Kind::Shape,
        &[
            p("radius1", ParamType::Num, N(1.0), NonNeg),
            p("radius2", ParamType::Num, N(1.0), NonNeg),
        ],
    ),
    b("cell5", Kind::Shape, &[RADIUS]),
    b("cell16", Kind::Shape, &[RADIUS]),
    b("cell24", Kind::Shape, &[RADIUS]),
    b(
        "subtract",
        Kind::Operation,
        &[
            SHAPE,
            p("cut", ParamType::Shape, Required, Any),
            p("smooth", ParamType::Num, N(0.0), NonNeg),
        ],
    ),
    b(
        "onion",
        Kind::Operation,
        &[SHAPE, p("thickness", ParamType::Num, Required, NonNeg)],
    ),
    b(
        "round",
        Kind::Operation,
        &[SHAPE, p("radius", ParamType::Num, Required, NonNeg)],
    ),
    b(
        "translate",
        Kind::Operation,
        &[SHAPE, p("offset", ParamType::Vec4, Required, Any)],
    ),
    b(
        "scale",
        Kind::Operation,
        &[SHAPE, p("factor", ParamType::Num, Required, Positive)],
    ),
    b(
        "symmetry",
        Kind::Operation,
        &[SHAPE, p("normal", ParamType::Vec4, Required, Any)],
    ),
    b(
        "tile",
        Kind::Operation,
        &[SHAPE, p("lattice", ParamType::Lattice, Required, Any)],
    ),
    b(
        "d4",
        Kind::Lattice,
        &[p("scale", ParamType::Num, N(1.0), Positive)],
    ),
    b(
        "grid",
        Kind::Lattice,
        &[
            p("spacing", ParamType::Vec4, Required, Positive),
            p("limit", ParamType::Vec4, V([f64::INFINITY; 4]), NonNeg),
        ],
    ),
    b(
        "diffuse",
        Kind::Material,
        &[
            p("albedo", ParamType::Color, Grey(0.8), Unit),
            p("emission", ParamType::Color, Grey(0.0), NonNeg),
        ],
    ),
    b(
        "light",
        Kind::Material,
        &[
            p("color", ParamType::Color, Grey(1.0), NonNeg),
            p("intensity", ParamType::Num, N(1.0), NonNeg),
        ],
    ),
    b(
        "mirror",
        Kind::Material,
        &[p("tint", ParamType::Color, Grey(1.0), Unit)],
    ),
    b(
        "glass",
        Kind::Material,
        &[
            p("ior", ParamType::Num, N(1.5), Positive),
            p("tint", ParamType::Color, Grey(1.0), Unit),
            p("extinction", ParamType::Num, N(0.0), NonNeg),
            p("albedo", ParamType::Color, Grey(1.0), Unit),
        ],
    ),
    b(
        "shiny",
        Kind::Material,
        &[
            p("roughness", ParamType::Num, N(0.3), Unit),
            p("color", ParamType::Color, Grey(0.9), Unit),
        ],
    ),
    b(
        "fog",
        Kind::Material,
        &[
            p("extinction", ParamType::Num, N(0.1), NonNeg),
            p("albedo", ParamType::Color, Grey(0.9), Unit),
            p("anisotropy", ParamType::Num, N(0.0), OpenSigned),
        ],
    ),
    b(
        "vec4",
        Kind::Constructor,
        &[
            p("x", ParamType::Num, Required, Any),
            p("y", ParamType::Num, Required, Any),
            p("z", ParamType::Num, Required, Any),
            p("w", ParamType::Num, Required, Any),
        ],
    ),
    b(
        "len",
        Kind::Constructor,
        &[p("list", ParamType::List, Required, Any)],
    ),
    b(
        "rgb",
        Kind::Constructor,
        &[
            p("r", ParamType::Num, Required, Any),
            p("g", ParamType::Num, Required, Any),
            p("b", ParamType::Num, Required, Any),
        ],
    ),
    b(
        "hsv",
        Kind::Constructor,
        &[
            p("h", ParamType::Angle, Required, Any),
            p("s", ParamType::Num, N(1.0), Unit),
            p("v", ParamType::Num, N(1.0), NonNeg),
        ],
    ),
    b(
        "d4_cell",
        Kind::Constructor,
        &[
            p("p", ParamType::Vec4, Required, Any),
            p("scale", ParamType::Num, N(1.0), Positive),
        ],
    ),
    b(
        "lattice_cell",
        Kind::Constructor,
        &[
            p("p", ParamType::Vec4, Required, Any),
            p("lattice", ParamType::Lattice, Required, Any),
        ],
    ),
];

const fn b(name: &'static str, kind: Kind, params: &'static [ParamSpec]) -> Builtin {
    Builtin { name, kind, params }
}

/// Builtins that bind their own arguments (see [`TABLE`]).
pub const SPECIAL: [&str; 3] = ["union", "intersect", "rotate"];

/// Named constants of the language.
pub const CONSTANTS: [&str; 11] = [
    "pi", "tau", "inf", "air", "t", "xy", "xz", "xw", "yz", "yw", "zw",
];

/// The builtin called `name` in the table, if any.
pub fn find(name: &str) -> Option<&'static Builtin> {
    TABLE.iter().find(|b| b.name == name)
}

/// A parameter's default in the language's own notation, as the reference tables show it.
pub fn show_default(spec: &ParamSpec) -> Option<String> {
    let n = |x: f64| {
        if x.is_infinite() {
            "inf".to_string()
        } else {
            x.to_string()
        }
    };
    match spec.default {
        ParamDefault::Required => None,
        ParamDefault::Num(x) => Some(n(x)),
        ParamDefault::Vec4(v) => Some(format!("[{}]", v.map(n).join(", "))),
        ParamDefault::Grey(x) => Some(format!("rgb({})", n(x))),
    }
}

/// One parameter as the reference tables write it: `` `name: type = default` ``.
pub fn show_param(spec: &ParamSpec) -> String {
    match show_default(spec) {
        Some(d) => format!("`{}: {} = {d}`", spec.name, spec.ty.ty()),
        None => format!("`{}: {}`", spec.name, spec.ty.ty()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The reference tables of shapes and materials in `docs/language.md` list each builtin's
    /// parameters exactly as the table defines them.
    #[test]
    fn docs_tables_match_the_table() {
        let docs = include_str!("../../docs/language.md");
        for b in TABLE
            .iter()
            .filter(|b| matches!(b.kind, Kind::Shape | Kind::Material))
        {
            let params: Vec<String> = b.params.iter().map(show_param).collect();
            let row = format!("| `{}` | {} |", b.name, params.join(", "));
            assert!(
                docs.lines().any(|l| l.starts_with(&row)),
                "docs/language.md has no row starting `{row}`"
            );
        }
    }

    #[test]
    fn every_material_kind_has_its_table_entry() {
        use crate::scene::MaterialKind;
        for k in MaterialKind::ALL {
            let n = k.params().len();
            let entry = find(k.name()).map(|b| b.params.len());
            assert_eq!(entry.unwrap_or(0), n, "{}", k.name());
            if k != MaterialKind::Air {
                assert!(entry.is_some_and(|e| e > 0), "{} is missing", k.name());
            }
        }
    }
}
