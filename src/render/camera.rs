//! The camera of one frame: a position and four orthonormal axes in 4D. Primary rays leave the
//! position through a virtual screen in the 3D subspace spanned by the right, up and forward
//! axes, so every frame images one 3D slice of the 4D world.

use crate::math::Plane;
use crate::math::plane::rotate;
use glam::DVec4;

#[derive(Clone, Copy, Debug, PartialEq)]
/// The camera of one frame, its position and axes evaluated at that frame's `t`.
pub struct FrameCamera {
    /// Where rays start, in world space.
    pub position: DVec4,
    /// Right, up, forward and the fourth axis (the slice's normal).
    pub axes: [DVec4; 4],
    /// `tan(fov / 2)`: half the screen's width at distance 1.
    pub half_width: f64,
}

impl FrameCamera {
    /// The camera at `position` with a horizontal field of view of `fov` radians, turned by
    /// the `look` rotations (with their angles at this frame).
    pub fn new(position: DVec4, fov: f64, look: &[(Plane, f64)]) -> FrameCamera {
        // Each rotation turns the axes in order, the first applied first.
        let axes = [DVec4::X, DVec4::Y, DVec4::Z, DVec4::W]
            .map(|v| DVec4::from_array(rotate(v.to_array(), look.iter().copied())));
        FrameCamera {
            position,
            axes,
            half_width: (fov / 2.0).tan(),
        }
    }

    /// The unit direction through the screen point `(sx, sy)`, with `(0, 0)` the top-left and
    /// `(width, height)` the bottom-right corner, in pixels.
    pub fn direction(&self, sx: f64, sy: f64, width: u32, height: u32) -> DVec4 {
        let (w, h) = (width as f64, height as f64);
        let x = (2.0 * sx / w - 1.0) * self.half_width;
        let y = (1.0 - 2.0 * sy / h) * self.half_width * h / w;
        (self.axes[2] + x * self.axes[0] + y * self.axes[1]).normalize()
    }
}
