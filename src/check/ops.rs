//! Operators and maths on values: one set of type rules, applied to constants directly and
//! recorded as field nodes when an operand is known only per point or per frame.

use super::context::{Checker, article};
use super::suggest::did_you_mean;
use super::value::*;
use crate::diagnostic::Diagnostic;
use crate::math::kernel::{bin, un};
use crate::math::{Bin, Un};
use crate::source::Span;
use crate::syntax::ast::{BinOp, Ident, UnOp};
use std::rc::Rc;

/// A numeric value as lanes: num/angle 1, color 3, vec4 4.
fn lanes(v: &Value) -> Option<Vec<f64>> {
    match v {
        Value::Num(x) | Value::Angle(x) => Some(vec![*x]),
        Value::Vec4(a) => Some(a.to_vec()),
        Value::Color(c) => Some(c.to_vec()),
        _ => None,
    }
}

fn from_lanes(ty: &Type, xs: &[f64]) -> Value {
    match ty {
        Type::Angle => Value::Angle(xs[0]),
        Type::Vec4 => Value::Vec4([xs[0], xs[1], xs[2], xs[3]]),
        Type::Color => Value::Color([xs[0], xs[1], xs[2]]),
        _ => Value::Num(xs[0]),
    }
}

/// The type of `a op b`, or why there is none.
pub fn binary_type(op: BinOp, a: &Type, b: &Type) -> Result<Type, &'static str> {
    use Type::*;
    match op {
        BinOp::Add | BinOp::Sub => match (a, b) {
            (x, y) if x == y && x.is_numeric() => Ok(x.clone()),
            (Angle, Num) | (Num, Angle) => Err("angle-num"),
            _ => Err(""),
        },
        BinOp::Mul => match (a, b) {
            (Num, x) | (x, Num) if x.is_numeric() => Ok(x.clone()),
            (Vec4, Vec4) => Ok(Vec4),
            (Color, Color) => Ok(Color),
            _ => Err(""),
        },
        BinOp::Div => match (a, b) {
            (x, Num) if x.is_numeric() => Ok(x.clone()),
            (Vec4, Vec4) => Ok(Vec4),
            (Color, Color) => Ok(Color),
            (Angle, Angle) => Ok(Num),
            (Num, Angle) => Err("angle-num"),
            _ => Err(""),
        },
        BinOp::Mod => match (a, b) {
            (Num, Num) => Ok(Num),
            (Angle, Angle) => Ok(Angle),
            (Vec4, Num) | (Vec4, Vec4) => Ok(Vec4),
            (Angle, Num) | (Num, Angle) => Err("angle-num"),
            _ => Err(""),
        },
        BinOp::Lt | BinOp::Le | BinOp::Gt | BinOp::Ge => match (a, b) {
            (Num, Num) | (Angle, Angle) => Ok(Bool),
            (Angle, Num) | (Num, Angle) => Err("angle-num"),
            _ => Err(""),
        },
        BinOp::Eq | BinOp::Ne => match (a, b) {
            (x, y) if x == y && matches!(x, Num | Angle | Bool | Vec4 | Color | Str | Plane) => {
                Ok(Bool)
            }
            (Angle, Num) | (Num, Angle) => Err("angle-num"),
            _ => Err(""),
        },
        BinOp::And | BinOp::Or => match (a, b) {
            (Bool, Bool) => Ok(Bool),
            _ => Err(""),
        },
        BinOp::Range => match (a, b) {
            (Num, Num) => Ok(List(Box::new(Num))),
            _ => Err(""),
        },
        BinOp::Dims => match (a, b) {
            (Num, Num) => Ok(Size),
            _ => Err(""),
        },
    }
}

