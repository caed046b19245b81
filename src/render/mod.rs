//! The 4D path tracer.
//!
//! Light-transport building blocks, each a small self-contained module checked numerically in
//! `tests/physics_samplers.rs`: `sampling` (frames, uniform and cosine samplers, Fresnel),
//! `bsdf` (surface scattering) and `phase` (scattering in media).

pub mod bsdf;
pub mod phase;
pub mod sampling;
