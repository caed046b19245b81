//! Value builtins: `vec4`, `len`, `rgb`, `hsv`, the lattices `d4` and `grid`, and the cell
//! functions `d4_cell` and `lattice_cell`.

use super::Args;
use crate::check::context::Checker;
use crate::check::ops;
use crate::check::value::*;
use crate::diagnostic::Diagnostic;
use crate::scene::builtins::ParamSpec;
use std::rc::Rc;

pub(super) fn build(a: &mut Args, name: &'static str, specs: &'static [ParamSpec]) -> Value {
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
            // `rgb(x)` is a grey: the missing channels default to the first. Two channels
            // would silently repeat the first as blue, so it takes one or three.
            if a.slots[1].is_some() != a.slots[2].is_some() {
                let given: Vec<&str> = (0..3)
                    .filter(|i| a.slots[*i].is_some())
                    .map(|i| a.names[i])
                    .collect();
                a.ck.error(
                    Diagnostic::error("E0202", "`rgb` takes one number or three")
                        .label(a.span, format!("this gives only {}", given.join(" and ")))
                        .note("`rgb(x)` is a grey; `rgb(r, g, b)` gives each channel")
                        .help("add the missing channel, as in `rgb(0.95, 0.65, 0.2)`, or give one number for a grey"),
                );
                return Value::Error;
            }
            let r = a.get(0, &specs[0]).0;
            let g = a.get_or(1, Type::Num, Some(r.clone())).0;
            let b = a.get_or(2, Type::Num, Some(r.clone())).0;
            if !a.ok {
                return Value::Error;
            }
            ops::make_color(a.ck, &[r, g, b])
        }
        "hsv" => {
            let [h, s, v] = [0, 1, 2].map(|i| a.ranged(i, &specs[i]));
            if !a.ok {
                return Value::Error;
            }
            match (h, s, v) {
                (Value::Angle(h), Value::Num(s), Value::Num(v)) => {
                    Value::Color(crate::math::color::hsv(h, s, v))
                }
                (h, s, v) if [&h, &s, &v].iter().all(|x| !x.is_error()) => {
                    hsv_field(a.ck, &h, &s, &v)
                }
                _ => Value::Error,
            }
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
        _ => Value::Error,
    }
}

/// `hsv` of values known only per point or frame, as a colour field:
/// `v * mix(1, clamp(|fract(h / turn + k) * 6 - 3| - 1, 0, 1), s)` with `k` = 1, 2/3, 1/3 for
/// red, green and blue, which is `math::color::hsv`. The saturation is clamped to 0..1 and the
/// value to at least 0, the ranges a constant must be in.
fn hsv_field(ck: &mut Checker, h: &Value, s: &Value, v: &Value) -> Value {
    use crate::math::{Bin, Un};
    use crate::scene::field::{FieldBin as B, FieldOp, MathFn};
    let num = |ck: &mut Checker, x: f64| ck.lift(&Value::Num(x));
    let bin = |ck: &mut Checker, op: B, x, y| match ck.field(FieldOp::Binary(op, x, y), Type::Num) {
        Value::Field(id, _) => id,
        _ => unreachable!("a field"),
    };
    let math =
        |ck: &mut Checker, f: MathFn, xs: Vec<_>| match ck.field(FieldOp::Math(f, xs), Type::Num) {
            Value::Field(id, _) => id,
            _ => unreachable!("a field"),
        };
    let (h, s, v) = (ck.lift(h), ck.lift(s), ck.lift(v));
    let (zero, one) = (num(ck, 0.0), num(ck, 1.0));
    let s = math(ck, MathFn::Clamp, vec![s, zero, one]);
    let v = math(ck, MathFn::Bin(Bin::Max), vec![v, zero]);
    let per_turn = num(ck, 1.0 / std::f64::consts::TAU);
    let turns = bin(ck, B::Mul, h, per_turn);
    let (six, three) = (num(ck, 6.0), num(ck, 3.0));
    let channels = [1.0, 2.0 / 3.0, 1.0 / 3.0].map(|k| {
        let k = num(ck, k);
        let x = bin(ck, B::Add, turns, k);
        let x = math(ck, MathFn::Un(Un::Fract), vec![x]);
        let x = bin(ck, B::Mul, x, six);
        let x = bin(ck, B::Sub, x, three);
        let x = math(ck, MathFn::Un(Un::Abs), vec![x]);
        let x = bin(ck, B::Sub, x, one);
        let x = math(ck, MathFn::Clamp, vec![x, zero, one]);
        let x = math(ck, MathFn::Mix, vec![one, x, s]);
        Value::Field(bin(ck, B::Mul, v, x), Type::Num)
    });
    crate::check::ops::make_color(ck, &channels)
}
