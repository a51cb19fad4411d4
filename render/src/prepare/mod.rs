//! Preparing a loaded scene for rendering: the passes that measure and train once per scene,
//! each from what the ones before it found, and return what the path loop reads beside the
//! scene ([`Prepared`]).
//!
//! 1. Where light sampling may look through openings ([`Scene::light_through_openings_possible`]):
//!    the light-visibility grid's unblocked shares ([`visibility`]) and each opening's exit
//!    ([`exits`]), traced with ordinary light samples; from the exits, the apertures; then what
//!    searching the openings is worth in each cell, with the strategy search itself; then the
//!    candidate lists where many openings compete. Together they are the [`Survey`].
//! 2. Where light selection is learned, or bounces may be aimed at openings: training paths
//!    traced through the full path loop with the survey, their light samples and bounces
//!    recorded, and the guides learned from them ([`training`], [`aiming`]).
//!
//! Everything here depends only on the scene and its seed, never on the crop, the sample range
//! or the thread count, so every part of a split render prepares the same.

pub mod aiming;
pub mod exits;
pub mod training;
pub mod visibility;

use crate::error::RenderError;
use crate::geometry::Triangle;
use crate::integrator::{Context, through_view};
use crate::lights::{LightGuide, LightSelection};
use crate::scene::{Overrides, Scene};
use crate::through::{Apertures, BounceGuide, OpeningCandidates, Survey, facing_pairs};
use glam::Vec3;
use rift_fx::Shot;
use std::time::Instant;

/// A scene ready to render: the scene as loaded, and what preparing it measured.
pub struct Prepared {
    pub scene: Scene,
    /// Light sampling through the openings (`None` where it cannot bring light or is off).
    pub survey: Option<Survey>,
    /// Light selection learned per region (`None` unless the selection is learned and
    /// training found light).
    pub light_guide: Option<LightGuide>,
    /// Bounces aimed at openings per region (`None` unless the scene may aim them and some
    /// region found light coming through openings).
    pub bounce_guide: Option<BounceGuide>,
    /// Seconds spent training the guides.
    pub training_seconds: f64,
}

impl Prepared {
    /// Loads the scene of `shot` at `frame` with `overrides` and prepares it.
    pub fn build(shot: &Shot, frame: i64, overrides: &Overrides) -> Result<Self, RenderError> {
        Ok(Self::new(Scene::load_with(shot, frame, overrides)?))
    }

    /// Prepares `scene`.
    pub fn new(scene: Scene) -> Self {
        let survey = survey(&scene);
        let started = Instant::now();
        let trained = training::train(
            &Context::new(&scene, survey.as_ref(), None),
            scene.lights.selection() == LightSelection::Learned,
            scene.guide_through_openings_possible(),
        );
        let training_seconds = if trained.light_guide.is_some() || trained.bounce_guide.is_some() {
            started.elapsed().as_secs_f64()
        } else {
            0.0
        };
        Self {
            scene,
            survey,
            light_guide: trained.light_guide,
            bounce_guide: trained.bounce_guide,
            training_seconds,
        }
    }

    /// What the path loop traces in.
    pub fn context(&self) -> Context<'_> {
        Context::new(&self.scene, self.survey.as_ref(), self.light_guide.as_ref())
            .aiming(self.bounce_guide.as_ref())
    }
}

/// What light sampling through the openings of `scene` needs measured; `None` where it cannot
/// bring light.
fn survey(scene: &Scene) -> Option<Survey> {
    if !scene.light_through_openings_possible() {
        return None;
    }
    let times = scene.portals.times();
    let still = &scene.triangles[..scene.static_triangles];
    let unblocked = visibility::measure_unblocked(scene, static_bounds(still), times);
    let exits = exits::measure(scene);
    let walled_off = exits::walled_off(scene, &facing_pairs(&scene.portals));
    let apertures = Apertures::new(&scene.portals, exits, &walled_off);
    // Every point searches while the worth of searching is measured.
    let searching = Survey {
        apertures,
        visibility: unblocked,
        candidates: None,
    };
    let worth = visibility::measure_worth(&through_view(scene, &searching), times);
    let visibility = searching.visibility.with_worth(worth);
    let candidates = OpeningCandidates::new(&searching.apertures, visibility.cells(), times[0]);
    Some(Survey {
        apertures: searching.apertures,
        visibility,
        candidates,
    })
}

/// The lower and upper corners of `triangles` (a unit box around the origin when there are
/// none).
fn static_bounds(triangles: &[Triangle]) -> [Vec3; 2] {
    let corners = triangles.iter().flat_map(|t| t.v);
    let lower = corners.clone().fold(Vec3::INFINITY, Vec3::min);
    let upper = corners.fold(Vec3::NEG_INFINITY, Vec3::max);
    if lower.cmple(upper).all() {
        [lower, upper]
    } else {
        [Vec3::splat(-0.5), Vec3::splat(0.5)]
    }
}
