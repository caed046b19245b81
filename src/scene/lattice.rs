//! Lattices for tiling. Their parameters are compile-time constants.

use crate::math::kernel::d4;

/// The points `tile` puts a copy of a shape at, each copy in its own cell.
#[derive(Clone, Debug, PartialEq)]
pub enum Lattice {
    /// Integer points with an even coordinate sum, times `scale`.
    D4 {
        /// Scale of the lattice; neighbouring points are `scale * sqrt(2)` apart.
        scale: f64,
    },
    /// Points `spacing * k` with `|k_i| <= limit_i`.
    Grid {
        /// Distance between neighbouring points along each axis, each positive.
        spacing: [f64; 4],
        /// How many cells each side of the origin along each axis (infinite: unbounded).
        limit: [f64; 4],
    },
}

impl Lattice {
    /// Radius of the largest ball centred on a lattice point that stays inside its cell.
    pub fn inradius(&self) -> f64 {
        match self {
            Lattice::D4 { scale } => scale * std::f64::consts::FRAC_1_SQRT_2,
            Lattice::Grid { spacing, .. } => {
                spacing.iter().cloned().fold(f64::INFINITY, f64::min) / 2.0
            }
        }
    }

    /// The nearest lattice point in lattice units (D4), or the grid cell.
    pub fn cell_of(&self, p: [f64; 4]) -> [f64; 4] {
        match self {
            Lattice::D4 { scale } => {
                let out = d4(p.map(|x| x / scale));
                std::array::from_fn(|i| out[4 + i])
            }
            Lattice::Grid { spacing, limit } => {
                std::array::from_fn(|i| (p[i] / spacing[i]).round().clamp(-limit[i], limit[i]))
            }
        }
    }
}
