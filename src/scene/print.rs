//! The readable text of a typed scene (`--emit scene`): settings, camera, objects with their
//! shape trees, then the field expressions they reach, numbered in the order first met.

use super::Scene;
use super::field::{Const, FieldId, FieldOp, Fields, Input, Param};
use super::lattice::Lattice;
use super::material::{Material, Slot};
use super::shape::{ParamRef, Rotation, Shape};
use crate::math::Un;
use std::collections::HashMap;
use std::fmt::{self, Write};
use std::rc::Rc;

/// Numbers print in their shortest exact form so snapshots stay stable.
pub struct Num(pub f64);

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = if self.0 == 0.0 { 0.0 } else { self.0 };
        if v.is_infinite() {
            return f.write_str(if v > 0.0 { "inf" } else { "-inf" });
        }
        // 1e300 as written, not as 301 digits; below 1e21 every whole number reads in full.
        if v.abs() >= 1e21 {
            return write!(f, "{v:e}");
        }
        write!(f, "{v}")
    }
}

/// Angles and colours are rounded to 9 places, so that degrees read as written.
pub fn round9(x: f64) -> f64 {
    (x * 1e9).round() / 1e9
}

fn vec4(a: &[f64; 4]) -> String {
    let parts: Vec<String> = a.iter().map(|x| Num(*x).to_string()).collect();
    format!("[{}]", parts.join(", "))
}

fn color(c: &[f64; 3]) -> String {
    let parts: Vec<String> = c.iter().map(|x| Num(round9(*x)).to_string()).collect();
    format!("rgb({})", parts.join(", "))
}

fn angle(a: f64) -> String {
    format!("{}deg", Num(round9(a.to_degrees())))
}

/// A lattice as the scene language writes it, e.g. `d4(scale: 1)`.
pub fn lattice(l: &Lattice) -> String {
    match l {
        Lattice::D4 { scale } => format!("d4(scale: {})", Num(*scale)),
        Lattice::Grid { spacing, limit } => {
            format!("grid(spacing: {}, limit: {})", vec4(spacing), vec4(limit))
        }
    }
}

/// Prints values, numbering the field nodes they reach.
struct Printer<'a> {
    fields: &'a Fields,
    ids: HashMap<FieldId, usize>,
    order: Vec<FieldId>,
}

