//! Unidirectional path tracing with next-event estimation and multiple importance sampling
//! (power heuristic) between light sampling and BSDF sampling, and Russian roulette from the
//! third bounce on paths whose throughput has fallen low. Each bounce draws one stratified
//! four-dimensional set (light choice and point, BSDF direction) and four hashed numbers
//! (roulette, lobe choice), so the Sobol dimensions line up across paths.
//!
//! Portals: a ray that meets the front of an opening inside its teleport region continues from
//! the there side (with the opening's opacity as the probability; otherwise it passes through).
//! A teleport is not a bounce: it consumes no bounce depth and no bounce dimensions. Teleports
//! in a row are limited by `max_portal_depth`; the count restarts at every scattering event, so
//! a surface's lighting does not depend on how many openings the camera path crossed to reach
//! it. An opening met past the limit ends the path: it shows black (with alpha 1).
//!
//! An opening with a time offset shifts the path's time: the there side, and everything the
//! path meets after, is evaluated at the shifted time.
//!
//! Visibility: each ray has a [`RayClass`](crate::portals::RayClass) (camera, through a
//! portal, indirect, shadow) that the objects' flags and cull volumes filter. An emitter that
//! indirect rays do not see can only be found by light sampling, which then gets the full MIS
//! weight.
//!
//! Light sampling looks through openings ([`crate::through::strategies`]): each shading point picks a
//! strategy (ordinary, or a chain of openings) with the hashed strategy number, samples a light
//! as seen from its image beyond the chain, and the shadow ray follows the teleports. Emission
//! that BSDF sampling finds after teleports is weighed against the strategy for the same chain
//! at the previous vertex, with the opacity coin flips in the BSDF density; chains no strategy
//! samples (too long, an opening with ior ≠ 1, light sampling through openings off) keep the
//! full weight. Shadow rays that pass openings without teleporting are attenuated by
//! 1 − opacity.
//!
//! The loop itself is in [`path`]; next-event estimation (a light sample for a shading point,
//! through openings or not) in [`direct`]; shadow rays, through the openings of a chain, in
//! [`shadow`]. The scene, and what preparing it measured, come in a [`Context`].

mod direct;
mod path;
mod shadow;

pub use direct::{Probe, probe_light};

use crate::geometry::Ray;
use crate::lights::LightGuide;
use crate::lights::emitters::{LightSampler, Picked, Receiver};
use crate::sampling::SampleStream;
use crate::scene::Scene;
use crate::scene::light_groups::MAX_LIGHT_GROUPS;
use crate::through::{BounceGuide, Survey, View};
use glam::Vec3;

/// A tie between an opening and a surface within this relative distance goes to the opening, so
/// an opening placed flat on a wall works.
pub(crate) const PORTAL_TIE: f32 = 1e-4;
/// What paths are traced in: the scene, and what preparing it measured for light sampling
/// ([`crate::prepare`]).
#[derive(Clone, Copy)]
pub struct Context<'a> {
    pub scene: &'a Scene,
    /// Light sampling, its selection guided where a guide was learned.
    pub lights: LightSampler<'a>,
    /// Light sampling through openings; `None` where it cannot bring light (no opening, no
    /// light, no teleport allowed) or the shot turns it off: ordinary light sampling only.
    pub through: Option<View<'a>>,
    /// Where bounces are aimed at openings (`None`: BSDF sampling alone).
    pub bounce_guide: Option<&'a BounceGuide>,
    /// The angle a pixel spans at the image's centre: how fast a camera ray's footprint grows,
    /// for texture filtering.
    pub pixel_spread: f32,
}

impl<'a> Context<'a> {
    /// Paths in `scene`, sampling light through its openings as `survey` measured them and
    /// picking lights as `guide` learned (each `None`: without).
    pub fn new(
        scene: &'a Scene,
        survey: Option<&'a Survey>,
        guide: Option<&'a LightGuide>,
    ) -> Self {
        Self {
            scene,
            lights: scene.lights.sampler(guide),
            through: survey.map(|survey| through_view(scene, survey)),
            bounce_guide: None,
            pixel_spread: (1.0 / scene.camera.projection.focal_pixels()) as f32,
        }
    }

