//! `[render]` settings and the command-line overrides applied over them before the scene is
//! loaded.

use super::schema::RenderSection;
use super::{optional, parse, portals};
use crate::error::RenderError;
use crate::lights::LightSelection;
use rift_fx::shot::check;
use rift_fx::{Invalid, Shot};
use std::path::PathBuf;

/// Render settings from `[render]` (command-line flags override them).
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    pub spp: u32,
    pub seed: u32,
    /// `None`: unlimited (Russian roulette ends paths).
    pub max_bounces: Option<u32>,
    /// Branches a camera path splits into at its first scattering event (1: none).
    pub indirect_samples: u32,
    /// Teleports allowed in a row before the next scattering event.
    pub max_portal_depth: u32,
    /// Light sampling also looks through openings (see [`crate::through::strategies`]).
    pub light_through_openings: bool,
    /// Bounces may be aimed at openings (see [`crate::through::bounce_guide`]).
    pub guide_through_openings: bool,
    /// Denoise finished frames (`rift render --denoise` asks the same).
    pub denoise: bool,
    /// Output path pattern; `#`s become the frame number.
    pub output: String,
    /// `[render] rings`: where the shot's rings come from (`None`: generated in memory).
    pub rings: Option<String>,
}

impl Settings {
    /// The shot's `[render]` settings with `overrides` applied (what the scene is built with;
    /// also what farm jobs are split by).
    pub fn read(shot: &Shot, overrides: &Overrides) -> Result<Self, RenderError> {
        let file = &shot.source;
        let invalid = |e: Invalid| RenderError::Shot(e.in_file(file));
        let render: RenderSection = match &shot.render.render {
            Some(t) => parse(file, "render", t)?,
            None => RenderSection::default(),
        };
        let settings = Settings {
            spp: optional(render.spp, 16, |v| {
                check::integer("render.spp", v, 1, 1 << 16, "a positive integer")
            })
            .map_err(invalid)?,
            seed: optional(render.seed, 0, |v| {
                check::integer("render.seed", v, 0, u32::MAX as i64, "an integer ≥ 0")
            })
            .map_err(invalid)?,
            max_bounces: optional(render.max_bounces, None, |v| {
                check::integer("render.max_bounces", v, 0, 1 << 16, "an integer ≥ 0").map(Some)
            })
            .map_err(invalid)?,
            indirect_samples: optional(render.indirect_samples, 1, |v| {
                check::integer(
                    "render.indirect_samples",
                    v,
                    1,
                    16,
                    "an integer from 1 to 16",
                )
            })
            .map_err(invalid)?,
            max_portal_depth: optional(
                render.max_portal_depth,
                portals::DEFAULT_MAX_PORTAL_DEPTH,
                |v| check::integer("render.max_portal_depth", v, 0, 1 << 16, "an integer ≥ 0"),
            )
            .map_err(invalid)?,
            light_through_openings: render.light_through_openings.unwrap_or(true),
            guide_through_openings: render.guide_through_openings.unwrap_or(false),
            denoise: render.denoise.unwrap_or(false),
            output: render
                .output
                .unwrap_or_else(|| format!("out/{}.####.exr", shot.name)),
            rings: render.rings,
        };
        Ok(Settings {
            spp: overrides.spp.unwrap_or(settings.spp),
            seed: overrides.seed.unwrap_or(settings.seed),
            max_portal_depth: overrides
                .max_portal_depth
                .unwrap_or(settings.max_portal_depth),
            light_through_openings: overrides
                .light_through_openings
                .unwrap_or(settings.light_through_openings),
            guide_through_openings: overrides
                .guide_through_openings
                .unwrap_or(settings.guide_through_openings),
            ..settings
        })
    }
}

/// Settings given outside the shot (the command line), applied before the scene is built
/// because some shape it: the portal depth limit bounds the times rays can reach.
#[derive(Clone, Debug, Default)]
pub struct Overrides {
    pub spp: Option<u32>,
    pub seed: Option<u32>,
    pub max_portal_depth: Option<u32>,
    /// `Some(false)` turns light sampling through openings off.
    pub light_through_openings: Option<bool>,
    /// `Some(true)` turns bounces aimed at openings on, `Some(false)` off.
    pub guide_through_openings: Option<bool>,
    /// A ring cache path pattern (`#` frame tokens) replacing `[render] rings`.
    pub rings: Option<PathBuf>,
    /// How light sampling picks emitters (default: the light tree).
    pub light_selection: Option<LightSelection>,
    /// Bytes the scene may take; a scene whose triangles would need more is refused once its
    /// meshes are read, before any BVH is built.
    pub memory_budget: Option<u64>,
}
