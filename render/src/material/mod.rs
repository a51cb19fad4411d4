//! Materials: BSDFs with emission, the GGX microfacet model they share, and the energy lost
//! between facets added back.

pub mod bsdf;
pub mod inputs;
pub mod microfacet;

pub use bsdf::multiscatter::Multiscatter;
pub use bsdf::{Bsdf, Material, Side};
pub use inputs::{ColorInput, Inputs, Lookup, ScalarInput};