impl Printer<'_> {
    fn field(&mut self, id: FieldId) -> String {
        if let Some(k) = self.ids.get(&id) {
            return format!("%{k}");
        }
        // Constants read better inline than as numbered nodes.
        if let FieldOp::Const(c) = &self.fields.get(id).op {
            return self.constant(c);
        }
        // Children first, so the listing reads top to bottom.
        for c in self.fields.get(id).op.children() {
            self.field(c);
        }
        let k = self.order.len();
        self.ids.insert(id, k);
        self.order.push(id);
        format!("%{k}")
    }

    fn param<T>(&mut self, p: &Param<T>, show: impl Fn(&T) -> String) -> String {
        match p {
            Param::Const(x) => show(x),
            Param::Field(id) => self.field(*id),
        }
    }

    fn constant(&mut self, c: &Const) -> String {
        match c {
            Const::Num(x) => Num(*x).to_string(),
            Const::Angle(a) => angle(*a),
            Const::Bool(b) => b.to_string(),
            Const::Vec4(a) => vec4(a),
            Const::Color(c) => color(c),
            Const::Material(m) => self.material(m),
        }
    }

    fn line(&mut self, id: FieldId) -> String {
        let node = self.fields.get(id);
        let f = |p: &mut Self, x: &FieldId| p.field(*x);
        let list = |p: &mut Self, xs: &[FieldId]| {
            xs.iter()
                .map(|x| p.field(*x))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let body = match &node.op {
            FieldOp::Input(Input::P) => "p".to_string(),
            FieldOp::Input(Input::N) => "n".to_string(),
            FieldOp::Input(Input::T) => "t".to_string(),
            FieldOp::Const(c) => self.constant(c),
            FieldOp::Unary(op, a) => {
                format!("{}{}", if *op == Un::Neg { "-" } else { "!" }, f(self, a))
            }
            FieldOp::Binary(op, a, b) => format!("{} {} {}", f(self, a), op.symbol(), f(self, b)),
            FieldOp::Math(m, xs) => format!("{}({})", m.name(), list(self, xs)),
            FieldOp::Component(a, i) => {
                format!("{}.{}", f(self, a), ["x", "y", "z", "w"][*i as usize])
            }
            FieldOp::MakeVec4(xs) => format!("[{}]", list(self, xs)),
            FieldOp::MakeColor(xs) => format!("rgb({})", list(self, xs)),
            FieldOp::Select(c, a, b) => {
                format!("if {} then {} else {}", f(self, c), f(self, a), f(self, b))
            }
            FieldOp::Index(xs, i) => format!("[{}][{}]", list(self, xs), f(self, i)),
            FieldOp::Cell(l, a) => format!("cell({}, {})", lattice(l), f(self, a)),
        };
        format!("{body}: {}", node.ty)
    }

    fn rotation(&mut self, r: &Rotation) -> String {
        if r.is_empty() {
            return "identity".to_string();
        }
        r.iter()
            .map(|(p, a)| format!("rotate({}, {})", p.name(), self.param(a, |x| angle(*x))))
            .collect::<Vec<_>>()
            .join(" |> ")
    }

    fn material(&mut self, m: &Material) -> String {
        let kind = m.kind();
        let ps: Vec<String> = (kind.params().iter().zip(m.params()))
            .map(|(spec, p)| {
                let v = match p {
                    Slot::Num(x) => self.param(x, |x| Num(*x).to_string()),
                    Slot::Color(c) => self.param(c, color),
                };
                format!("{}: {v}", spec.name)
            })
            .collect();
        if ps.is_empty() {
            return kind.name().to_string();
        }
        format!("{}({})", kind.name(), ps.join(", "))
    }

    fn shape(&mut self, s: &Shape, indent: usize, out: &mut String) {
        let ps: Vec<String> = (s.kind.params().into_iter())
            .map(|(n, p)| {
                let v = match p {
                    ParamRef::Num(x) => self.param(x, |x| Num(*x).to_string()),
                    ParamRef::Vector(v) => self.param(v, vec4),
                    ParamRef::Rotation(r) => self.rotation(r),
                    ParamRef::Lattice(l) => lattice(l),
                };
                format!("{n}: {v}")
            })
            .collect();
        let _ = writeln!(
            out,
            "{:w$}{}({})",
            "",
            s.kind.name(),
            ps.join(", "),
            w = indent * 2
        );
        for c in s.kind.children() {
            self.shape(c, indent + 1, out);
        }
    }

    fn object_material(&mut self, m: &Param<Rc<Material>>) -> String {
        match m {
            Param::Const(m) => self.material(m),
            Param::Field(id) => self.field(*id),
        }
    }
}

impl fmt::Display for Scene {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = &self.render;
        let mut p = Printer {
            fields: &self.fields,
            ids: HashMap::new(),
            order: vec![],
        };
        writeln!(f, "render")?;
        writeln!(f, "  size {} x {}", r.width, r.height)?;
        writeln!(
            f,
            "  frames {}  spp {}  bounces {}",
            r.frames, r.spp, r.bounces
        )?;
        writeln!(
            f,
            "  epsilon {}  max_steps {}  seed {}",
            Num(r.epsilon),
            r.max_steps,
            r.seed
        )?;
        writeln!(
            f,
            "  denoise \"{}\"  quality \"{}\"  fps {}  exposure {}",
            r.denoise.name(),
            r.quality.name(),
            Num(r.fps),
            Num(r.exposure)
        )?;
        let c = &self.camera;
        writeln!(f, "camera")?;
        writeln!(f, "  from {}", vec4(&c.from))?;
        writeln!(f, "  to {}", vec4(&c.to))?;
        writeln!(f, "  look {}", p.rotation(&c.look))?;
        writeln!(f, "  fov {}", angle(c.fov))?;
        writeln!(f, "sky {}", color(&self.sky))?;
        writeln!(f, "medium {}", p.material(&self.medium))?;
        for o in &self.objects {
            writeln!(f, "object {}", o.name)?;
            let mut shape = String::new();
            p.shape(&o.shape, 2, &mut shape);
            writeln!(f, "  shape\n{}", shape.trim_end())?;
            writeln!(f, "  material {}", p.object_material(&o.material))?;
        }
        if !p.order.is_empty() {
            writeln!(f, "fields")?;
            let mut i = 0;
            while i < p.order.len() {
                let id = p.order[i];
                let line = p.line(id);
                writeln!(f, "  %{i} = {line}")?;
                i += 1;
            }
        }
        Ok(())
    }
}
