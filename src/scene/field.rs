//! Field expressions: the values of a scene known only per point (`p`, `n`) or per frame (`t`),
//! as an arena of typed nodes that lowering turns into IR. Children precede their parents.

use super::lattice::Lattice;
use super::material::Material;
use super::types::Type;
use crate::math::{Bin, Un};
use std::rc::Rc;

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

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FieldId(pub u32);

/// A constant inside a field expression.
#[derive(Clone, Debug, PartialEq)]
pub enum Const {
    Num(f64),
    Angle(f64),
    Bool(bool),
    Vec4([f64; 4]),
    Color([f64; 3]),
    Material(Rc<Material>),
}

/// A parameter that is a constant or a field (of `t` for shapes; of `p`, `n`, `t` for
/// materials and custom distances).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Param<T> {
    Const(T),
    Field(FieldId),
}

impl<T: Copy> Param<T> {
    /// The value, when it is a constant.
    pub fn constant(&self) -> Option<T> {
        match self {
            Param::Const(x) => Some(*x),
            Param::Field(_) => None,
        }
    }
}

impl<T> Param<T> {
    pub fn deps(&self, fields: &Fields) -> u8 {
        match self {
            Param::Const(_) => 0,
            Param::Field(id) => fields.get(*id).deps,
        }
    }
}

/// Maths builtins shared by constant evaluation and field expressions: most are one scalar
/// operation of `math` applied per component; the rest combine several.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MathFn {
    Un(Un),
    Bin(Bin),
    Clamp,
    Mix,
    Length,
    Dot,
    Normalize,
}

impl MathFn {
    /// Every maths builtin with its name in the language.
    pub const ALL: [(&'static str, MathFn); 24] = {
        use MathFn::{Bin as B, Un as U};
        [
            ("sin", U(Un::Sin)),
            ("cos", U(Un::Cos)),
            ("tan", U(Un::Tan)),
            ("asin", U(Un::Asin)),
            ("acos", U(Un::Acos)),
            ("atan", U(Un::Atan)),
            ("atan2", B(Bin::Atan2)),
            ("sqrt", U(Un::Sqrt)),
            ("abs", U(Un::Abs)),
            ("floor", U(Un::Floor)),
            ("ceil", U(Un::Ceil)),
            ("round", U(Un::Round)),
            ("fract", U(Un::Fract)),
            ("sign", U(Un::Sign)),
            ("exp", U(Un::Exp)),
            ("log", U(Un::Ln)),
            ("pow", B(Bin::Pow)),
            ("min", B(Bin::Min)),
            ("max", B(Bin::Max)),
            ("clamp", MathFn::Clamp),
            ("mix", MathFn::Mix),
            ("length", MathFn::Length),
            ("dot", MathFn::Dot),
            ("normalize", MathFn::Normalize),
        ]
    };

    pub fn from_name(name: &str) -> Option<MathFn> {
        MathFn::ALL
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, f)| *f)
    }

    pub fn name(self) -> &'static str {
        MathFn::ALL
            .iter()
            .find(|(_, f)| *f == self)
            .map_or("?", |(n, _)| n)
    }

    pub fn params(self) -> &'static [&'static str] {
        use MathFn as M;
        match self {
            M::Un(Un::Sin | Un::Cos | Un::Tan) => &["angle"],
            M::Bin(Bin::Atan2) => &["y", "x"],
            M::Bin(Bin::Pow) => &["x", "y"],
            M::Bin(_) | M::Dot => &["a", "b"],
            M::Clamp => &["x", "lo", "hi"],
            M::Mix => &["a", "b", "k"],
            M::Length | M::Normalize => &["v"],
            M::Un(_) => &["x"],
        }
    }

    /// Expected types of the arguments given the first one's type, and the result type.
    pub fn signature(self, first: &Type) -> (Vec<Type>, Type) {
        use MathFn as M;
        use Type as T;
        let x = if first.is_numeric() {
            first.clone()
        } else {
            T::Num
        };
        match self {
            M::Un(Un::Sin | Un::Cos | Un::Tan) => (vec![T::Angle], T::Num),
            M::Un(Un::Asin | Un::Acos | Un::Atan) => (vec![T::Num], T::Angle),
            M::Bin(Bin::Atan2) => (vec![T::Num, T::Num], T::Angle),
            // Documented as `num` (or `vec4`, componentwise): an angle or colour is an error
            // here, at the call, not where the result is used.
            M::Un(
                Un::Sqrt
                | Un::Exp
                | Un::Ln
                | Un::Abs
                | Un::Floor
                | Un::Ceil
                | Un::Round
                | Un::Fract
                | Un::Sign,
            ) => {
                let x = if *first == T::Vec4 { T::Vec4 } else { T::Num };
                (vec![x.clone()], x)
            }
            M::Bin(Bin::Pow) => (vec![T::Num, T::Num], T::Num),
            M::Un(_) => (vec![x.clone()], x),
            M::Bin(_) => (vec![x.clone(), x.clone()], x),
            M::Clamp => (vec![x.clone(), x.clone(), x.clone()], x),
            M::Mix => (vec![x.clone(), x.clone(), T::Num], x),
            M::Length => (vec![T::Vec4], T::Num),
            M::Dot => (vec![T::Vec4, T::Vec4], T::Num),
            M::Normalize => (vec![T::Vec4], T::Vec4),
        }
    }
}

/// A binary operator of a field expression: componentwise arithmetic and comparisons, and
/// `==` / `!=` over whole values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FieldBin {
    Add,
    Sub,
    Mul,
    Div,
    Mod,
    Lt,
    Le,
    Gt,
    Ge,
    Eq,
    Ne,
    And,
    Or,
}

impl FieldBin {
    /// The operator as the language writes it.
    pub fn symbol(self) -> &'static str {
        use FieldBin::*;
        match self {
            Add => "+",
            Sub => "-",
            Mul => "*",
            Div => "/",
            Mod => "mod",
            Lt => "<",
            Le => "<=",
            Gt => ">",
            Ge => ">=",
            Eq => "==",
            Ne => "!=",
            And => "&&",
            Or => "||",
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum FieldOp {
    Input(Input),
    Const(Const),
    /// `-x` (`Un::Neg`) or `!x` (`Un::Not`), per component.
    Unary(Un, FieldId),
    Binary(FieldBin, FieldId, FieldId),
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

impl FieldOp {
    /// The operands, in order.
    pub fn children(&self) -> Vec<FieldId> {
        match self {
            FieldOp::Input(_) | FieldOp::Const(_) => vec![],
            FieldOp::Unary(_, a) | FieldOp::Component(a, _) | FieldOp::Cell(_, a) => vec![*a],
            FieldOp::Binary(_, a, b) => vec![*a, *b],
            FieldOp::Math(_, xs) => xs.clone(),
            FieldOp::MakeVec4(xs) => xs.to_vec(),
            FieldOp::MakeColor(xs) => xs.to_vec(),
            FieldOp::Select(c, a, b) => vec![*c, *a, *b],
            FieldOp::Index(xs, i) => xs.iter().chain([i]).copied().collect(),
        }
    }
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

    pub fn push(&mut self, op: FieldOp, ty: Type) -> FieldId {
        let deps = match &op {
            FieldOp::Input(Input::P) => DEP_P,
            FieldOp::Input(Input::N) => DEP_N,
            FieldOp::Input(Input::T) => DEP_T,
            FieldOp::Const(Const::Material(m)) => m.deps(self),
            op => op.children().iter().fold(0, |d, x| d | self.get(*x).deps),
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
