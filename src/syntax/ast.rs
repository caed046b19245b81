//! The syntax tree. Expressions live in an arena (`Ast::exprs`) addressed by `ExprId`, with their
//! spans in a parallel table, so the tree has no recursive `Drop` and children always precede
//! their parents (a single forward pass computes depths).

use crate::source::Span;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ExprId(pub u32);

#[derive(Clone, Debug, PartialEq)]
pub struct Ident {
    pub name: String,
    pub span: Span,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unit {
    Deg,
    Rad,
    Turn,
}

impl Unit {
    pub fn name(self) -> &'static str {
        match self {
            Unit::Deg => "deg",
            Unit::Rad => "rad",
            Unit::Turn => "turn",
        }
    }
    /// Radians per unit.
    pub fn radians(self) -> f64 {
        match self {
            Unit::Deg => std::f64::consts::PI / 180.0,
            Unit::Rad => 1.0,
            Unit::Turn => std::f64::consts::TAU,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UnOp {
    Neg,
    Not,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BinOp {
    Add,
    Sub,
    Mul,
    Div,
    Mod,
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
    And,
    Or,
    /// `a..b`: the integers a, a+1, ..., b-1.
    Range,
    /// `512 x 384`: an image size.
    Dims,
}

impl BinOp {
    pub fn symbol(self) -> &'static str {
        match self {
            BinOp::Add => "+",
            BinOp::Sub => "-",
            BinOp::Mul => "*",
            BinOp::Div => "/",
            BinOp::Mod => "mod",
            BinOp::Eq => "==",
            BinOp::Ne => "!=",
            BinOp::Lt => "<",
            BinOp::Le => "<=",
            BinOp::Gt => ">",
            BinOp::Ge => ">=",
            BinOp::And => "&&",
            BinOp::Or => "||",
            BinOp::Range => "..",
            BinOp::Dims => "x",
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Arg {
    pub name: Option<Ident>,
    pub value: ExprId,
}

#[derive(Clone, Debug, PartialEq)]
pub struct LetStmt {
    pub name: Ident,
    pub ty: Option<TypeExpr>,
    pub value: ExprId,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Expr {
    /// Stands in for an expression that failed to parse (already reported).
    Error,
    Number {
        value: f64,
        unit: Option<Unit>,
    },
    Bool(bool),
    Str(String),
    /// `#rrggbb`
    Hex([u8; 3]),
    Name(Ident),
    List(Vec<ExprId>),
    Unary(UnOp, ExprId),
    Binary(BinOp, ExprId, ExprId),
    /// `a |> f(b)` means `f(a, b)`.
    Pipe(ExprId, ExprId),
    Call {
        callee: ExprId,
        args: Vec<Arg>,
    },
    Field(ExprId, Ident),
    Index(ExprId, ExprId),
    If {
        cond: ExprId,
        then: ExprId,
        otherwise: ExprId,
    },
    For {
        var: Ident,
        iter: ExprId,
        body: ExprId,
    },
    Lambda {
        params: Vec<Ident>,
        body: ExprId,
    },
    /// `sdf |p| body`: a custom distance function.
    Sdf {
        param: Ident,
        body: ExprId,
    },
    Block {
        lets: Vec<LetStmt>,
        result: ExprId,
    },
}

impl Expr {
    /// Children in evaluation order.
    pub fn children(&self) -> Vec<ExprId> {
        match self {
            Expr::Error
            | Expr::Number { .. }
            | Expr::Bool(_)
            | Expr::Str(_)
            | Expr::Hex(_)
            | Expr::Name(_) => vec![],
            Expr::List(xs) => xs.clone(),
            Expr::Unary(_, a) | Expr::Field(a, _) => vec![*a],
            Expr::Binary(_, a, b) | Expr::Pipe(a, b) | Expr::Index(a, b) => vec![*a, *b],
            Expr::Call { callee, args } => std::iter::once(*callee)
                .chain(args.iter().map(|a| a.value))
                .collect(),
            Expr::If {
                cond,
                then,
                otherwise,
            } => vec![*cond, *then, *otherwise],
            Expr::For { iter, body, .. } => vec![*iter, *body],
            Expr::Lambda { body, .. } | Expr::Sdf { body, .. } => vec![*body],
            Expr::Block { lets, result } => lets.iter().map(|l| l.value).chain([*result]).collect(),
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum TypeKind {
    Named(String),
    List(Box<TypeExpr>),
}

#[derive(Clone, Debug, PartialEq)]
pub struct TypeExpr {
    pub kind: TypeKind,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Param {
    pub name: Ident,
    pub ty: TypeExpr,
    pub default: Option<ExprId>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct FnDef {
    pub name: Ident,
    pub params: Vec<Param>,
    pub ret: Option<TypeExpr>,
    pub body: ExprId,
}

/// `name = value` inside `object`, `render` and `camera` blocks.
#[derive(Clone, Debug, PartialEq)]
pub struct Setting {
    pub name: Ident,
    pub value: ExprId,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlockKind {
    Render,
    Camera,
}

impl BlockKind {
    pub fn keyword(self) -> &'static str {
        match self {
            BlockKind::Render => "render",
            BlockKind::Camera => "camera",
        }
    }

    /// The settings the block takes (the checker reads them; hints and completion offer them).
    pub fn settings(self) -> &'static [&'static str] {
        match self {
            BlockKind::Render => &[
                "size",
                "frames",
                "spp",
                "bounces",
                "epsilon",
                "max_steps",
                "seed",
                "denoise",
                "quality",
                "fps",
                "exposure",
                "threads",
            ],
            BlockKind::Camera => &["from", "to", "look", "fov"],
        }
    }
}

/// The settings of an `object`.
pub const OBJECT_SETTINGS: [&str; 2] = ["shape", "material"];

#[derive(Clone, Debug, PartialEq)]
pub enum ItemKind {
    /// An item that failed to parse (already reported).
    Error,
    Import {
        path: String,
        path_span: Span,
    },
    Let(LetStmt),
    Fn(FnDef),
    Object {
        name: Ident,
        settings: Vec<Setting>,
    },
    Block {
        kind: BlockKind,
        settings: Vec<Setting>,
    },
    Sky(ExprId),
    Medium(ExprId),
}

#[derive(Clone, Debug, PartialEq)]
pub struct Item {
    pub kind: ItemKind,
    pub span: Span,
}

/// One parsed file.
#[derive(Clone, Debug, Default)]
pub struct Ast {
    pub exprs: Vec<Expr>,
    pub spans: Vec<Span>,
    pub items: Vec<Item>,
}

impl Ast {
    pub fn alloc(&mut self, expr: Expr, span: Span) -> ExprId {
        self.exprs.push(expr);
        self.spans.push(span);
        ExprId(self.exprs.len() as u32 - 1)
    }

    pub fn expr(&self, id: ExprId) -> &Expr {
        &self.exprs[id.0 as usize]
    }

    pub fn span(&self, id: ExprId) -> Span {
        self.spans[id.0 as usize]
    }

    /// The deepest expression and its depth, in one forward pass (children precede parents).
    pub fn deepest(&self) -> Option<(ExprId, usize)> {
        let mut depth = vec![0usize; self.exprs.len()];
        let mut best: Option<(ExprId, usize)> = None;
        for (i, e) in self.exprs.iter().enumerate() {
            let d = 1 + e
                .children()
                .iter()
                .map(|c| depth[c.0 as usize])
                .max()
                .unwrap_or(0);
            depth[i] = d;
            if best.is_none_or(|(_, bd)| d > bd) {
                best = Some((ExprId(i as u32), d));
            }
        }
        best
    }
}
