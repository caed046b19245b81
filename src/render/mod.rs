//! The 4D path tracer.
//!
//! Light-transport building blocks, each a small self-contained module checked numerically in
//! `tests/physics_samplers.rs`: `sampling` (frames, uniform and cosine samplers, Fresnel),
//! `bsdf` (surface scattering) and `phase` (scattering in media). On top of them: `frame`
//! (what the compile stage hands over: one frame's tapes, cells, camera, media and lights),
//! `march` (sphere tracing on packets), `material` and `integrator` (the path tracer,
//! accumulating into `crate::film`'s per-pixel buffers); `driver` runs them over tiles and
//! frames.

pub mod bsdf;
pub mod camera;
pub mod driver;
pub mod frame;
// The integrator, the marchers and the probe run the frame's bytecode (`crate::vm`): public
// for tests and benchmarks, not part of the API, which sees their results and choices only.
#[doc(hidden)]
pub mod integrator;
pub mod lights;
#[doc(hidden)]
pub mod march;
pub mod material;
pub mod phase;
#[doc(hidden)]
pub mod probe;
pub mod sampler;
pub mod sampling;
#[doc(hidden)]
pub mod shadow_cull;

pub use integrator::Stats;
pub use march::{Limits, MarcherKind};
