//! hyperslice: a renderer for four-dimensional scenes written in the `.4ds` language.
//!
//! The pipeline runs one way: source -> tokens -> AST -> typed scene (see `docs/`).

pub mod diagnostic;
pub mod source;
pub mod syntax;
