//! Values of the constant stage, and the symbolic field expressions (of `p`, `n`, `t`) that are
//! left for the renderer.

use super::types::Type;
use crate::source::{FileId, Span};
use crate::syntax::ast::{BinOp, ExprId, FnDef, Ident, UnOp};
use std::fmt;
use std::rc::Rc;

pub use crate::math::Plane;

/// A lattice for tiling. Its parameters are compile-time constants.
#[derive(Clone, Debug, PartialEq)]
pub enum Lattice {
    /// Integer points with an even coordinate sum, times `scale`.
    D4 { scale: f64 },
    /// Points `spacing * k` with `|k_i| <= limit_i`.
    Grid { spacing: [f64; 4], limit: [f64; 4] },
}

impl Lattice {
    /// Radius of the largest ball centred on a lattice point that stays inside its cell.
    pub fn inradius(&self) -> f64 {
        match self {
            Lattice::D4 { scale } => scale * std::f64::consts::FRAC_1_SQRT_2,
            Lattice::Grid { spacing, .. } => {
                spacing.iter().cloned().fold(f64::INFINITY, f64::min) / 2.0
            }
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MaterialKind {
    Diffuse,
    Light,
    Mirror,
    Glass,
    Shiny,
    Fog,
    Air,
}

impl MaterialKind {
    pub fn name(self) -> &'static str {
        match self {
            MaterialKind::Diffuse => "diffuse",
            MaterialKind::Light => "light",
            MaterialKind::Mirror => "mirror",
            MaterialKind::Glass => "glass",
            MaterialKind::Shiny => "shiny",
            MaterialKind::Fog => "fog",
            MaterialKind::Air => "air",
        }
    }
}

/// A material with its parameters in declaration order (each a constant or a field).
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub kind: MaterialKind,
    pub params: Vec<(&'static str, Value)>,
}

impl Material {
    pub fn param(&self, name: &str) -> Option<&Value> {
        self.params.iter().find(|(n, _)| *n == name).map(|(_, v)| v)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShapeKind {
    Hypersphere,
    Halfspace,
    Hyperbox,
    Spherinder,
    Cubinder,
    Duocylinder,
    Cell5,
    Cell16,
    Cell24,
    /// `sdf |p| ...`: the distance is the field in param `distance`.
    Custom,
    Union,
    Intersect,
    Subtract,
    Onion,
    Round,
    Translate,
    Rotate,
    Scale,
    Symmetry,
    Tile,
}

impl ShapeKind {
    pub fn name(self) -> &'static str {
        match self {
            ShapeKind::Hypersphere => "hypersphere",
            ShapeKind::Halfspace => "halfspace",
            ShapeKind::Hyperbox => "hyperbox",
            ShapeKind::Spherinder => "spherinder",
            ShapeKind::Cubinder => "cubinder",
            ShapeKind::Duocylinder => "duocylinder",
            ShapeKind::Cell5 => "cell5",
            ShapeKind::Cell16 => "cell16",
            ShapeKind::Cell24 => "cell24",
            ShapeKind::Custom => "sdf",
            ShapeKind::Union => "union",
            ShapeKind::Intersect => "intersect",
            ShapeKind::Subtract => "subtract",
            ShapeKind::Onion => "onion",
            ShapeKind::Round => "round",
            ShapeKind::Translate => "translate",
            ShapeKind::Rotate => "rotate",
            ShapeKind::Scale => "scale",
            ShapeKind::Symmetry => "symmetry",
            ShapeKind::Tile => "tile",
        }
    }
}

/// A shape: a primitive or an operation over child shapes, with parameters that are constants
/// or fields of the frame variable `t`.
#[derive(Clone, Debug, PartialEq)]
pub struct Shape {
    pub kind: ShapeKind,
    pub params: Vec<(&'static str, Value)>,
    pub children: Vec<Rc<Shape>>,
    /// Nesting depth, bounded so that every recursive pass over shapes stays shallow.
    pub depth: u32,
}

impl Shape {
    pub fn param(&self, name: &str) -> Option<&Value> {
        self.params.iter().find(|(n, _)| *n == name).map(|(_, v)| v)
    }
}

/// A callable value.
#[derive(Debug)]
pub enum Function {
    Builtin(&'static str),
    /// A top-level `fn`, by its index in the checker's global table.
    User {
        global: usize,
        file: FileId,
        def: Rc<FnDef>,
    },
    Lambda {
        file: FileId,
        params: Vec<Ident>,
        body: ExprId,
        env: super::eval::Env,
        span: Span,
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
    Rotation(Rc<Vec<(Plane, Value)>>),
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

/// Inputs a field may depend on, as bit flags.
pub const DEP_P: u8 = 1;
pub const DEP_N: u8 = 2;
pub const DEP_T: u8 = 4;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Input {
    /// The point being shaded or measured.
    P,
    /// The surface normal at a hit point.
    N,
    /// The frame variable, 0 on the first frame and 1 on the last.
    T,
}

/// Maths builtins shared by constant evaluation and field expressions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MathFn {
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Atan2,
    Sqrt,
    Abs,
    Floor,
    Ceil,
    Round,
    Fract,
    Sign,
    Exp,
    Log,
    Pow,
    Min,
    Max,
    Clamp,
    Mix,
    Length,
    Dot,
    Normalize,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FieldId(pub u32);

#[derive(Clone, Debug, PartialEq)]
pub enum FieldOp {
    Input(Input),
    Const(Value),
    Unary(UnOp, FieldId),
    Binary(BinOp, FieldId, FieldId),
    Math(MathFn, Vec<FieldId>),
    Component(FieldId, u8),
    MakeVec4([FieldId; 4]),
    MakeColor([FieldId; 3]),
    Select(FieldId, FieldId, FieldId),
    /// Element `index` of a list (the index is clamped to the list at run time).
    Index(Vec<FieldId>, FieldId),
    /// The lattice cell containing a point.
    Cell(Lattice, FieldId),
}

#[derive(Clone, Debug, PartialEq)]
pub struct FieldNode {
    pub op: FieldOp,
    pub ty: Type,
    pub deps: u8,
}

/// The arena of field expressions; children precede parents.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Fields {
    pub nodes: Vec<FieldNode>,
}

impl Fields {
    pub fn get(&self, id: FieldId) -> &FieldNode {
        &self.nodes[id.0 as usize]
    }

    /// Which of p, n, t a value depends on.
    pub fn deps(&self, v: &Value) -> u8 {
        match v {
            Value::Field(id, _) => self.get(*id).deps,
            Value::Material(m) => m.params.iter().fold(0, |d, (_, v)| d | self.deps(v)),
            Value::Shape(s) => self.shape_deps(s),
            Value::List(xs) => xs.iter().fold(0, |d, x| d | self.deps(x)),
            Value::Rotation(r) => r.iter().fold(0, |d, (_, a)| d | self.deps(a)),
            _ => 0,
        }
    }

    /// A custom distance's own `p` is bound inside it, so it does not count.
    fn shape_deps(&self, s: &Shape) -> u8 {
        let own = s.params.iter().fold(0, |d, (_, v)| d | self.deps(v));
        let own = if s.kind == ShapeKind::Custom {
            own & !DEP_P
        } else {
            own
        };
        s.children.iter().fold(own, |d, c| d | self.shape_deps(c))
    }

    pub fn push(&mut self, op: FieldOp, ty: Type) -> FieldId {
        let deps = match &op {
            FieldOp::Input(Input::P) => DEP_P,
            FieldOp::Input(Input::N) => DEP_N,
            FieldOp::Input(Input::T) => DEP_T,
            FieldOp::Const(v) => self.deps(v),
            FieldOp::Unary(_, a) | FieldOp::Component(a, _) | FieldOp::Cell(_, a) => {
                self.get(*a).deps
            }
            FieldOp::Binary(_, a, b) => self.get(*a).deps | self.get(*b).deps,
            FieldOp::Math(_, xs) | FieldOp::Index(xs, _) => {
                let extra = if let FieldOp::Index(_, i) = &op {
                    self.get(*i).deps
                } else {
                    0
                };
                xs.iter().fold(extra, |d, x| d | self.get(*x).deps)
            }
            FieldOp::MakeVec4(xs) => xs.iter().fold(0, |d, x| d | self.get(*x).deps),
            FieldOp::MakeColor(xs) => xs.iter().fold(0, |d, x| d | self.get(*x).deps),
            FieldOp::Select(c, a, b) => self.get(*c).deps | self.get(*a).deps | self.get(*b).deps,
        };
        self.nodes.push(FieldNode { op, ty, deps });
        FieldId(self.nodes.len() as u32 - 1)
    }
}

pub fn describe_deps(deps: u8) -> String {
    let mut names = vec![];
    if deps & DEP_P != 0 {
        names.push("the point `p`");
    }
    if deps & DEP_N != 0 {
        names.push("the normal `n`");
    }
    if deps & DEP_T != 0 {
        names.push("the frame variable `t`");
    }
    names.join(" and ")
}

/// Numbers print in their shortest exact form so snapshots stay stable.
pub struct Num(pub f64);

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = if self.0 == 0.0 { 0.0 } else { self.0 };
        if v.is_infinite() {
            return f.write_str(if v > 0.0 { "inf" } else { "-inf" });
        }
        write!(f, "{v}")
    }
}
