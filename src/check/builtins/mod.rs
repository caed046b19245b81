//! The builtin constants and functions: maths, shapes, operations, lattices, materials and
//! constructors. Parameters, defaults and ranges come from the scene's builtin table; this
//! module binds arguments to them and dispatches by kind (`shapes`, `materials`, `values`),
//! which report what is wrong and build typed scene values.

mod materials;
mod shapes;
mod values;

pub use shapes::make_shape;

use super::context::Checker;
use super::ops;
use super::value::*;
use crate::diagnostic::Diagnostic;
use crate::scene::builtins::{self as table, Kind, ParamDefault, ParamSpec, SPECIAL};
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

/// A builtin that takes a shape first and gives a shape: what `|>` is for.
pub fn is_shape_operation(name: &str) -> bool {
    SPECIAL.contains(&name) || table::find(name).is_some_and(|b| b.kind == Kind::Operation)
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

pub(super) fn default_value(spec: &ParamSpec) -> Option<Value> {
    match spec.default {
        ParamDefault::Required => None,
        ParamDefault::Num(x) => Some(Value::Num(x)),
        ParamDefault::Vec4(v) => Some(Value::Vec4(v)),
        ParamDefault::Grey(x) => Some(Value::Color([x; 3])),
    }
}

/// Bound arguments of one builtin call, with typed accessors that report errors.
pub(super) struct Args<'c, 'a> {
    pub(super) ck: &'c mut Checker<'a>,
    pub(super) fname: &'static str,
    pub(super) names: Vec<&'static str>,
    pub(super) slots: Vec<Option<ArgVal>>,
    pub(super) span: Span,
    pub(super) ok: bool,
}

impl Args<'_, '_> {
    /// The argument at `i`, converted to `want`, or `default`.
    pub(super) fn get_or(&mut self, i: usize, want: Type, default: Option<Value>) -> (Value, Span) {
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
    pub(super) fn get(&mut self, i: usize, spec: &ParamSpec) -> (Value, Span) {
        self.get_or(i, spec.ty.ty(), default_value(spec))
    }

    /// The argument at `i`, whose constant components must satisfy the entry's range.
    pub(super) fn ranged(&mut self, i: usize, spec: &ParamSpec) -> Value {
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
    pub(super) fn constant(&mut self, i: usize, spec: &ParamSpec) -> Value {
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
    pub(super) fn num(&mut self, i: usize, spec: &ParamSpec) -> Param<f64> {
        let v = self.ranged(i, spec);
        v.num().unwrap_or(Param::Const(f64::NAN))
    }

    /// A shape argument.
    pub(super) fn shape(&mut self, i: usize) -> Option<Rc<Shape>> {
        match self.get_or(i, Type::Shape, None).0 {
            Value::Shape(s) => Some(s),
            _ => {
                self.ok = false;
                None
            }
        }
    }
}

/// `translate(0, 1, 0, 0)`: four numbers where one vec4 is wanted, which would otherwise read
/// as one wrong type and three extra arguments.
fn spread_vec4(
    name: &str,
    params: &[ParamSpec],
    args: &[ArgVal],
    span: Span,
) -> Option<Diagnostic> {
    let positional = args.iter().take_while(|a| a.name.is_none()).count();
    if positional <= params.len() {
        return None;
    }
    let i = params.iter().position(|p| p.ty == table::ParamType::Vec4)?;
    let four = args.get(i..i + 4)?;
    let nums: Vec<f64> = four
        .iter()
        .map(|a| match a.value {
            Value::Num(x) => Some(x),
            _ => None,
        })
        .collect::<Option<_>>()?;
    if positional != i + 4 {
        return None;
    }
    let shown: Vec<String> = nums.iter().map(|x| Num(*x).to_string()).collect();
    let whole = four[0].span.to(four[3].span);
    Some(
        Diagnostic::error(
            "E0201",
            format!(
                "mismatched types: argument `{}` of `{name}` must be a vec4",
                params[i].name
            ),
        )
        .label(four[0].span, "expected a vec4, found a num")
        .label(whole, "these four numbers are one vec4")
        .label(span, format!("`{name}` takes {}", builtin_params(params)))
        .help(format!("write `{name}([{}])`", shown.join(", "))),
    )
}

fn builtin_params(params: &[ParamSpec]) -> String {
    params
        .iter()
        .map(|p| format!("`{}`", p.name))
        .collect::<Vec<_>>()
        .join(", ")
}

pub fn call(ck: &mut Checker, name: &'static str, args: Vec<ArgVal>, span: Span) -> Value {
    if let Some(f) = MathFn::from_name(name)
        && !(name == "round" && args.first().is_some_and(|a| a.value.ty() == Type::Shape))
    {
        return ops::math(ck, f, name, args, span);
    }
    match name {
        "union" | "intersect" => return shapes::combine(ck, name, args, span),
        "rotate" => return shapes::rotate(ck, args, span),
        _ => {}
    }
    let Some(builtin) = table::find(name) else {
        return Value::Error;
    };
    let names = builtin.names();
    if let Some(d) = spread_vec4(name, builtin.params, &args, span) {
        return ck.error(d);
    }
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
    let out = match builtin.kind {
        Kind::Shape | Kind::Operation => shapes::build(&mut a, name, builtin.params),
        Kind::Material => materials::build(&mut a, name, builtin.params),
        Kind::Lattice | Kind::Constructor => values::build(&mut a, name, builtin.params),
    };
    if a.ok { out } else { Value::Error }
}
