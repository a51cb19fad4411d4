//! Materials: BSDFs with emission, the GGX microfacet model they share, and the energy lost
//! between facets added back.

pub mod bsdf;
pub mod inputs;
pub mod microfacet;
pub mod surface;

pub use bsdf::multiscatter::Multiscatter;
pub use bsdf::{Bsdf, Side};
pub use inputs::{ColorInput, Filter, Inputs, Lookup, NormalInput, ScalarInput};
pub use surface::Material;
