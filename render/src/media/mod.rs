//! Participating media: homogeneous media, density grids read from OpenVDB files into sparse
//! voxels, and where in the scene each medium is.

pub mod grid;
pub mod homogeneous;
pub mod vdb;
pub mod volumes;
pub mod voxels;

pub use homogeneous::Medium;
pub use volumes::Volumes;
