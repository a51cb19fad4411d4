//! rift-render: a portal-aware CPU path tracer.
//!
//! It builds a scene from the same shot file as rift-fx (through [`rift_fx::Shot`]) and traces
//! light with unidirectional path tracing, next-event estimation and multiple importance
//! sampling. render depends on fx, never the reverse.
//!
//! The folders, from the bottom up (each may use those above it in this list, never those
//! below; `ARCHITECTURE.md` draws the layers):
//!
//! - [`platform`]: processor features, huge pages, cache prefetch; [`color`]: luminance.
//! - [`sampling`]: sample numbers (Sobol, hashing) and warps.
//! - [`geometry`]: rays, triangles, round curves, BVHs, motion.
//! - [`texture`]: images read within bounds.
//! - [`material`], [`media`]: BSDFs; participating media and density grids.
//! - [`portals`]: openings, their masks and teleports, visibility and cull volumes.
//! - [`lights`]: emitters, the light tree, learned selection, the environment.
//! - [`through`]: light sampling through openings.
//! - [`scene`]: loading a shot into a [`Scene`]; [`camera`]: its lens.
//! - [`integrator`]: the path loop, direct light, shadow rays.
//! - [`prepare`]: the measuring and training passes that run once per scene.
//! - [`frame`]: render passes, the film, checkpoints, Cryptomatte.
//!
//! The crate is read with its private items (`cargo doc --document-private-items`): its one
//! user is the `rift` binary, and its docs are for the people working on it, so a public
//! item's doc may name the private ones it rests on.
#![allow(rustdoc::private_intra_doc_links)]

pub mod camera;
pub mod color;
pub mod error;
pub mod frame;
pub mod geometry;
pub mod integrator;
pub mod lights;
pub mod material;
pub mod media;
pub mod platform;
pub mod portals;
pub mod prepare;
pub mod sampling;
pub mod scene;
pub mod texture;
pub mod through;
pub mod untrusted;

pub use error::RenderError;
pub use geometry::Ray;
pub use rift_fx;
pub use scene::Scene;
