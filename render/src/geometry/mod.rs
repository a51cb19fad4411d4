//! Geometry: watertight triangles, robust ray origins, per-part BVHs and the two-level scene
//! structure that gives moving objects motion blur.

pub mod accel;
pub mod build;
pub mod contact;
pub mod deforming;
pub mod instance;
pub mod motion;
pub mod moving_bvh;
pub mod offset;
pub mod packed_normal;
pub mod ray;
pub mod round_cone;
pub mod strands;
pub mod triangle;
pub mod triangle_bvh;
pub mod wide_bvh;

pub use accel::{Accel, Hit, STATIC, every_triangle};
pub use contact::{Contacts, Met};
pub use deforming::{Deformation, Samples};
pub use instance::{MovingInstance, Placement};
pub use motion::{ObjectMotion, changes_during};
pub use offset::{offset_origin, offset_target};
pub use packed_normal::PackedNormal;
pub use ray::Ray;
pub use round_cone::{RoundCone, RoundConeHit};
pub use strands::{Ring, RingFrame, Segment, StrandHit, Strands};
pub use triangle::{Triangle, intersect_watertight};
pub use triangle_bvh::{TriangleBvh, TriangleHit};
