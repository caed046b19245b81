//! Values of the constant stage. Shapes, materials, lattices and rotations are the typed
//! scene's own types; what depends on `p`, `n` or `t` is a field expression of the scene.

use crate::source::{FileId, Span};
use crate::syntax::ast::{ExprId, FnDef, Ident};
use std::cell::Cell;
use std::rc::Rc;

pub use crate::math::Plane;
pub use crate::scene::field::{DEP_N, DEP_P, describe_deps};
pub use crate::scene::{
    Const, FieldBin, FieldId, FieldOp, Fields, Input, Lattice, Material, MaterialKind, MathFn, Num,
    Param, Rotation, Shape, ShapeKind, Slot, Type,
};

/// A callable value.
#[derive(Debug)]
pub enum Function {
    Builtin(&'static str),
    /// A top-level `fn`.
    User {
        file: FileId,
        def: Rc<FnDef>,
    },
    Lambda {
        file: FileId,
        params: Vec<Ident>,
        body: ExprId,
        env: Env,
    },
}

#[derive(Clone, Debug)]
pub enum Value {
    Num(f64),
    Angle(f64),
    Bool(bool),
    Vec4([f64; 4]),
    Color([f64; 3]),
    Str(Rc<str>),
    Size(f64, f64),
    Plane(Plane),
    /// Plane rotations applied in order; angles are constants or fields of `t`.
    Rotation(Rc<Rotation>),
    Lattice(Rc<Lattice>),
    Material(Rc<Material>),
    Shape(Rc<Shape>),
    List(Rc<Vec<Value>>),
    Function(Rc<Function>),
    /// A value known only per point or per frame.
    Field(FieldId, Type),
    /// The result of an expression that already produced an error.
    Error,
}

impl PartialEq for Value {
    fn eq(&self, other: &Self) -> bool {
        use Value::*;
        match (self, other) {
            (Num(a), Num(b)) | (Angle(a), Angle(b)) => a == b,
            (Bool(a), Bool(b)) => a == b,
            (Vec4(a), Vec4(b)) => a == b,
            (Color(a), Color(b)) => a == b,
            (Str(a), Str(b)) => a == b,
            (Size(a, b), Size(c, d)) => a == c && b == d,
            (Plane(a), Plane(b)) => a == b,
            (Rotation(a), Rotation(b)) => a == b,
            (Lattice(a), Lattice(b)) => a == b,
            (Material(a), Material(b)) => a == b,
            (Shape(a), Shape(b)) => a == b,
            (List(a), List(b)) => a == b,
            (Function(a), Function(b)) => Rc::ptr_eq(a, b),
            (Field(a, _), Field(b, _)) => a == b,
            _ => false,
        }
    }
}

impl Value {
    pub fn ty(&self) -> Type {
        match self {
            Value::Num(_) => Type::Num,
            Value::Angle(_) => Type::Angle,
            Value::Bool(_) => Type::Bool,
            Value::Vec4(_) => Type::Vec4,
            Value::Color(_) => Type::Color,
            Value::Str(_) => Type::Str,
            Value::Size(..) => Type::Size,
            Value::Plane(_) => Type::Plane,
            Value::Rotation(_) => Type::Rotation,
            Value::Lattice(_) => Type::Lattice,
            Value::Material(_) => Type::Material,
            Value::Shape(_) => Type::Shape,
            Value::List(xs) => Type::List(Box::new(xs.first().map_or(Type::Unknown, Value::ty))),
            Value::Function(_) => Type::Function,
            Value::Field(_, t) => t.clone(),
            Value::Error => Type::Unknown,
        }
    }

