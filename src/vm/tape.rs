//! Bytecode tapes: the live nodes of a graph for some roots, in order, with registers from a
//! single forward pass (a register is reused as soon as its last reader has run) and constants
//! folded into the instructions as immediates wherever an operation takes one.

use crate::ir::{Bin, Graph, Id, Node, Un, Var};

pub type Reg = u16;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Instr {
    Const {
        d: Reg,
        k: f32,
    },
    Un {
        op: Un,
        d: Reg,
        a: Reg,
    },
    Bin {
        op: Bin,
        d: Reg,
        a: Reg,
        b: Reg,
    },
    /// `a op k`
    BinImm {
        op: Bin,
        d: Reg,
        a: Reg,
        k: f32,
    },
    /// `k op b`, for operations that do not commute.
    ImmBin {
        op: Bin,
        d: Reg,
        k: f32,
        b: Reg,
    },
    Select {
        d: Reg,
        c: Reg,
        a: Reg,
        b: Reg,
    },
    /// `|v + r[0..4]| - r[4]`
    Length {
        d: Reg,
        v: [Reg; 4],
        r: [f32; 5],
    },
    Affine {
        d: Reg,
        v: [Reg; 4],
        r: [f32; 5],
    },
    /// The hyperbox distance at `v + r[0..4]` with half-extents `r[4..8]`, minus `r[8]`.
    Box {
        d: Reg,
        v: [Reg; 4],
        r: [f32; 9],
    },
    SMin {
        d: Reg,
        a: Reg,
        b: Reg,
        k: Reg,
    },
    SMax {
        d: Reg,
        a: Reg,
        b: Reg,
        k: Reg,
    },
    D4 {
        d: [Reg; 8],
        v: [Reg; 4],
    },
    Rep {
        d: [Reg; 2],
        a: Reg,
        l: f32,
    },
    MinId {
        d: [Reg; 2],
        a: Reg,
        b: Reg,
        c: Reg,
        id: f32,
    },
}

impl Instr {
    /// Registers read.
    pub fn reads(&self) -> Vec<Reg> {
        match *self {
            Instr::Const { .. } => vec![],
            Instr::Un { a, .. } | Instr::BinImm { a, .. } | Instr::Rep { a, .. } => vec![a],
            Instr::ImmBin { b, .. } => vec![b],
            Instr::Bin { a, b, .. } => vec![a, b],
            Instr::Select { c, a, b, .. } => vec![c, a, b],
            Instr::SMin { a, b, k, .. } | Instr::SMax { a, b, k, .. } => vec![a, b, k],
            Instr::MinId { a, b, c, .. } => vec![a, b, c],
            Instr::Length { v, .. }
            | Instr::Affine { v, .. }
            | Instr::Box { v, .. }
            | Instr::D4 { v, .. } => v.to_vec(),
        }
    }

    /// Registers written.
    pub fn writes(&self) -> Vec<Reg> {
        match *self {
            Instr::D4 { d, .. } => d.to_vec(),
            Instr::Rep { d, .. } | Instr::MinId { d, .. } => d.to_vec(),
            Instr::Const { d, .. }
            | Instr::Un { d, .. }
            | Instr::Bin { d, .. }
            | Instr::BinImm { d, .. }
            | Instr::ImmBin { d, .. }
            | Instr::Select { d, .. }
            | Instr::Length { d, .. }
            | Instr::Affine { d, .. }
            | Instr::Box { d, .. }
            | Instr::SMin { d, .. }
            | Instr::SMax { d, .. } => vec![d],
        }
    }
}

/// A compiled tape. Registers `0..9` hold the inputs (`Var::index`); the rest are scratch.
#[derive(Clone, Debug, PartialEq)]
pub struct Tape {
    pub name: String,
    pub code: Vec<Instr>,
    /// Registers the tape needs, inputs included.
    pub regs: usize,
    /// Registers holding the results, one per root.
    pub outputs: Vec<Reg>,
    /// Which inputs the tape reads.
    pub inputs: Vec<Var>,
}