    /// These paths with their bounces aimed at openings as `guide` learned.
    pub fn aiming(self, guide: Option<&'a BounceGuide>) -> Self {
        Self {
            bounce_guide: guide,
            ..self
        }
    }

    /// Paths in `scene` with ordinary light sampling and the unguided light tree, as the
    /// measuring passes that prepare a scene trace them.
    pub fn plain(scene: &'a Scene) -> Self {
        Self::new(scene, None, None)
    }
}

/// The strategy search's view of `scene`, whose openings `survey` measured.
pub fn through_view<'a>(scene: &'a Scene, survey: &'a Survey) -> View<'a> {
    View {
        portals: &scene.portals,
        lights: &scene.lights,
        survey,
        max_depth: scene.settings.max_portal_depth,
    }
}

/// Where a path leaves what it saw for whoever trains on it ([`crate::prepare::training`]).
/// Rendering passes [`NoRecorder`], whose `RECORDS` is false: the loop then leaves every
/// recording step out, as `FULL` leaves out the tests a scene of surfaces and lamps does not
/// need.
pub trait Recorder {
    /// False for a recorder that keeps nothing.
    const RECORDS: bool;
    /// Keeps one light sample.
    fn light_sample(&mut self, record: LightRecord);
    /// The path is about to bounce at `p` (its `bounce`-th scattering event, counted from 0),
    /// carrying `beta` there, its radiance so far `radiance` (light sampling there included).
    fn bounce(&mut self, p: Vec3, bounce: u32, beta: Vec3, radiance: Vec3);
    /// The path teleported through `opening` right after its `bounce`-th scattering event,
    /// before meeting anything else, its radiance then `radiance`.
    fn teleported(&mut self, opening: u32, bounce: u32, radiance: Vec3);
}

/// The recorder that keeps nothing.
pub struct NoRecorder;

impl Recorder for NoRecorder {
    const RECORDS: bool = false;
    #[inline(always)]
    fn light_sample(&mut self, _: LightRecord) {}
    #[inline(always)]
    fn bounce(&mut self, _: Vec3, _: u32, _: Vec3, _: Vec3) {}
    #[inline(always)]
    fn teleported(&mut self, _: u32, _: u32, _: Vec3) {}
}

/// One light sample a recorded path took.
#[derive(Clone, Copy, Debug)]
pub struct LightRecord {
    /// Where it was taken, as light selection saw it (beyond openings for a chain's strategy).
    pub receiver: Receiver,
    /// What it took (`None`: a point on an opening's aperture, or no light at all).
    pub took: Option<Picked>,
    /// Luminance of what it brought over the density it was drawn with, shadow ray included.
    pub value: f32,
}

/// One bounce a recorded path made at an opaque surface.
#[derive(Clone, Copy, Debug)]
pub struct BounceRecord {
    pub p: Vec3,
    /// The opening the bounce's ray teleported through before meeting anything else.
    pub opening: Option<u32>,
    /// Luminance of what came back along the bounce (all the path gathered after it) over
    /// what the path carried to it: the bounce's own estimate of the light it scatters.
    pub value: f32,
    /// The part of `value` gathered beyond the opening (none without one): light met on the
    /// way to it (a lamp in front of it) did not come through it.
    pub through: f32,
}

/// What training paths record: their light samples, and their bounces with what came back
/// along each.
#[derive(Default)]
pub struct Recording {
    pub lights: Vec<LightRecord>,
    pub bounces: Vec<BounceRecord>,
    /// The bounces of the path being traced, the last `open.len()` of `bounces`.
    open: Vec<OpenBounce>,
    /// What is recorded (the default records nothing).
    wanted: Wanted,
}

/// What a [`Recording`] keeps: a training pass that learns only one guide leaves the other's
/// records out (on the showcase the light samples alone are some 20 MB).
#[derive(Clone, Copy, Debug, Default)]
pub struct Wanted {
    pub lights: bool,
    pub bounces: bool,
}

/// A bounce of the path being recorded, until the path ends.
struct OpenBounce {
    /// Its scattering event's count along the path.
    bounce: u32,
    /// The throughput the path carried to it.
    beta: Vec3,
    /// The path's radiance when it was made, and when its ray teleported (if it did).
    made: Vec3,
    teleported: Option<Vec3>,
}