/// The field operator of a binary operator whose operands vary per point or frame (ranges and
/// image sizes are constants, so they never get here; they become `+`).
fn field_bin(op: BinOp) -> FieldBin {
    match op {
        BinOp::Sub => FieldBin::Sub,
        BinOp::Mul => FieldBin::Mul,
        BinOp::Div => FieldBin::Div,
        BinOp::Mod => FieldBin::Mod,
        BinOp::Lt => FieldBin::Lt,
        BinOp::Le => FieldBin::Le,
        BinOp::Gt => FieldBin::Gt,
        BinOp::Ge => FieldBin::Ge,
        BinOp::Eq => FieldBin::Eq,
        BinOp::Ne => FieldBin::Ne,
        BinOp::And => FieldBin::And,
        BinOp::Or => FieldBin::Or,
        BinOp::Add | BinOp::Range | BinOp::Dims => FieldBin::Add,
    }
}

/// `a op b` on constants whose types passed `binary_type`.
pub fn const_binary(op: BinOp, a: &Value, b: &Value, ty: &Type) -> Value {
    match (op, a, b) {
        (BinOp::And, Value::Bool(x), Value::Bool(y)) => return Value::Bool(*x && *y),
        (BinOp::Or, Value::Bool(x), Value::Bool(y)) => return Value::Bool(*x || *y),
        (BinOp::Eq, x, y) => return Value::Bool(x == y),
        (BinOp::Ne, x, y) => return Value::Bool(x != y),
        _ => {}
    }
    let (Some(x), Some(y)) = (lanes(a), lanes(b)) else {
        return Value::Error;
    };
    let n = x.len().max(y.len());
    let get = |v: &[f64], i: usize| if v.len() == 1 { v[0] } else { v[i] };
    let kernel = match op {
        BinOp::Add => Bin::Add,
        BinOp::Sub => Bin::Sub,
        BinOp::Mul => Bin::Mul,
        BinOp::Div => Bin::Div,
        _ => Bin::Mod,
    };
    let f = |p: f64, q: f64| bin(kernel, p, q);
    match op {
        BinOp::Lt => Value::Bool(x[0] < y[0]),
        BinOp::Le => Value::Bool(x[0] <= y[0]),
        BinOp::Gt => Value::Bool(x[0] > y[0]),
        BinOp::Ge => Value::Bool(x[0] >= y[0]),
        _ => from_lanes(
            ty,
            &(0..n)
                .map(|i| f(get(&x, i), get(&y, i)))
                .collect::<Vec<_>>(),
        ),
    }
}

pub fn binary(
    ck: &mut Checker,
    op: BinOp,
    a: Value,
    b: Value,
    aspan: Span,
    bspan: Span,
    span: Span,
) -> Value {
    if a.is_error() || b.is_error() {
        return Value::Error;
    }
    let (ta, tb) = (a.ty(), b.ty());
    let ty = match binary_type(op, &ta, &tb) {
        Ok(t) => t,
        Err(why) => {
            let d = Diagnostic::error(
                if why == "angle-num" { "E0210" } else { "E0207" },
                format!(
                    "`{}` does not work on {} and {}",
                    op.symbol(),
                    article(&ta),
                    article(&tb)
                ),
            )
            .label(aspan, format!("this is {}", article(&ta)))
            .label(bspan, format!("this is {}", article(&tb)));
            let d = match (why, op) {
                ("angle-num", _) => d
                    .note("angles and plain numbers are kept apart so that units cannot be mixed up")
                    .help("give the number a unit (`30deg`, `0.5rad`, `0.25turn`), or divide the angle by one (`a / 1deg`)"),
                (_, BinOp::Add | BinOp::Sub) if ta != tb => d.help("both sides of `+` and `-` must have the same type"),
                (_, BinOp::Dims) => d.help("an image size is two whole numbers: `512 x 384`"),
                (_, BinOp::And | BinOp::Or) => d.help("`&&` and `||` combine booleans, such as comparisons"),
                _ => d,
            };
            return ck.error(d);
        }
    };
    let deps = ck.deps(&a) | ck.deps(&b);
    if deps != 0 {
        if matches!(op, BinOp::Range | BinOp::Dims) {
            let what = if op == BinOp::Range {
                "a range's ends"
            } else {
                "an image size"
            };
            ck.require_const(
                if ck.deps(&a) != 0 { &a } else { &b },
                if ck.deps(&a) != 0 { aspan } else { bspan },
                what,
            );
            return Value::Error;
        }
        if matches!(op, BinOp::Eq | BinOp::Ne)
            && !matches!(ta, Type::Num | Type::Angle | Type::Bool)
        {
            return ck.error(
                Diagnostic::error(
                    "E0208",
                    format!("cannot compare {} values that vary per point or frame", ta),
                )
                .label(span, "this comparison must be known before rendering")
                .help("compare their components instead, as in `c.x == 0`"),
            );
        }
        let (la, lb) = (ck.lift(&a), ck.lift(&b));
        return ck.field(FieldOp::Binary(field_bin(op), la, lb), ty);
    }
    match (op, &a, &b) {
        (BinOp::Range, Value::Num(lo), Value::Num(hi)) => range(ck, *lo, *hi, aspan, bspan, span),
        (BinOp::Dims, Value::Num(w), Value::Num(h)) => Value::Size(*w, *h),
        (BinOp::Div | BinOp::Mod, _, Value::Num(z)) if *z == 0.0 => ck.error(
            Diagnostic::error("E0302", "division by zero")
                .label(bspan, "this is zero")
                .label(aspan, "so this cannot be divided by it"),
        ),
        _ => {
            let out = const_binary(op, &a, &b, &ty);
            overflow(ck, &[&a, &b], out, span)
        }
    }
}