pub const INPUTS: usize = 9;

/// `Emit::last` for a value nothing reads, one already freed, and a root (read at the end).
const NEVER: usize = usize::MAX - 2;
const FREED: usize = usize::MAX - 1;
const ROOT: usize = usize::MAX;

/// Where a node's value lives while emitting.
#[derive(Clone, Copy, PartialEq)]
enum Slot {
    None,
    Imm(f32),
    Reg,
}

impl Tape {
    /// Compile the nodes `roots` need into a tape.
    pub fn compile(name: &str, g: &Graph, roots: &[Id]) -> Tape {
        Emit::new(g, roots).run(name, roots)
    }
}

struct Emit<'g> {
    g: &'g Graph,
    live: Vec<bool>,
    /// For each node value (node, output), the index of the last instruction reading it.
    last: Vec<[usize; 8]>,
    /// Register of each node's outputs.
    reg: Vec<[Reg; 8]>,
    free: Vec<Reg>,
    regs: usize,
    code: Vec<Instr>,
    /// Constants that some instruction needs in a register.
    needs_reg: Vec<bool>,
}

/// Which node value an operand reads: the node and its output slot (through `Proj`).
fn source(g: &Graph, id: Id) -> (usize, usize) {
    match g.get(id) {
        Node::Proj(t, i) => (t.0 as usize, i as usize),
        _ => (id.0 as usize, 0),
    }
}

/// Whether operand `i` of `n` can be an immediate.
fn takes_imm(n: &Node, i: usize) -> bool {
    matches!(n, Node::Bin(..)) && i < 2
}

