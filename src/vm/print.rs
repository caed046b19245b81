//! `--emit bytecode`: each tape with its inputs, register count and instructions, and with
//! `--cell`, the cell of the cells' marcher that holds a point.

use super::Program;
use super::cells::Cell;
use super::tape::{Instr, Reg, Tape};
use crate::ir::exact::{Form, Piece};
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

/// `1 piece`, `2 pieces`.
fn count(n: usize, what: &str) -> String {
    format!("{n} {what}{}", if n == 1 { "" } else { "s" })
}

/// `[a b c d]`, each in its shortest `f64` form.
fn vec4(v: [f64; 4]) -> String {
    let parts: Vec<String> = v.iter().map(|x| x.to_string()).collect();
    format!("[{}]", parts.join(" "))
}

impl fmt::Display for Piece {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}, object {}", form(&self.form), self.object)
    }
}

/// One exact form, as `--emit bytecode --cell` prints it.
fn form(form: &Form) -> String {
    let rows = |a: &[[f64; 4]; 4]| -> String {
        let rows: Vec<String> = a.iter().map(|r| vec4(*r)).collect();
        rows.join(" ")
    };
    match form {
        Form::Plane { g, c } => format!("plane {} . p + {c}", vec4(*g)),
        Form::Ball {
            rows: a,
            b,
            r,
            sign,
        } => {
            format!(
                "ball {sign} (|A p + {}| - {r}), A rows {}",
                vec4(*b),
                rows(a)
            )
        }
        Form::Box {
            rows: a,
            b,
            half,
            r,
            sign,
        } => format!(
            "box {sign} (box(A p + {}, half {}) - {r}), A rows {}",
            vec4(*b),
            vec4(*half),
            rows(a)
        ),
        Form::Hull { planes, sign } => {
            let planes: Vec<String> = (planes.iter())
                .map(|(g, c)| format!("{} . p + {c}", vec4(*g)))
                .collect();
            format!("hull {sign} max({})", planes.join(", "))
        }
        Form::Abs { f, k } => format!("|{}| - {k}", self::form(f)),
        Form::Lattice(t) => format!(
            "{:?}-tiled ball |M (q - c) + {}| - {}, c the lattice point of q = B p + {}, B rows {}, M rows {}",
            t.tiling,
            vec4(t.off),
            t.r,
            vec4(t.at),
            rows(&t.to),
            rows(&t.m)
        ),
    }
}

/// `--emit bytecode --cell`: the cell a ray at a point marches through. A header names the
/// cell (its depth, corner, edge, the origin of its tapes' local coordinates, the distance
/// below which they are exact, and whether it is the region outside the cells' cube), then
/// the lower bounds of its distances, the pieces rays meet exactly (the whole distance, or
/// with the tape of the rest where the cell is partial), and its scene and interior tapes.
impl fmt::Display for Cell {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (depth, _) = self.id();
        let place = if self.size.is_finite() {
            "inside the cube"
        } else {
            "outside the cube"
        };
        writeln!(
            f,
            "cell {place}: depth {depth}, lo {}, size {}, origin {}, reach {}",
            vec4(self.lo.to_array()),
            self.size,
            vec4(self.origin.to_array()),
            self.reach
        )?;
        if !self.size.is_finite() {
            writeln!(
                f,
                "  (every unbounded object: a ray that proves some out of its way runs the \
                 tapes of the others)"
            )?;
        }
        writeln!(
            f,
            "lower bounds: scene {}, interior {}",
            self.lower[0], self.lower[1]
        )?;
        let mut rest = None;
        if let Some(pieces) = &self.exact {
            writeln!(f, "exact: {}", count(pieces.len(), "piece"))?;
            for p in pieces.iter() {
                writeln!(f, "  {p}")?;
            }
        } else if let Some(partial) = self.partial() {
            writeln!(
                f,
                "partial: {} met exactly, the rest on tape rest (rays outside objects)",
                count(partial.pieces.len(), "piece")
            )?;
            for p in partial.pieces.iter() {
                writeln!(f, "  {p}")?;
            }
            rest = Some(&partial.rest);
        }
        if let Some(pieces) = &self.inner {
            writeln!(f, "inside objects, exact: {}", count(pieces.len(), "piece"))?;
            for p in pieces.iter() {
                writeln!(f, "  {p}")?;
            }
        }
        writeln!(f)?;
        if let Some(t) = rest {
            writeln!(f, "{t}")?;
        }
        writeln!(f, "{}", self.scene)?;
        if let Some(t) = &self.interior {
            writeln!(f, "{t}")?;
        }
        Ok(())
    }
}
