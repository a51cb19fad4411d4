//! Geometry: watertight triangles, robust ray origins, and the BVH over a scene's triangles.

pub mod accel;
pub mod offset;
pub mod triangle;

pub use accel::{Accel, Hit};
pub use offset::offset_origin;
pub use triangle::{Triangle, intersect_watertight};
