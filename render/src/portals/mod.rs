//! Portal openings: their frames and teleports at each ray's time, the masks that bound their
//! teleport regions, the tree rays find them through, and what each kind of ray may see
//! (visibility flags, cull volumes behind openings).

pub mod masks;
pub mod openings;
pub mod tree;
pub mod visibility;

pub use masks::Mask;
pub use openings::Portals;
pub use visibility::{Flags, RayClass, Visibility};