    pub fn is_error(&self) -> bool {
        matches!(self, Value::Error)
    }
}

impl Value {
    /// A constant as the language writes it, for hovers; `None` for shapes, materials,
    /// functions, fields and the like.
    pub fn describe(&self) -> Option<String> {
        let list = |xs: &[f64]| xs.iter().map(|x| Num(*x).to_string()).collect::<Vec<_>>();
        Some(match self {
            Value::Num(x) => Num(*x).to_string(),
            Value::Angle(x) => format!("{}deg", Num(crate::scene::print::round9(x.to_degrees()))),
            Value::Bool(b) => b.to_string(),
            Value::Vec4(v) => format!("[{}]", list(v).join(", ")),
            Value::Color(c) => format!("rgb({})", list(c).join(", ")),
            Value::Str(s) => format!("{s:?}"),
            Value::Size(w, h) => format!("{} x {}", Num(*w), Num(*h)),
            Value::Plane(p) => Plane::ALL.iter().find(|(_, q)| q == p)?.0.to_string(),
            _ => return None,
        })
    }

    /// The value as a field constant, if it is one of the types a field can hold.
    pub fn to_const(&self) -> Option<Const> {
        Some(match self {
            Value::Num(x) => Const::Num(*x),
            Value::Angle(x) => Const::Angle(*x),
            Value::Bool(b) => Const::Bool(*b),
            Value::Vec4(v) => Const::Vec4(*v),
            Value::Color(c) => Const::Color(*c),
            Value::Material(m) => Const::Material(m.clone()),
            _ => return None,
        })
    }

    /// A number or angle parameter.
    pub fn num(&self) -> Option<Param<f64>> {
        match self {
            Value::Num(x) | Value::Angle(x) => Some(Param::Const(*x)),
            Value::Field(id, _) => Some(Param::Field(*id)),
            _ => None,
        }
    }

    /// A vector parameter (a field may still be a number, broadcast when lowered).
    pub fn vector(&self) -> Option<Param<[f64; 4]>> {
        match self {
            Value::Vec4(v) => Some(Param::Const(*v)),
            Value::Field(id, _) => Some(Param::Field(*id)),
            _ => None,
        }
    }

    /// A colour parameter.
    pub fn color(&self) -> Option<Param<[f64; 3]>> {
        match self {
            Value::Color(c) => Some(Param::Const(*c)),
            Value::Field(id, _) => Some(Param::Field(*id)),
            _ => None,
        }
    }
}

/// Which of `p`, `n`, `t` a value depends on.
pub fn deps(fields: &Fields, v: &Value) -> u8 {
    match v {
        Value::Field(id, _) => fields.get(*id).deps,
        Value::Material(m) => m.deps(fields),
        Value::Shape(s) => s.deps(fields),
        Value::List(xs) => xs.iter().fold(0, |d, x| d | deps(fields, x)),
        Value::Rotation(r) => r.iter().fold(0, |d, (_, a)| d | a.deps(fields)),
        _ => 0,
    }
}

/// A local binding; scopes form a persistent linked list so closures capture cheaply.
#[derive(Debug)]
pub struct Scope {
    pub(super) name: String,
    pub(super) value: Value,
    pub(super) span: Span,
    pub(super) used: Cell<bool>,
    pub(super) parent: Env,
}

#[derive(Clone, Debug, Default)]
pub struct Env(Option<Rc<Scope>>);

impl Env {
    pub fn bind(&self, name: &str, value: Value, span: Span) -> (Env, Rc<Scope>) {
        let scope = Rc::new(Scope {
            name: name.to_string(),
            value,
            span,
            used: Cell::new(false),
            parent: self.clone(),
        });
        (Env(Some(scope.clone())), scope)
    }

    pub(super) fn lookup(&self, name: &str) -> Option<&Scope> {
        let mut cur = self.0.as_deref();
        while let Some(s) = cur {
            if s.name == name {
                return Some(s);
            }
            cur = s.parent.0.as_deref();
        }
        None
    }

    pub(super) fn names(&self) -> Vec<&str> {
        let mut out = vec![];
        let mut cur = self.0.as_deref();
        while let Some(s) = cur {
            out.push(s.name.as_str());
            cur = s.parent.0.as_deref();
        }
        out
    }
}

/// An evaluated argument.
#[derive(Clone, Debug)]
pub struct ArgVal {
    pub name: Option<Ident>,
    pub value: Value,
    pub span: Span,
}
