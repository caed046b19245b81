//! The 4D path tracer.
