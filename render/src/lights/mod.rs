//! Emitters and how next-event estimation picks them: the scene's emitters (emissive triangles,
//! strand segments, the lights a lighter places, the sky of environment and distant lights),
//! the light tree over them, selection learned per region, and how much of each strand's light
//! gets out of its ring.

pub mod emitters;
pub mod environment;
pub mod guide;
pub mod shapes;
pub mod sky;
pub mod strand_exposure;
pub mod tree;

pub use emitters::{Emitter, LightSample, LightSampler, LightSelection, Lights, Receiver};
pub use environment::Environment;
pub use guide::LightGuide;
pub use shapes::{Cone, Shape, ShapeLight};
pub use sky::{Sky, SkyPart, Sun};
pub use tree::LightTree;
