//! Forms below an object, for escape proofs: where `x >= min_i f_i`
//! everywhere, a ray that meets none of the forms `f_i` never reaches `x <= 0`, and one exact
//! meeting of each (`Form::meet`) proves it instead of a pass of interval bounds over the
//! object's graph. A halfspace with a ball cut out of it is covered by the halfspace, a smooth
//! union of a sphere and a grid of spheres by both grown by the blend.

use super::{Form, MAX_PIECES, min_of_forms, offset};
use crate::ir::{Bin, Graph, Id, Node, Un};

/// Forms below an object's distance (`cover`).
#[derive(Clone, Debug)]
pub struct Cover {
    pub forms: Vec<Form>,
    /// Whether the distance is the least of the forms (`min_of_forms`), not only at least it:
    /// a ray from outside that reaches a form's surface then reaches the object's.
    pub exact: bool,
}

/// Forms `f_i` with `x >= min_i f_i` everywhere, `x` the distance `id`, where the graph shows
/// some: its own forms where it is a min of them (`min_of_forms`, an exact cover); either
/// operand's of an intersection (`max(a, b) >= a`, and a smooth one is at least the plain
/// one); both operands' of a union, a smooth one's lowered by a quarter of its blend width
/// (`smin(a, b, k) >= min(a, b) - k / 4`); a shell's surface's (`|x| >= x`); and a form's
/// moved by a constant added. None where a part is none of these (a complement, a product, a
/// custom field's own arithmetic) or more than `MAX_PIECES` forms.
pub fn cover(g: &Graph, id: Id) -> Option<Cover> {
    let mut forms = vec![];
    if min_of_forms(g, id, false, 0, &mut forms).is_some() && forms.len() <= MAX_PIECES {
        return Some(Cover { forms, exact: true });
    }
    forms.clear();
    below(g, id, 0, &mut forms)?;
    Some(Cover {
        forms,
        exact: false,
    })
}

/// `cover` of `id`, appended to `out` (left as it was where there is none).
fn below(g: &Graph, id: Id, depth: u32, out: &mut Vec<Form>) -> Option<()> {
    if depth > 32 || out.len() > MAX_PIECES {
        return None;
    }
    let from = out.len();
    let found = (min_of_forms(g, id, false, 0, out).is_some() && out.len() <= MAX_PIECES)
        .then_some(())
        .or_else(|| {
            out.truncate(from);
            match g.get(id) {
                // `max(a, b)` is `a` where `b` is NaN, which `b`'s forms know nothing of:
                // they stand for it only where `b` is never NaN. (A smooth max is NaN where
                // either is.)
                Node::Bin(Bin::Max, a, b) => below(g, a, depth + 1, out)
                    .or_else(|| never_nan(g, b).then(|| below(g, b, depth + 1, out))?),
                Node::SMax(a, b, _) => {
                    below(g, a, depth + 1, out).or_else(|| below(g, b, depth + 1, out))
                }
                Node::Bin(Bin::Min, a, b) => {
                    below(g, a, depth + 1, out)?;
                    below(g, b, depth + 1, out)
                }
                Node::SMin(a, b, k) => {
                    let k = g.constant(k)?.max(0.0);
                    below(g, a, depth + 1, out)?;
                    below(g, b, depth + 1, out)?;
                    lower(&mut out[from..], k / 4.0)
                }
                Node::Un(Un::Abs, a) => below(g, a, depth + 1, out),
                Node::Bin(op @ (Bin::Add | Bin::Sub), a, b) => {
                    let (x, k) = offset(g, op, a, b)?;
                    below(g, x, depth + 1, out)?;
                    lower(&mut out[from..], -k)
                }
                _ => None,
            }
        });
    if found.is_none() {
        out.truncate(from);
    }
    found
}

/// Whether `id` is a number wherever the point is (its operations give none NaN from
/// numbers: no square roots, logarithms, quotients, powers), as far as a walk of at most
/// `MAX_WALK` nodes shows.
fn never_nan(g: &Graph, id: Id) -> bool {
    let mut seen = vec![false; g.len()];
    let mut todo = vec![id];
    let mut walked = 0;
    while let Some(n) = todo.pop() {
        if std::mem::replace(&mut seen[n.0 as usize], true) {
            continue;
        }
        walked += 1;
        let node = g.get(n);
        let safe = match node {
            Node::Const(k) => k.get().is_finite(),
            Node::Un(op, _) => !matches!(
                op,
                Un::Sqrt | Un::Ln | Un::Asin | Un::Acos | Un::Tan | Un::Exp
            ),
            Node::Bin(op, ..) => !matches!(op, Bin::Div | Bin::Mod | Bin::Pow | Bin::Atan2),
            _ => true,
        };
        if !safe || walked > MAX_WALK {
            return false;
        }
        todo.extend(node.children());
    }
    true
}

/// The most nodes `never_nan` walks.
const MAX_WALK: usize = 4096;

/// The forms less `k` (each `f - k`), where `k` is a number.
fn lower(forms: &mut [Form], k: f64) -> Option<()> {
    if !k.is_finite() {
        return None;
    }
    for f in forms {
        *f = f.clone().plus(-k);
    }
    Some(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each object's cover in a one-object scene.
    fn cover_of(shape: &str) -> Option<Cover> {
        let source = format!("object o {{ shape = {shape} }}");
        let scene = crate::Compilation::from_source("t.4ds", &source)
            .scene
            .expect("the test scene compiles");
        let ir = crate::compile::Compiled::new(&scene).program(Some(0.0)).ir;
        cover(&ir.graph, ir.objects[0].distance)
    }

    /// `max(a, b)` is `a` where `b` is NaN (the kernel's `max` keeps its first operand when the
    /// comparison fails), so `b`'s forms cover it only where `b` is never NaN. A reviewer's
    /// counterexample: past `x = 0` the inner `max` is NaN and the outer one is the solid
    /// `-1 - z^2`, which the plane `y = 0.5` of the inner one does not hold. Where the operand
    /// with the plane is first, or NaN cannot arise, the plane covers.
    #[test]
    fn a_max_is_covered_by_an_operand_that_is_never_nan() {
        let nan = "sdf |p| max(-1 - p.z * p.z, max(sqrt(p.x), p.y - 0.5))";
        assert!(cover_of(nan).is_none());
        for shape in [
            "sdf |p| max(p.y - 0.5, sqrt(p.x))",
            "sdf |p| max(-1 - p.z * p.z, max(p.x * p.x, p.y - 0.5))",
        ] {
            let forms = cover_of(shape).expect("a cover").forms;
            assert_eq!(forms.len(), 1, "{shape}: {forms:?}");
            assert!(matches!(forms[0], Form::Plane { .. }), "{shape}: {forms:?}");
        }
    }
}