/// The largest number, as the messages about overflow give it.
const LARGEST: &str = "about 1.8e308";

/// `out`, or E0301 where it is infinite but nothing it came from (`inputs`) is: the constant
/// arithmetic ran past the range of a number, as `1e308 * 10` or `exp(1000)` do, and an
/// infinite intensity or position would only turn into NaN pixels. `inf` itself, written or
/// carried through (`2 * inf`, a grid's unlimited axis), stays.
fn overflow(ck: &mut Checker, inputs: &[&Value], out: Value, span: Span) -> Value {
    let infinite = |v: &Value| lanes(v).is_some_and(|l| l.iter().any(|x| x.is_infinite()));
    if infinite(&out) && !inputs.iter().any(|v| infinite(v)) {
        return ck.error(
            Diagnostic::error("E0301", "number too large")
                .label(
                    span,
                    format!("this comes to infinity, past the largest number ({LARGEST})"),
                )
                .help("use smaller values, or write `inf` where an unlimited value is meant"),
        );
    }
    out
}

fn range(ck: &mut Checker, lo: f64, hi: f64, aspan: Span, bspan: Span, span: Span) -> Value {
    for (v, s) in [(lo, aspan), (hi, bspan)] {
        if v.fract() != 0.0 {
            return ck.error(
                Diagnostic::error("E0209", "a range needs whole numbers")
                    .label(s, format!("{} is not a whole number", Num(v)))
                    .help("use `floor(...)` or `round(...)` to make it whole"),
            );
        }
    }
    let len = (hi - lo).max(0.0);
    if len > super::context::MAX_LIST as f64 {
        return ck.error(
            Diagnostic::error("E0402", "range too large")
                .label(span, format!("this range has {} items", Num(len)))
                .note(format!(
                    "a range or list may have at most {} items",
                    super::context::MAX_LIST
                ))
                .help("use `tile` to repeat a shape instead of listing copies"),
        );
    }
    Value::List(Rc::new(
        (0..len as usize)
            .map(|i| Value::Num(lo + i as f64))
            .collect(),
    ))
}

