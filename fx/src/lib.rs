//! rift-fx: the portal-boundary ring effect and the portal rig maths it shares with the renderer.
//!
//! A shot file ([`shot`]) describes cameras, portal openings and a ring look per opening. The rig
//! ([`rig`]) evaluates frames over time and solves teleportal constraints; [`ring`] generates
//! counter-rotating, noise-modulated strands whose speed looks the same whatever the camera does,
//! baked with velocity, acceleration, colour and intensity per vertex; [`export`] writes them as USD,
//! PLY point clouds and a fast native cache.

pub mod error;
pub mod io;
pub mod rig;

pub use error::{FxError, Invalid};
pub mod ring;
pub mod shot;

pub use shot::{FrameRange, Shot};
pub mod export;