impl<'g> Emit<'g> {
    fn new(g: &'g Graph, roots: &[Id]) -> Emit<'g> {
        let live = g.live(roots);
        let mut needs_reg = vec![false; g.len()];
        for (i, _) in live.iter().enumerate().filter(|(_, l)| **l) {
            let n = g.get(Id(i as u32));
            let ops = n.children();
            let both_const =
                matches!(n, Node::Bin(..)) && ops.iter().all(|c| g.constant(*c).is_some());
            for (j, c) in ops.iter().enumerate() {
                if g.constant(*c).is_some() && (!takes_imm(&n, j) || (both_const && j == 1)) {
                    needs_reg[c.0 as usize] = true;
                }
            }
        }
        for r in roots {
            if g.constant(*r).is_some() {
                needs_reg[r.0 as usize] = true;
            }
        }
        Emit {
            g,
            live,
            last: vec![[NEVER; 8]; g.len()],
            reg: vec![[Reg::MAX; 8]; g.len()],
            free: vec![],
            regs: INPUTS,
            code: vec![],
            needs_reg,
        }
    }

    fn slot(&self, id: Id) -> Slot {
        match self.g.get(id) {
            Node::Const(k) if !self.needs_reg[id.0 as usize] => Slot::Imm(k.get() as f32),
            Node::Proj(..) => Slot::Reg,
            Node::Var(_) => Slot::Reg,
            _ if self.live[id.0 as usize] => Slot::Reg,
            _ => Slot::None,
        }
    }

    fn r(&self, id: Id) -> Reg {
        let (n, i) = source(self.g, id);
        self.reg[n][i]
    }

    fn alloc(&mut self) -> Reg {
        self.free.pop().unwrap_or_else(|| {
            self.regs += 1;
            (self.regs - 1) as Reg
        })
    }

    /// Which nodes become instructions, in order: live nodes except inputs, projections and
    /// constants held as immediates.
    fn emitted(&self) -> Vec<usize> {
        (0..self.g.len())
            .filter(|i| {
                self.live[*i]
                    && match self.g.get(Id(*i as u32)) {
                        Node::Var(_) | Node::Proj(..) => false,
                        Node::Const(_) => self.needs_reg[*i],
                        _ => true,
                    }
            })
            .collect()
    }

    fn run(mut self, name: &str, roots: &[Id]) -> Tape {
        let order = self.emitted();
        // Last readers; roots are read after the last instruction.
        for (pos, &i) in order.iter().enumerate() {
            for c in self.g.get(Id(i as u32)).children() {
                if self.slot(c) == Slot::Reg {
                    let (n, j) = source(self.g, c);
                    self.last[n][j] = pos;
                }
            }
        }
        for r in roots {
            let (n, j) = source(self.g, *r);
            self.last[n][j] = ROOT;
        }
        let mut inputs = vec![];
        for v in Var::ALL {
            if let Some(id) = (0..self.g.len())
                .find(|i| self.live[*i] && self.g.get(Id(*i as u32)) == Node::Var(v))
            {
                self.reg[id][0] = v.index() as Reg;
                inputs.push(v);
            }
        }
        for (pos, &i) in order.iter().enumerate() {
            let node = self.g.get(Id(i as u32));
            // Destinations first, so no instruction writes a register it reads.
            for j in 0..node.arity() {
                self.reg[i][j] = self.alloc();
            }
            let instr = self.instr(i, &node);
            self.code.push(instr);
            for c in node.children() {
                let (n, j) = source(self.g, c);
                if self.slot(c) == Slot::Reg && self.last[n][j] == pos && !self.is_input(n) {
                    self.last[n][j] = FREED;
                    self.free.push(self.reg[n][j]);
                }
            }
            for j in 0..node.arity() {
                if self.last[i][j] == NEVER {
                    self.free.push(self.reg[i][j]);
                }
            }
        }
        let outputs = roots.iter().map(|r| self.r(*r)).collect();
        Tape {
            name: name.to_string(),
            code: self.code,
            regs: self.regs,
            outputs,
            inputs,
        }
    }

    fn is_input(&self, n: usize) -> bool {
        matches!(self.g.get(Id(n as u32)), Node::Var(_))
    }

    fn instr(&self, i: usize, n: &Node) -> Instr {
        let d = self.reg[i][0];
        let r = |id: Id| self.r(id);
        let v4 = |v: [Id; 4]| v.map(|x| self.r(x));
        let f = |k: crate::ir::K| k.get() as f32;
        match *n {
            Node::Const(k) => Instr::Const { d, k: f(k) },
            Node::Un(op, a) => Instr::Un { op, d, a: r(a) },
            Node::Bin(op, a, b) => match (self.slot(a), self.slot(b)) {
                (_, Slot::Imm(k)) => Instr::BinImm { op, d, a: r(a), k },
                (Slot::Imm(k), _) if op.commutes() => Instr::BinImm { op, d, a: r(b), k },
                (Slot::Imm(k), _) => Instr::ImmBin { op, d, k, b: r(b) },
                _ => Instr::Bin {
                    op,
                    d,
                    a: r(a),
                    b: r(b),
                },
            },
            Node::Select(c, a, b) => Instr::Select {
                d,
                c: r(c),
                a: r(a),
                b: r(b),
            },
            Node::Length(v, row) => Instr::Length {
                d,
                v: v4(v),
                r: row.map(f),
            },
            Node::Affine(v, row) => Instr::Affine {
                d,
                v: v4(v),
                r: row.map(f),
            },
            Node::BoxDist(v, row) => Instr::Box {
                d,
                v: v4(v),
                r: row.map(f),
            },
            Node::SMin(a, b, k) => Instr::SMin {
                d,
                a: r(a),
                b: r(b),
                k: r(k),
            },
            Node::SMax(a, b, k) => Instr::SMax {
                d,
                a: r(a),
                b: r(b),
                k: r(k),
            },
            Node::D4(v) => Instr::D4 {
                d: self.reg[i],
                v: v4(v),
            },
            Node::Rep(a, l) => Instr::Rep {
                d: [self.reg[i][0], self.reg[i][1]],
                a: r(a),
                l: f(l),
            },
            Node::MinId(a, b, c, id) => Instr::MinId {
                d: [self.reg[i][0], self.reg[i][1]],
                a: r(a),
                b: r(b),
                c: r(c),
                id: f(id),
            },
            Node::Var(_) | Node::Proj(..) => unreachable!("not emitted"),
        }
    }
}