pub fn unary(ck: &mut Checker, op: UnOp, v: Value, span: Span) -> Value {
    let ty = v.ty();
    let ok = match op {
        UnOp::Neg => Type::is_numeric(&ty),
        UnOp::Not => ty == Type::Bool,
    };
    if v.is_error() {
        return Value::Error;
    }
    if !ok {
        let sym = if op == UnOp::Neg { "-" } else { "!" };
        return ck.error(
            Diagnostic::error(
                "E0207",
                format!("`{sym}` does not work on {}", article(&ty)),
            )
            .label(span, format!("this is {}", article(&ty))),
        );
    }
    if ck.deps(&v) != 0 {
        let a = ck.lift(&v);
        let op = match op {
            UnOp::Neg => Un::Neg,
            UnOp::Not => Un::Not,
        };
        return ck.field(FieldOp::Unary(op, a), ty);
    }
    match (op, &v) {
        (UnOp::Not, Value::Bool(b)) => Value::Bool(!b),
        _ => from_lanes(
            &ty,
            &lanes(&v)
                .unwrap_or_default()
                .iter()
                .map(|x| -x)
                .collect::<Vec<_>>(),
        ),
    }
}

pub fn make_vec4(ck: &mut Checker, vals: &[Value]) -> Value {
    if vals.iter().all(|v| ck.deps(v) == 0) {
        let xs: Vec<f64> = vals
            .iter()
            .map(|v| if let Value::Num(x) = v { *x } else { 0.0 })
            .collect();
        return Value::Vec4([xs[0], xs[1], xs[2], xs[3]]);
    }
    let ids = [
        ck.lift(&vals[0]),
        ck.lift(&vals[1]),
        ck.lift(&vals[2]),
        ck.lift(&vals[3]),
    ];
    ck.field(FieldOp::MakeVec4(ids), Type::Vec4)
}

pub fn make_color(ck: &mut Checker, vals: &[Value]) -> Value {
    if vals.iter().all(|v| ck.deps(v) == 0) {
        let xs: Vec<f64> = vals
            .iter()
            .map(|v| if let Value::Num(x) = v { *x } else { 0.0 })
            .collect();
        return Value::Color([xs[0], xs[1], xs[2]]);
    }
    let ids = [ck.lift(&vals[0]), ck.lift(&vals[1]), ck.lift(&vals[2])];
    ck.field(FieldOp::MakeColor(ids), Type::Color)
}

/// Implicit conversions: a number where a colour is wanted is a grey.
pub fn coerce(ck: &mut Checker, v: Value, want: &Type) -> Value {
    if *want == Type::Color && v.ty() == Type::Num {
        return make_color(ck, &[v.clone(), v.clone(), v]);
    }
    v
}

pub fn component(ck: &mut Checker, v: Value, field: &Ident, span: Span) -> Value {
    let names: &[&str] = match v.ty() {
        Type::Vec4 => &["x", "y", "z", "w"],
        Type::Color => &["r", "g", "b"],
        Type::Size => &["width", "height"],
        _ => &[],
    };
    if v.is_error() {
        return Value::Error;
    }
    let Some(i) = names.iter().position(|n| *n == field.name) else {
        let ty = v.ty();
        let hint = did_you_mean(&field.name, names.iter().copied()).or_else(|| {
            (!names.is_empty()).then(|| format!("{} has the components {}", ty, names.join(", ")))
        });
        return ck.error(
            Diagnostic::error(
                "E0101",
                format!("{} has no component `{}`", article(&ty), field.name),
            )
            .label(field.span, "unknown component")
            .label(span, format!("this is {}", article(&ty)))
            .maybe_help(hint),
        );
    };
    match &v {
        Value::Vec4(a) => Value::Num(a[i]),
        Value::Color(c) => Value::Num(c[i]),
        Value::Size(w, h) => Value::Num(if i == 0 { *w } else { *h }),
        Value::Field(id, _) => ck.field(FieldOp::Component(*id, i as u8), Type::Num),
        _ => Value::Error,
    }
}

fn liftable(t: &Type) -> bool {
    matches!(
        t,
        Type::Num
            | Type::Angle
            | Type::Bool
            | Type::Vec4
            | Type::Color
            | Type::Material
            | Type::Unknown
    )
}

