//! rift-render: a portal-aware CPU path tracer.
//!
//! It builds a scene from the same shot file as rift-fx (through [`rift_fx::Shot`]) and traces
//! light with unidirectional path tracing, next-event estimation and multiple importance
//! sampling. render depends on fx, never the reverse.

pub mod geometry;

pub use rift_fx;
