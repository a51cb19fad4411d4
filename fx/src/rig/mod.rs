//! Rig maths in f64: similarity transforms, keyframed transforms, cameras, portal openings and the
//! teleportal constraint solver.

pub mod camera;
pub mod keyframes;
pub mod opening;
pub mod similarity;

pub use camera::{Camera, LensKey, Projection};
pub use keyframes::{AnimatedTransform, Interpolation, TransformKey};
pub use opening::{Opening, Rig, ThereFrame, solve_here, solve_there};
pub use similarity::{Similarity, SimilarityError};