impl Recording {
    /// An empty recording that keeps what is `wanted`.
    pub fn new(wanted: Wanted) -> Self {
        Self {
            wanted,
            ..Self::default()
        }
    }

    /// Closes the bounces of the path just traced, which gathered `radiance` in all.
    pub fn path_done(&mut self, radiance: Vec3) {
        let first_open = self.bounces.len() - self.open.len();
        let closing = &mut self.bounces[first_open..];
        let per_throughput = |gathered: Vec3, beta: Vec3| {
            let back = Vec3::select(beta.cmpgt(Vec3::ZERO), gathered / beta, Vec3::ZERO);
            let value = crate::color::luminance(back);
            if value.is_finite() {
                value.max(0.0)
            } else {
                0.0
            }
        };
        for (record, open) in closing.iter_mut().zip(&self.open) {
            record.value = per_throughput(radiance - open.made, open.beta);
            record.through = open
                .teleported
                .map_or(0.0, |at| per_throughput(radiance - at, open.beta));
        }
        self.open.clear();
    }
}

impl Recorder for Recording {
    const RECORDS: bool = true;
    fn light_sample(&mut self, record: LightRecord) {
        if self.wanted.lights {
            self.lights.push(record);
        }
    }

    fn bounce(&mut self, p: Vec3, bounce: u32, beta: Vec3, radiance: Vec3) {
        if !self.wanted.bounces {
            return;
        }
        self.bounces.push(BounceRecord {
            p,
            opening: None,
            value: 0.0,
            through: 0.0,
        });
        self.open.push(OpenBounce {
            bounce,
            beta,
            made: radiance,
            teleported: None,
        });
    }

    fn teleported(&mut self, opening: u32, bounce: u32, radiance: Vec3) {
        if let (Some(record), Some(open)) = (self.bounces.last_mut(), self.open.last_mut())
            && open.bounce == bounce
        {
            record.opening = Some(opening);
            open.teleported = Some(radiance);
        }
    }
}

/// What one camera path returns.
#[derive(Clone, Copy, Debug, Default)]
pub struct PathSample {
    pub radiance: Vec3,
    /// The part of `radiance` that arrived through openings: light that teleported on its way
    /// from the emitter to the first surface the camera sees (what the camera itself sees
    /// through an opening does not count; `portal_depth` tells that apart).
    pub through: Vec3,
    /// `radiance` by the light group of the emitter it came from (the scene's
    /// [`Scene::light_groups`]; all in group 0 when it has none).
    pub groups: [Vec3; MAX_LIGHT_GROUPS],
    /// The camera ray's hit, for alpha and the AOVs.
    pub first: Option<FirstHit>,
    /// Teleports before the camera path's first scattering event.
    pub portal_depth: u32,
    /// `radiance` as it stood when the camera path first scattered: the emission the camera
    /// sees directly (lamps, rings, the sky, through openings too). `None` until it scatters,
    /// so all of `radiance` when it never does ([`Self::direct_emission`]).
    pub emitted: Option<Vec3>,
}

impl PathSample {
    /// The emission the camera sees directly, which a denoiser must leave as it is.
    pub fn direct_emission(&self) -> Vec3 {
        self.emitted.unwrap_or(self.radiance)
    }
}

/// The surface a camera ray hit (through any openings on the way).
#[derive(Clone, Copy, Debug)]
pub struct FirstHit {
    /// Distance along the camera ray to the first surface or opening.
    pub t: f32,
    /// World-space geometric normal, facing the camera.
    pub normal: Vec3,
    pub albedo: Vec3,
    /// The object (or ring) seen, as [`Scene::id_names`] indexes it, or
    /// [`crate::scene::NO_OBJECT`].
    pub object: u32,
}

/// Traces one path along `camera_ray`, whose range is the camera's clipping interval, leaving
/// what it records in `recorder`.
pub fn trace<R: Recorder>(
    ctx: &Context,
    camera_ray: Ray,
    s: &mut SampleStream,
    recorder: &mut R,
) -> PathSample {
    if ctx.scene.only_surfaces_and_lamps() && !R::RECORDS {
        path::trace_plain(ctx, camera_ray, s)
    } else {
        path::trace_full(ctx, camera_ray, s, recorder)
    }
}
