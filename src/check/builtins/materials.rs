//! Material builtins: every parameter is ranged and typed by the builtin table.

use super::Args;
use crate::check::value::*;
use crate::scene::builtins::{ParamSpec, ParamType};
use std::rc::Rc;

/// A material call: every parameter ranged and typed by the table.
pub(super) fn build(a: &mut Args, name: &str, specs: &'static [ParamSpec]) -> Value {
    let Some(kind) = MaterialKind::ALL.into_iter().find(|k| k.name() == name) else {
        return Value::Error;
    };
    let params: Vec<Slot<Param<f64>, Param<[f64; 3]>>> = (0..specs.len())
        .map(|i| {
            let v = a.ranged(i, &specs[i]);
            if specs[i].ty == ParamType::Color {
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
