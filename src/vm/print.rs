//! `--emit bytecode`: each tape with its inputs, register count and instructions.

use super::Program;
use super::tape::{Instr, Reg, Tape};
use std::fmt;

fn regs(v: &[Reg]) -> String {
    let parts: Vec<String> = v.iter().map(|r| format!("r{r}")).collect();
    parts.join(" ")
}

/// An immediate in its shortest `f32` form.
struct F(f32);

impl fmt::Display for F {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            x if x.is_infinite() => f.write_str(if x > 0.0 { "inf" } else { "-inf" }),
            0.0 => f.write_str("0"),
            x => write!(f, "{x}"),
        }
    }
}

fn nums(v: &[f32]) -> String {
    let parts: Vec<String> = v.iter().map(|x| F(*x).to_string()).collect();
    parts.join(" ")
}

impl fmt::Display for Instr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let k = F;
        match *self {
            Instr::Const { d, k: x } => write!(f, "r{d} = const {}", k(x)),
            Instr::Un { op, d, a } => write!(f, "r{d} = {} r{a}", op.name()),
            Instr::Bin { op, d, a, b } => write!(f, "r{d} = {} r{a} r{b}", op.name()),
            Instr::BinImm { op, d, a, k: x } => write!(f, "r{d} = {} r{a} {}", op.name(), k(x)),
            Instr::ImmBin { op, d, k: x, b } => write!(f, "r{d} = {} {} r{b}", op.name(), k(x)),
            Instr::Select { d, c, a, b } => write!(f, "r{d} = select r{c} r{a} r{b}"),
            Instr::Length { d, v, r } => write!(
                f,
                "r{d} = length {} + [{}] - {}",
                regs(&v),
                nums(&r[..4]),
                k(r[4])
            ),
            Instr::Affine { d, v, r } => write!(
                f,
                "r{d} = affine {} [{} | {}]",
                regs(&v),
                nums(&r[..4]),
                k(r[4])
            ),
            Instr::Box { d, v, r } => write!(
                f,
                "r{d} = box {} + [{}] half [{}] - {}",
                regs(&v),
                nums(&r[..4]),
                nums(&r[4..8]),
                k(r[8])
            ),
            Instr::SMin { d, a, b, k: s } => write!(f, "r{d} = smin r{a} r{b} k r{s}"),
            Instr::SMax { d, a, b, k: s } => write!(f, "r{d} = smax r{a} r{b} k r{s}"),
            Instr::D4 { d, v } => write!(f, "{} = d4 {}", regs(&d), regs(&v)),
            Instr::Rep { d, a, l } => write!(f, "{} = rep r{a} limit {}", regs(&d), k(l)),
            Instr::MinId { d, a, b, c, id } => {
                write!(f, "{} = min_id r{a} r{b} r{c} id {}", regs(&d), k(id))
            }
        }
    }
}

impl fmt::Display for Tape {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let inputs: Vec<String> = self
            .inputs
            .iter()
            .map(|v| format!("{}=r{}", v.name(), v.index()))
            .collect();
        writeln!(
            f,
            "tape {}: {} ops, {} registers, inputs [{}], outputs [{}]",
            self.name,
            self.code.len(),
            self.regs,
            inputs.join(" "),
            regs(&self.outputs)
        )?;
        for ins in &self.code {
            writeln!(f, "  {ins}")?;
        }
        Ok(())
    }
}

impl fmt::Display for Program {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for t in self.tapes() {
            writeln!(f, "{t}")?;
        }
        Ok(())
    }
}