pub fn index(ck: &mut Checker, list: Value, idx: Value, lspan: Span, ispan: Span) -> Value {
    if list.is_error() || idx.is_error() {
        return Value::Error;
    }
    let items: Vec<Value> = match &list {
        Value::List(xs) => xs.to_vec(),
        Value::Vec4(a) => a.iter().map(|x| Value::Num(*x)).collect(),
        Value::Field(id, Type::Vec4) => {
            let id = *id;
            (0..4)
                .map(|i| ck.field(FieldOp::Component(id, i), Type::Num))
                .collect()
        }
        other => {
            let ty = other.ty();
            return ck.error(
                Diagnostic::error("E0207", format!("cannot index {}", article(&ty)))
                    .label(lspan, format!("this is {}, not a list", article(&ty))),
            );
        }
    };
    if !ck.expect(&idx, &Type::Num, ispan, "an index") {
        return Value::Error;
    }
    match idx {
        Value::Num(i) => {
            if i.fract() != 0.0 || i < 0.0 || i >= items.len() as f64 {
                let why = if i.fract() != 0.0 {
                    "is not a whole number".to_string()
                } else {
                    format!("is outside 0..{}", items.len())
                };
                let title = if i.fract() != 0.0 {
                    "index is not a whole number"
                } else {
                    "index out of range"
                };
                return ck.error(
                    Diagnostic::error("E0209", title)
                        .label(ispan, format!("the index {} {why}", Num(i)))
                        .label(
                            lspan,
                            format!(
                                "this list has {} item{}",
                                items.len(),
                                super::context::plural(items.len())
                            ),
                        )
                        .help("wrap the index with `mod`, as in `xs[i mod len(xs)]`"),
                );
            }
            items[i as usize].clone()
        }
        Value::Field(iid, _) => {
            let ty = items.first().map_or(Type::Unknown, Value::ty);
            if items.is_empty() || !liftable(&ty) {
                return ck.error(
                    Diagnostic::error("E0208", format!("cannot choose {} per point or frame", article(&ty)))
                        .label(ispan, "this index is known only while rendering")
                        .note("lists of numbers, angles, vectors, colours, booleans and materials can be indexed this way"),
                );
            }
            let ids: Vec<FieldId> = items.iter().map(|v| ck.lift(v)).collect();
            ck.field(FieldOp::Index(ids, iid), ty)
        }
        _ => Value::Error,
    }
}

pub fn select(
    ck: &mut Checker,
    cond: FieldId,
    a: Value,
    b: Value,
    aspan: Span,
    bspan: Span,
) -> Value {
    if a.is_error() || b.is_error() {
        return Value::Error;
    }
    let (ta, tb) = (a.ty(), b.ty());
    let (a, b) = (coerce(ck, a, &tb), coerce(ck, b, &ta));
    let (ta, tb) = (a.ty(), b.ty());
    if !ta.accepts(&tb) {
        return ck.error(
            Diagnostic::error("E0201", "the branches of `if` have different types")
                .label(aspan, format!("this is {}", article(&ta)))
                .label(bspan, format!("this is {}", article(&tb)))
                .help("both branches must give the same type of value"),
        );
    }
    if !liftable(&ta) {
        let deps = ck.fields.get(cond).deps;
        return ck.error(
            Diagnostic::error("E0208", format!("cannot choose between {} values per point or frame", ta))
                .label(aspan, format!("the condition depends on {}", describe_deps(deps)))
                .note("numbers, angles, vectors, colours, booleans and materials can be chosen this way")
                .help("decide with a condition known at compile time, or move the choice into a material map"),
        );
    }
    let (la, lb) = (ck.lift(&a), ck.lift(&b));
    ck.field(FieldOp::Select(cond, la, lb), ta)
}

