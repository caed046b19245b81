//! `--emit ir`: the graph as SSA text, constants written inline, then the roots.

use super::lower::Place;
use super::{Graph, Id, K, Node, SceneIr};
use crate::scene::{Num, Slot};
use std::fmt::{self, Write};

fn operand(g: &Graph, id: Id) -> String {
    match g.get(id) {
        Node::Const(k) => Num(k.get()).to_string(),
        _ => format!("%{}", id.0),
    }
}

fn list(g: &Graph, ids: &[Id]) -> String {
    let parts: Vec<String> = ids.iter().map(|i| operand(g, *i)).collect();
    format!("[{}]", parts.join(" "))
}

fn nums(ks: &[K]) -> String {
    let parts: Vec<String> = ks.iter().map(|k| Num(k.get()).to_string()).collect();
    parts.join(" ")
}

/// One node's right-hand side.
pub fn node(g: &Graph, n: &Node) -> String {
    let o = |id: Id| operand(g, id);
    match *n {
        Node::Var(v) => format!("var {}", v.name()),
        Node::Const(k) => format!("const {}", Num(k.get())),
        Node::Un(op, a) => format!("{} {}", op.name(), o(a)),
        Node::Bin(op, a, b) => format!("{} {} {}", op.name(), o(a), o(b)),
        Node::Select(c, a, b) => format!("select {} {} {}", o(c), o(a), o(b)),
        Node::Length(v, r) => format!(
            "length {} + [{}] - {}",
            list(g, &v),
            nums(&r[..4]),
            nums(&r[4..])
        ),
        Node::Affine(v, r) => format!(
            "affine {} [{} | {}]",
            list(g, &v),
            nums(&r[..4]),
            nums(&r[4..])
        ),
        Node::BoxDist(v, r) => format!(
            "box {} + [{}] half [{}] - {}",
            list(g, &v),
            nums(&r[..4]),
            nums(&r[4..8]),
            nums(&r[8..])
        ),
        Node::SMin(a, b, k) => format!("smin {} {} k {}", o(a), o(b), o(k)),
        Node::SMax(a, b, k) => format!("smax {} {} k {}", o(a), o(b), o(k)),
        Node::D4(v) => format!("d4 {}", list(g, &v)),
        Node::Rep(x, l) => format!("rep {} limit {}", o(x), Num(l.get())),
        Node::MinId(a, b, c, k) => format!("min_id {} {} {} id {}", o(a), o(b), o(c), Num(k.get())),
        Node::Proj(a, i) => format!("%{}.{}", a.0, i),
    }
}

impl fmt::Display for SceneIr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let g = &self.graph;
        let live = g.live(&self.roots());
        let shown = (0..g.len())
            .filter(|i| live[*i] && !matches!(g.get(Id(*i as u32)), Node::Const(_)))
            .count();
        writeln!(f, "ir: {shown} nodes")?;
        for (i, _) in live.iter().enumerate().filter(|(_, l)| **l) {
            let n = g.get(Id(i as u32));
            if !matches!(n, Node::Const(_)) {
                writeln!(f, "  %{i} = {}", node(g, &n))?;
            }
        }
        writeln!(
            f,
            "scene distance {}, nearest {}",
            operand(g, self.distance),
            operand(g, self.nearest)
        )?;
        for o in &self.objects {
            writeln!(f, "object {}: distance {}", o.name, operand(g, o.distance))?;
            let m = &o.material;
            if m.leaves.len() > 1 {
                writeln!(f, "  material selector {}", operand(g, m.selector))?;
            }
            for (i, leaf) in m.leaves.iter().enumerate() {
                let mut s = String::new();
                let kind = leaf.kind();
                for (j, (spec, p)) in kind.params().iter().zip(leaf.params()).enumerate() {
                    let sep = if j == 0 { "" } else { ", " };
                    let v = match p {
                        Slot::Num(x) => operand(g, *x),
                        Slot::Color(c) => list(g, c),
                    };
                    let _ = write!(s, "{sep}{}: {v}", spec.name);
                }
                writeln!(f, "  material {i}: {}({s})", kind.name())?;
            }
        }
        for (plane, a) in &self.look {
            writeln!(f, "camera look {} {}", plane.name(), operand(g, *a))?;
        }
        if let Some((d, n)) = self.interior {
            writeln!(
                f,
                "interior distance {}, nearest {}",
                operand(g, d),
                operand(g, n)
            )?;
        }
        for l in &self.lights {
            let mut s = format!("radius {}", operand(g, l.radius));
            for p in &l.places {
                let _ = match p {
                    Place::Translate(v) => write!(s, ", translate {}", list(g, v)),
                    Place::Rotate(steps) => steps.iter().try_for_each(|(pl, a)| {
                        write!(s, ", rotate {} {}", pl.name(), operand(g, *a))
                    }),
                    Place::Scale(k) => write!(s, ", scale {}", operand(g, *k)),
                    Place::Round(r) => write!(s, ", round {}", operand(g, *r)),
                };
            }
            writeln!(f, "light {}: {s}", self.objects[l.object].name)?;
        }
        Ok(())
    }
}
