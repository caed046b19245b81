//! Forms below an object that is no form itself, for escape proofs: where `x >= min_i f_i`
//! everywhere, a ray that meets none of the forms `f_i` never reaches `x <= 0`, and one exact
//! meeting of each (`Form::meet`) proves it instead of a pass of interval bounds over the
//! object's graph. A halfspace with a ball cut out of it is covered by the halfspace, a smooth
//! union of a sphere and a grid of spheres by both grown by the blend.

use super::{Form, MAX_PIECES, min_of_forms};
use crate::ir::{Bin, Graph, Id, Node, Un};

/// Forms `f_i` with `x >= min_i f_i` everywhere, `x` the distance `id`, where the graph shows
/// some: its own forms where it is a min of them (`min_of_forms`); either operand's of an
/// intersection (`max(a, b) >= a`, and a smooth one is at least the plain one); both
/// operands' of a union, a smooth one's lowered by a quarter of its blend width (`smin(a, b,
/// k) >= min(a, b) - k / 4`); a shell's surface's (`|x| >= x`); and a form's moved by a
/// constant added. None where a part is none of these (a complement, a product, a custom
/// field's own arithmetic) or more than `MAX_PIECES` forms.
pub fn cover(g: &Graph, id: Id) -> Option<Vec<Form>> {
    let mut out = vec![];
    below(g, id, 0, &mut out)?;
    Some(out)
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
                Node::Bin(Bin::Max, a, b) | Node::SMax(a, b, _) => {
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
                    let (x, k) = match (g.constant(a), g.constant(b)) {
                        (_, Some(k)) => (a, if op == Bin::Add { k } else { -k }),
                        (Some(k), _) if op == Bin::Add => (b, k),
                        _ => return None,
                    };
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
