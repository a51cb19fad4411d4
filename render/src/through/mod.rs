//! Light sampling through openings: the strategies a shading point chooses between, the
//! openings as their search sees them, points drawn on an opening, and the grids that tell
//! where searching pays.

pub mod aperture;
pub mod aperture_tree;
pub mod candidates;
pub mod light_visibility;
pub mod strategies;

pub use strategies::{Apertures, Chain, Space, Strategies};
