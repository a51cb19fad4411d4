//! Light sampling through openings: the strategies a shading point chooses between (ordinary
//! light sampling, or the space beyond a chain of openings), the openings as their search sees
//! them, points drawn on an opening for the sky beyond it, and the grids that tell where
//! searching pays. Beside it, bounces aimed at openings ([`bounce_guide`]) for the light that
//! comes through them after bouncing beyond. What this module reads of a scene is a [`View`]; what preparing the scene
//! measured for it is a [`Survey`] ([`crate::prepare`] makes it).

pub mod aperture_sampling;
pub mod aperture_tree;
pub mod apertures;
pub mod bounce_guide;
pub mod candidates;
pub mod light_visibility;
pub mod strategies;

pub use apertures::{Apertures, ExitLight, facing_pairs};
pub use bounce_guide::{Aim, BounceGuide};
pub use candidates::OpeningCandidates;
pub use light_visibility::{Cells, LightVisibility};
pub use strategies::{CHAIN_DEPTH, Chain, Space, Strategies};

use crate::lights::Lights;
use crate::portals::Portals;

/// What preparing a scene measured for light sampling through its openings.
pub struct Survey {
    /// The openings, with what their exits pass on.
    pub apertures: Apertures,
    /// How much of ordinary light sampling walls leave unblocked where, and where searching
    /// the openings pays.
    pub visibility: LightVisibility,
    /// Where many openings compete, the ones a shading point's search tries first.
    pub candidates: Option<OpeningCandidates>,
}

/// What the strategy search reads: the scene's openings and lights, the survey of the openings,
/// and how many teleports in a row a path may make.
#[derive(Clone, Copy)]
pub struct View<'a> {
    pub portals: &'a Portals,
    pub lights: &'a Lights,
    pub survey: &'a Survey,
    pub max_depth: u32,
}
