//! Materials: BSDFs with emission, the GGX microfacet model they share, and the energy lost
//! between facets added back.

pub mod bsdf;
pub mod microfacet;
pub mod multiscatter;

pub use bsdf::{Bsdf, Material, Side};
