//! The scalar operations every stage computes with: the IR's nodes, the VM's instructions and
//! the checker's constant evaluation all name them here.

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Un {
    Neg,
    Abs,
    Sqrt,
    Floor,
    Ceil,
    Round,
    Fract,
    Sign,
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Exp,
    Ln,
    Not,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Bin {
    Add,
    Sub,
    Mul,
    Div,
    /// Floored modulo (the sign of the divisor).
    Mod,
    Min,
    Max,
    Pow,
    Atan2,
    Lt,
    Le,
    Eq,
    Ne,
    And,
    Or,
}

impl Un {
    pub fn name(self) -> &'static str {
        use Un::*;
        match self {
            Neg => "neg",
            Abs => "abs",
            Sqrt => "sqrt",
            Floor => "floor",
            Ceil => "ceil",
            Round => "round",
            Fract => "fract",
            Sign => "sign",
            Sin => "sin",
            Cos => "cos",
            Tan => "tan",
            Asin => "asin",
            Acos => "acos",
            Atan => "atan",
            Exp => "exp",
            Ln => "ln",
            Not => "not",
        }
    }
}

impl Bin {
    pub fn name(self) -> &'static str {
        use Bin::*;
        match self {
            Add => "add",
            Sub => "sub",
            Mul => "mul",
            Div => "div",
            Mod => "mod",
            Min => "min",
            Max => "max",
            Pow => "pow",
            Atan2 => "atan2",
            Lt => "lt",
            Le => "le",
            Eq => "eq",
            Ne => "ne",
            And => "and",
            Or => "or",
        }
    }

    pub fn commutes(self) -> bool {
        use Bin::*;
        matches!(self, Add | Mul | Min | Max | Eq | Ne | And | Or)
    }
}