/// Evaluate a maths builtin on constants of the right types, with the kernels the renderer uses.
fn apply(f: MathFn, args: &[Value], ty: &Type) -> Value {
    let l: Vec<Vec<f64>> = args.iter().map(|a| lanes(a).unwrap_or_default()).collect();
    let map1 = |op: Un| from_lanes(ty, &l[0].iter().map(|x| un(op, *x)).collect::<Vec<_>>());
    let zip = |f: &dyn Fn(f64, f64) -> f64| {
        let out: Vec<f64> = l[0].iter().zip(&l[1]).map(|(a, b)| f(*a, *b)).collect();
        from_lanes(ty, &out)
    };
    let length = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    match f {
        MathFn::Un(op) => map1(op),
        MathFn::Bin(op) => zip(&|a, b| bin(op, a, b)),
        MathFn::Clamp => {
            let out: Vec<f64> = (0..l[0].len())
                .map(|i| bin(Bin::Min, bin(Bin::Max, l[0][i], l[1][i]), l[2][i]))
                .collect();
            from_lanes(ty, &out)
        }
        MathFn::Mix => {
            let k = l[2][0];
            zip(&|a, b| a + (b - a) * k)
        }
        MathFn::Length => Value::Num(length(&l[0])),
        MathFn::Dot => Value::Num(l[0].iter().zip(&l[1]).map(|(a, b)| a * b).sum()),
        MathFn::Normalize => {
            let n = length(&l[0]);
            from_lanes(ty, &l[0].iter().map(|x| x / n).collect::<Vec<_>>())
        }
    }
}

/// Call a maths builtin: check argument types, then compute or record a field node.
pub fn math(ck: &mut Checker, f: MathFn, name: &str, args: Vec<ArgVal>, span: Span) -> Value {
    let Some(slots) = ck.bind(name, f.params(), args, span) else {
        return Value::Error;
    };
    let mut vals = Vec::new();
    let first_ty = slots
        .first()
        .and_then(|s| s.as_ref())
        .map_or(Type::Num, |a| a.value.ty());
    let (want, ret) = f.signature(&first_ty);
    for ((slot, p), w) in slots.into_iter().zip(f.params()).zip(&want) {
        let Some(a) = slot else {
            return ck.missing(name, p, span);
        };
        // Scalars broadcast in clamp's bounds.
        let v = if *w != Type::Num && a.value.ty() == Type::Num && matches!(f, MathFn::Clamp) {
            broadcast(ck, a.value, w)
        } else {
            a.value
        };
        if !ck.expect(&v, w, a.span, &format!("argument `{p}` of `{name}`")) {
            return Value::Error;
        }
        vals.push(v);
    }
    if vals.iter().any(|v| ck.deps(v) != 0) {
        let ids = vals.iter().map(|v| ck.lift(v)).collect();
        return ck.field(FieldOp::Math(f, ids), ret);
    }
    let out = apply(f, &vals, &ret);
    let out = overflow(ck, &vals.iter().collect::<Vec<_>>(), out, span);
    if lanes(&out).is_some_and(|l| l.iter().any(|x| x.is_nan())) {
        return ck.error(
            Diagnostic::error("E0301", format!("`{name}` is undefined here"))
                .label(span, "this gives no number (NaN)")
                .help(match f {
                    MathFn::Un(Un::Sqrt | Un::Ln) => "the argument must not be negative",
                    MathFn::Un(Un::Asin | Un::Acos) => "the argument must lie in [-1, 1]",
                    _ => "check the arguments",
                }),
        );
    }
    out
}

fn broadcast(ck: &mut Checker, v: Value, want: &Type) -> Value {
    match want {
        Type::Vec4 => make_vec4(ck, &[v.clone(), v.clone(), v.clone(), v]),
        Type::Color => make_color(ck, &[v.clone(), v.clone(), v]),
        Type::Angle => match v {
            Value::Num(x) => Value::Num(x),
            other => other,
        },
        _ => v,
    }
}
