//! Materials with typed parameters: the shared shape ([`crate::material`]) with the scene's
//! parameters (constants or fields) and the builtin table's entries for each.

use super::builtins::{self, ParamSpec};
use super::field::{Fields, Param};
pub use crate::material::{MaterialKind, Slot};

/// A material of the checked scene: each parameter a constant or a field.
pub type Material<N = Param<f64>, C = Param<[f64; 3]>> = crate::material::Material<N, C>;

impl MaterialKind {
    /// The parameters of this material in the builtin table (none for `air`).
    pub fn params(self) -> &'static [ParamSpec] {
        builtins::find(self.name()).map_or(&[], |b| b.params)
    }
}

impl<N, C> crate::material::Material<N, C> {
    /// [`convert`](Material::convert), with `f` also told each parameter's table entry.
    pub fn map<N2, C2>(
        &self,
        mut f: impl FnMut(&'static ParamSpec, Slot<&N, &C>) -> Slot<N2, C2>,
    ) -> Material<N2, C2> {
        let specs = self.kind().params();
        let mut k = 0;
        self.convert(|p| {
            k += 1;
            f(&specs[k - 1], p)
        })
    }
}

impl Material {
    /// The material of `kind` with every parameter at its table default.
    pub fn with_defaults(kind: MaterialKind) -> Material {
        let params = (kind.params().iter())
            .map(|spec| match spec.default {
                builtins::ParamDefault::Grey(x) => Slot::Color(Param::Const([x; 3])),
                d => Slot::Num(Param::Const(d.num())),
            })
            .collect();
        Material::from_params(kind, params).expect("the table matches the material types")
    }

    /// Which of `p`, `n`, `t` the parameters depend on.
    pub fn deps(&self, fields: &Fields) -> u8 {
        self.params().iter().fold(0, |d, p| {
            d | match p {
                Slot::Num(x) => x.deps(fields),
                Slot::Color(c) => c.deps(fields),
            }
        })
    }
}
