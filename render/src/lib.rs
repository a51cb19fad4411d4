//! rift-render: a portal-aware CPU path tracer.
//!
//! It builds a scene from the same shot file as rift-fx (through [`rift_fx::Shot`]) and traces
//! light with unidirectional path tracing, next-event estimation and multiple importance
//! sampling. render depends on fx, never the reverse.

pub mod aperture;
pub mod aperture_tree;
pub mod camera;
pub mod checkpoint;
pub mod cpu;
pub mod cryptomatte;
pub mod environment;
pub mod error;
pub mod exit_light;
pub mod film;
pub mod geometry;
pub mod grid_medium;
pub mod huge_pages;
pub mod integrator;
pub mod light_guide;
pub mod light_tree;
pub mod light_visibility;
pub mod lights;
pub mod mask;
pub mod material;
pub mod medium;
pub mod microfacet;
pub mod multiscatter;
pub mod opening_candidates;
pub mod opening_tree;
pub mod portal;
pub mod prefetch;
pub mod ray;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod sobol;
pub mod strand_exposure;
pub mod through;
pub mod untrusted;
pub mod vdb;
pub mod visibility;
pub mod volumes;
pub mod voxels;

pub use error::RenderError;
pub use ray::Ray;
pub use rift_fx;
pub use scene::Scene;
