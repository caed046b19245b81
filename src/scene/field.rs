//! Field expressions: the values of a scene known only per point (`p`, `n`) or per frame (`t`),
//! as an arena of typed nodes that lowering turns into IR. Children precede their parents.

use super::lattice::Lattice;
use super::material::Material;
use super::types::Type;
use crate::math::{Bin, Un};
use std::rc::Rc;

/// Inputs a field may depend on, as bit flags.
pub const DEP_P: u8 = 1;
/// Depends on the surface normal `n`.
pub const DEP_N: u8 = 2;
/// Depends on the frame variable `t`.
pub const DEP_T: u8 = 4;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
/// A variable a field expression reads.
pub enum Input {
    /// The point being shaded or measured.
    P,
    /// The surface normal at a hit point.
    N,
    /// The frame variable, 0 on the first frame and 1 on the last.
    T,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
/// Index of a node in [`Fields`].
pub struct FieldId(pub u32);

/// A constant inside a field expression.
#[derive(Clone, Debug, PartialEq)]
pub enum Const {
    /// A number.
    Num(f64),
    /// An angle, in radians.
    Angle(f64),
    /// `true` or `false`.
    Bool(bool),
    /// A 4D vector.
    Vec4([f64; 4]),
    /// A linear RGB colour.
    Color([f64; 3]),
    /// A constant material (a material map's branches).
    Material(Rc<Material>),
}

/// A parameter that is a constant or a field (of `t` for shapes; of `p`, `n`, `t` for
/// materials and custom distances).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Param<T> {
    /// Known when the scene is checked.
    Const(T),
    /// Computed per point or per frame by the field expression with this id.
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
    /// Which of `p`, `n`, `t` the parameter depends on ([`DEP_P`], [`DEP_N`], [`DEP_T`] bits; 0 for
    /// a constant).
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
    /// A one-argument function, per component (`sin`, `sqrt`, `floor`, ...).
    Un(Un),
    /// A two-argument function, per component (`atan2`, `pow`, `min`, `max`).
    Bin(Bin),
    /// `clamp(x, lo, hi)`.
    Clamp,
    /// `mix(a, b, k)`: `a + (b - a) * k`.
    Mix,
    /// `length(v)`: the Euclidean length of a `vec4`.
    Length,
    /// `dot(a, b)` of two `vec4`s.
    Dot,
    /// `normalize(v)`: `v` scaled to unit length.
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

    /// The builtin called `name` in the language, if there is one.
    pub fn from_name(name: &str) -> Option<MathFn> {
        MathFn::ALL
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, f)| *f)
    }

    /// The builtin's name in the language.
    pub fn name(self) -> &'static str {
        MathFn::ALL
            .iter()
            .find(|(_, f)| *f == self)
            .map_or("?", |(n, _)| n)
    }

    /// The builtin's parameter names, in order, for named arguments and messages.
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
    /// `+`
    Add,
    /// `-`
    Sub,
    /// `*`
    Mul,
    /// `/`
    Div,
    /// `mod`, the remainder.
    Mod,
    /// `<`
    Lt,
    /// `<=`
    Le,
    /// `>`
    Gt,
    /// `>=`
    Ge,
    /// `==`
    Eq,
    /// `!=`
    Ne,
    /// `&&`
    And,
    /// `\|\|`
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
/// One node of a field expression; operands are earlier nodes.
pub enum FieldOp {
    /// A variable: `p`, `n` or `t`.
    Input(Input),
    /// A constant.
    Const(Const),
    /// `-x` (`Un::Neg`) or `!x` (`Un::Not`), per component.
    Unary(Un, FieldId),
    /// An operator applied to two operands.
    Binary(FieldBin, FieldId, FieldId),
    /// A maths builtin applied to its arguments.
    Math(MathFn, Vec<FieldId>),
    /// One component (0 to 3: x, y, z, w, or r, g, b) of a `vec4` or colour.
    Component(FieldId, u8),
    /// A `vec4` from four numbers.
    MakeVec4([FieldId; 4]),
    /// A colour from three numbers.
    MakeColor([FieldId; 3]),
    /// `if c { a } else { b }`: condition, then value, else value.
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
/// One node of the field arena: its operation, its type and what it depends on.
pub struct FieldNode {
    /// What the node computes.
    pub op: FieldOp,
    /// The node's type.
    pub ty: Type,
    /// Which inputs it depends on, transitively ([`DEP_P`], [`DEP_N`], [`DEP_T`] bits).
    pub deps: u8,
}

/// The arena of field expressions; children precede parents.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Fields {
    /// The nodes, indexed by [`FieldId`].
    pub nodes: Vec<FieldNode>,
}

impl Fields {
    /// The node with id `id`; panics if there is no such node.
    pub fn get(&self, id: FieldId) -> &FieldNode {
        &self.nodes[id.0 as usize]
    }

    /// Append a node after its operands, working out its dependencies, and return its id.
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

/// The inputs in `deps` in words, for messages: "the point `p` and the frame variable `t`".
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
