//! The one definition of every numeric kernel: scalar operations (`op`, `kernel`), plane
//! rotations (`plane`) and colour curves (`color`). The checker's constant evaluation, the IR's
//! folding and reference evaluator, the VM, the camera and the light placement all compute
//! with these, so a value means the same in every stage.

pub mod color;
pub mod kernel;
pub mod lanes;
mod op;
pub mod plane;

pub use op::{Bin, Un};
pub use plane::Plane;
