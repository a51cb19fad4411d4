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
//! Visibility: each ray has a [`RayClass`] (camera, through a portal, indirect, shadow) that the
//! objects' flags and cull volumes filter. An emitter that indirect rays do not see can only be
//! found by light sampling, which then gets the full MIS weight.
//!
//! Light sampling looks through openings ([`crate::through::strategies`]): each shading point picks a
//! strategy (ordinary, or a chain of openings) with the hashed strategy number, samples a light
//! as seen from its image beyond the chain, and the shadow ray follows the teleports. Emission
//! that BSDF sampling finds after teleports is weighed against the strategy for the same chain
//! at the previous vertex, with the opacity coin flips in the BSDF density; chains no strategy
//! samples (too long, an opening with ior ≠ 1, light sampling through openings off) keep the
//! full weight. Shadow rays that pass openings without teleporting are attenuated by
//! 1 − opacity.

use crate::frame::cryptomatte::NONE as NO_OBJECT;
use crate::geometry::Hit;
use crate::geometry::ray::Ray;
use crate::geometry::{offset_origin, offset_target};
use crate::lights::LightGuide;
use crate::lights::emitters::{
    Found, LightPlace, LightSample, LightSampler, LightSource, Picked, Receiver,
};
use crate::material::bsdf::{Bsdf, Material, Side};
use crate::media::grid::{Rng, Tracked};
use crate::media::homogeneous::{Flight, Medium};
use crate::media::volumes::Inside;
use crate::portals::visibility::RayClass;
use crate::sampling::{Frame, SampleStream, power_heuristic};
use crate::scene::light_groups::MAX_LIGHT_GROUPS;
use crate::scene::{Scene, SceneHit};
use crate::through::aperture_sampling;
use crate::through::{Chain, Space, Strategies, Survey, View};
use glam::Vec3;

/// Roulette starts after this many bounces.
const ROULETTE_AFTER: u32 = 3;
/// Roulette leaves paths alone while their throughput is above this and kills the rest in
/// proportion. Killing bright paths (the plain max-throughput rule) adds more variance than the
/// time it saves in scenes with bright interreflection: on the Cornell box, moving from 1 to
/// 0.25 lowered relMSE at 256 spp by 42% for 25% more time (efficiency 113 → 156); 0.15 and
/// 0.4 measured within 3% of 0.25.
const ROULETTE_THRESHOLD: f32 = 0.25;
/// Every bounce still ends with at least 1 − this probability, so closed lossless scenes
/// terminate (0.99 rather than 0.95 gained another 5% efficiency on the Cornell box).
const ROULETTE_MAX_SURVIVAL: f32 = 0.99;

/// A tie between an opening and a surface within this relative distance goes to the opening, so
/// an opening placed flat on a wall works.
const PORTAL_TIE: f32 = 1e-4;

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
}

/// The recorder that keeps nothing.
pub struct NoRecorder;

impl Recorder for NoRecorder {
    const RECORDS: bool = false;
    #[inline(always)]
    fn light_sample(&mut self, _: LightRecord) {}
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

impl Recorder for Vec<LightRecord> {
    const RECORDS: bool = true;
    fn light_sample(&mut self, record: LightRecord) {
        self.push(record);
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
    /// [`crate::frame::cryptomatte::NONE`].
    pub object: u32,
}

/// A path between events: the ray it follows and what it carries from its last scattering
/// event.
#[derive(Clone, Copy)]
struct PathState {
    ray: Ray,
    /// Throughput.
    beta: Vec3,
    /// Scattering events so far.
    bounce: u32,
    /// Product of η² over refractions, so roulette sees the throughput without the radiance
    /// compression of entering or leaving glass.
    eta_scale: f32,
    /// Solid-angle pdf of the BSDF sample that produced the ray (MIS against light sampling);
    /// camera rays and specular bounces count as delta.
    prev_pdf: f32,
    prev_delta: bool,
    /// The last scattering point, as light selection saw it (for the MIS weight of emitters
    /// that BSDF sampling finds).
    prev_receiver: Receiver,
    /// Teleports since the last scattering event, and through which openings.
    chain: Chain,
    /// Probability of the opacity coin flips since the last scattering event (opacity per
    /// teleport, 1 − opacity per opening passed): part of the BSDF strategy's density.
    coins: f32,
    /// The camera ray's distance to its first opening.
    opening_t: Option<f32>,
    /// The path teleported after its first scattering event: all it gathers from then on is
    /// light through openings.
    lit_through: bool,
    /// The medium the ray travels in.
    inside: Inside,
    /// Distance from the last scattering event to the ray's origin (media boundaries crossed
    /// on the way restart the ray), for the distances light selection's density needs.
    travelled: f32,
    /// Media boundaries crossed since the last event: a guard against a ray caught on one.
    crossings: u32,
    /// Draws for tracking through density grids (seeded from the sample stream when the
    /// scene has grids).
    rng: Rng,
}

impl PathState {
    fn camera(ray: Ray) -> Self {
        Self {
            ray,
            beta: Vec3::ONE,
            bounce: 0,
            eta_scale: 1.0,
            prev_pdf: 0.0,
            prev_delta: true,
            prev_receiver: Receiver {
                p: ray.origin,
                n: None,
                time: ray.time,
            },
            chain: Chain::default(),
            coins: 1.0,
            opening_t: None,
            lit_through: false,
            inside: Inside::Ambient,
            travelled: 0.0,
            crossings: 0,
            rng: Rng::new(0),
        }
    }

    /// Who the current ray is, for visibility flags.
    fn class(&self) -> RayClass {
        match (self.bounce, self.chain.teleports()) {
            (0, 0) => RayClass::Camera,
            (0, _) => RayClass::ThroughPortal,
            _ => RayClass::Indirect,
        }
    }

    /// The MIS weight of emission `found` by the current ray at parameter `t` (at `point`,
    /// unless it is the environment), against light sampling at the last scattering point
    /// through the same openings, which chose by `strategies`. It is 1 where light sampling
    /// could not have found it: after a delta bounce, or through a chain no strategy there
    /// samples.
    fn emission_weight(
        &self,
        ctx: &Context,
        strategies: Option<&Strategies>,
        found: Found,
        t: f32,
        point: Option<Vec3>,
    ) -> f32 {
        if self.prev_delta {
            return 1.0;
        }
        let (q, space) = match (strategies, &ctx.through) {
            (Some(strategies), Some(view)) => strategies.find(view, &self.chain),
            _ if self.chain == Chain::default() => (1.0, None),
            _ => (0.0, None),
        };
        if q <= 0.0 {
            return 1.0;
        }
        let dir = self.ray.dir;
        let lights = &ctx.lights;
        let pdf_light = match space {
            None => lights.pdf_found(
                found,
                &self.prev_receiver,
                dir,
                self.travelled + t,
                &ctx.scene.strands,
            ),
            Some(space) => {
                // Distances beyond the chain count from the mapped shading point.
                let at = &space.receiver;
                let distance = point.map_or(t, |y| y.distance(at.p));
                let pdf = lights.pdf_found(found, at, dir, distance, &ctx.scene.strands);
                let sky = matches!(found, Found::Environment)
                    .then(|| (&self.prev_receiver, space.direction_back(dir)));
                space.density(&ctx.scene.portals, pdf, sky)
            }
        };
        power_heuristic(self.prev_pdf * self.coins, q * pdf_light)
    }

    /// Records the camera ray's first surface (or opening) for the AOVs.
    fn first_hit(&self, out: &mut PathSample, t: f32, normal: Vec3, albedo: Vec3, object: u32) {
        if self.bounce == 0 {
            out.first = Some(FirstHit {
                t: self.opening_t.unwrap_or(self.travelled + t),
                normal,
                albedo,
                object,
            });
        }
    }
}

impl PathSample {
    /// Adds light from an emitter of light group `group` to the path's radiance, and to its
    /// through-openings part when `through`.
    #[inline]
    fn gather(&mut self, light: Vec3, through: bool, group: u8) {
        self.radiance += light;
        self.groups[group as usize & (MAX_LIGHT_GROUPS - 1)] += light;
        if through {
            self.through += light;
        }
    }
}

/// What became of a ray at the openings in front of its hit.
enum Crossing {
    /// It passed every opening (or met none): the hit stands.
    Passed,
    /// It teleported at this distance along the old ray: the path continues along the new one.
    Teleported(f32),
    /// The path ends at an opening (the depth limit, or total reflection at its exit).
    Ended,
    /// A density grid stopped the path before the hit (or the next opening).
    InGrid(Tracked),
}

/// Follows the path's ray through the openings before `hit_t` (its hit, or `None` if it
/// escapes): each meets a teleport with its opacity's probability, else the ray passes. A
/// teleport updates the path's ray, time, throughput and chain.
fn cross_openings(
    ctx: &Context,
    path: &mut PathState,
    hit_t: Option<f32>,
    s: &mut SampleStream,
    out: &mut PathSample,
) -> Crossing {
    let portals = &ctx.scene.portals;
    let ray = path.ray;
    let end = hit_t.unwrap_or(ray.t_max);
    if portals.is_empty() {
        return track_grids(ctx, path, ray.t_min, end, out).unwrap_or(Crossing::Passed);
    }
    let limit = hit_t.map_or(ray.t_max, |t| t * (1.0 + PORTAL_TIE));
    let mut from = ray.t_min;
    while let Some(ph) = portals.intersect(&ray.between(from, limit)) {
        if let Some(stopped) = track_grids(ctx, path, from, ph.t, out) {
            return stopped;
        }
        let look = portals.look(ph.opening);
        if look.opacity < 1.0 {
            if s.uniform() >= look.opacity {
                path.coins *= 1.0 - look.opacity;
                from = ph.t;
                continue;
            }
            path.coins *= look.opacity;
        }
        if path.bounce == 0 && path.opening_t.is_none() {
            path.opening_t = Some(ph.t);
        }
        if path.chain.teleports() >= ctx.scene.settings.max_portal_depth {
            path.first_hit(out, ph.t, -ray.dir, Vec3::ZERO, NO_OBJECT);
            return Crossing::Ended;
        }
        let time = portals.exit_time(ph.opening, ray.time);
        let Some(next) = portals.teleport(&ph, ray.dir, time) else {
            return Crossing::Ended;
        };
        path.beta *= look.tint;
        path.chain.push(ph.opening);
        if path.bounce == 0 {
            out.portal_depth += 1;
        } else {
            path.lit_through = true;
        }
        path.ray = Ray::new(next.origin, next.direction, f32::INFINITY, time);
        return Crossing::Teleported(ph.t);
    }
    track_grids(ctx, path, from, end, out).unwrap_or(Crossing::Passed)
}

/// Delta-tracks the path's ray through the scene's density grids over [`from`, `to`],
/// gathering their emission and weighting the throughput: `Some` when the path collides
/// there (the caller's homogeneous medium had drawn no collision before `to`).
fn track_grids(
    ctx: &Context,
    path: &mut PathState,
    from: f32,
    to: f32,
    out: &mut PathSample,
) -> Option<Crossing> {
    let grids = &ctx.scene.media.grids;
    if grids.is_empty() || from >= to || from.is_nan() || to.is_nan() {
        return None;
    }
    let ray = path.ray;
    let mut emitted = Vec3::ZERO;
    let tracked = grids.track(
        ray.origin,
        ray.dir,
        ray.time,
        from,
        to,
        &mut path.rng,
        &mut path.beta,
        &mut emitted,
    );
    if emitted != Vec3::ZERO {
        out.gather(emitted, path.lit_through, 0);
    }
    (tracked != Tracked::Passed).then_some(Crossing::InGrid(tracked))
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
        trace_plain(ctx, camera_ray, s)
    } else {
        trace_full(ctx, camera_ray, s, recorder)
    }
}

/// [`trace`] in a scene of surfaces and lamps alone: the same path, sample for sample, without
/// the tests for openings, media, strands, the sky and hidden objects, none of which it holds.
fn trace_plain(ctx: &Context, camera_ray: Ray, s: &mut SampleStream) -> PathSample {
    let mut out = PathSample::default();
    follow_plain(ctx, PathState::camera(camera_ray), s, &mut out);
    out
}

/// Follows `path` in a scene of surfaces and lamps alone to its end.
fn follow_plain(ctx: &Context, mut path: PathState, s: &mut SampleStream, out: &mut PathSample) {
    let mut strategies = None;
    while let Some(hit) = ctx.scene.intersect_surfaces(&path.ray) {
        let Some((p, ng, material)) = surface_emission(ctx, &path, &strategies, &hit, out) else {
            break;
        };
        let bsdf = &material.bsdf;
        let plain = &mut NoRecorder;
        if !scatter_at::<false, _>(ctx, &mut path, &mut strategies, p, ng, bsdf, s, out, plain) {
            break;
        }
    }
}

/// Follows `path` to its end, in the loop that [`trace`] chose for the ctx.scene.
fn follow<const FULL: bool, R: Recorder>(
    ctx: &Context,
    path: PathState,
    strategies: Option<Strategies>,
    s: &mut SampleStream,
    out: &mut PathSample,
    recorder: &mut R,
) {
    if FULL {
        follow_full(ctx, path, strategies, s, out, recorder);
    } else {
        follow_plain(ctx, path, s, out);
    }
}

/// [`trace`] in any ctx.scene.
fn trace_full<R: Recorder>(
    ctx: &Context,
    camera_ray: Ray,
    s: &mut SampleStream,
    recorder: &mut R,
) -> PathSample {
    let mut out = PathSample::default();
    let mut path = PathState::camera(camera_ray);
    if !ctx.scene.media.bounded.is_empty() {
        path.inside = ctx.scene.media.at_point(camera_ray.origin);
    }
    if !ctx.scene.media.grids.is_empty() {
        path.rng = grid_rng(s);
    }
    follow_full(ctx, path, None, s, &mut out, recorder);
    out
}

/// A generator for tracking through density grids, seeded from the path's sample stream.
fn grid_rng(s: &mut SampleStream) -> Rng {
    Rng::new(crate::sampling::hash32(s.uniform().to_bits()))
}

/// Follows `path` to its end in any ctx.scene. `strategies` is how light sampling chose at its
/// last scattering point (`None`: ordinary light sampling only), kept beside the path state,
/// which stays small where no opening can matter.
fn follow_full<R: Recorder>(
    ctx: &Context,
    mut path: PathState,
    mut strategies: Option<Strategies>,
    s: &mut SampleStream,
    out: &mut PathSample,
    recorder: &mut R,
) {
    loop {
        let hit = ctx.scene.intersect(&path.ray, path.class());
        let hit_t = hit.map(|h| h.t());
        let medium = ctx.scene.media.medium(path.inside);
        let collision = medium.and_then(|m| free_flight(m, hit_t, s));
        // Where the path scatters next: a collision in a grid or in its medium, or the
        // surface it hit.
        let mut collided = None;
        match cross_openings(ctx, &mut path, collision.or(hit_t), s, out) {
            Crossing::Passed => {}
            Crossing::Teleported(at) => {
                if let Some(m) = medium {
                    path.beta *= m.passage(at);
                }
                path.inside = ctx.scene.media.at_point(path.ray.origin);
                continue;
            }
            Crossing::Ended | Crossing::InGrid(Tracked::Absorbed { .. }) => break,
            Crossing::InGrid(Tracked::Scattered {
                at,
                anisotropy,
                albedo,
            }) => {
                if let Some(m) = medium {
                    path.beta *= m.passage(at);
                }
                collided = Some(Event::Scattered {
                    at,
                    anisotropy,
                    albedo,
                });
            }
            Crossing::InGrid(Tracked::Passed) => {}
        }
        if let Some(m) = medium
            && collided.is_none()
        {
            match collision {
                Some(at) => collided = Some(Event::Collision { medium: m, at }),
                None => path.beta *= m.passage(hit_t.unwrap_or(f32::INFINITY)),
            }
        }
        if collided.is_none()
            && let Some(SceneHit::Surface(h)) = &hit
            && let Some(boundary) = ctx.scene.media.boundary(h.triangle)
        {
            if !cross_boundary(ctx, &mut path, h, boundary) {
                break;
            }
            continue;
        }
        let event = match (collided, hit) {
            (Some(event), _) => event,
            (None, Some(SceneHit::Surface(h))) => Event::Surface(h),
            (None, hit) => {
                finish(ctx, &mut path, strategies.as_ref(), hit, out);
                break;
            }
        };
        if !scatter(ctx, &mut path, &mut strategies, event, s, out, recorder) {
            break;
        }
    }
}

/// Where a path scatters.
enum Event<'a> {
    /// At a surface.
    Surface(Hit),
    /// At a collision `at` along the ray, in `medium`.
    Collision { medium: &'a Medium, at: f32 },
    /// At a scattering event `at` along the ray in a density grid, whose weight the tracking
    /// has applied.
    Scattered {
        at: f32,
        anisotropy: f32,
        albedo: Vec3,
    },
}

/// The end of a path that met no surface to scatter at: the sky it escapes to, or the strand
/// it hits (strands glow and absorb: their emission ends the path).
fn finish(
    ctx: &Context,
    path: &mut PathState,
    strategies: Option<&Strategies>,
    hit: Option<SceneHit>,
    out: &mut PathSample,
) {
    let dir = path.ray.dir;
    let Some(hit) = hit else {
        if let Some(env) = &ctx.scene.lights.environment {
            let weight =
                path.emission_weight(ctx, strategies, Found::Environment, f32::INFINITY, None);
            let light = path.beta * env.radiance(dir) * weight;
            out.gather(light, path.lit_through, ctx.scene.environment_group);
        }
        return;
    };
    if let SceneHit::Strand(h) = hit {
        let found = Found::Strand {
            segment: h.segment,
            s: h.s,
            normal: h.normal,
        };
        let point = Some(path.ray.at(h.t));
        let weight = path.emission_weight(ctx, strategies, found, h.t, point);
        let le = ctx.scene.strands.radiance(h.segment, h.s);
        let group = ctx.scene.strand_light_group(h.segment);
        out.gather(path.beta * le * weight, path.lit_through, group);
        let facing = if h.normal.dot(dir) <= 0.0 {
            h.normal
        } else {
            -h.normal
        };
        path.first_hit(
            out,
            h.t,
            facing,
            Vec3::ZERO,
            ctx.scene.strand_object(h.segment),
        );
    }
}

/// Scatters the path at `event`: a surface's emission or a medium's, then light sampling
/// (leaving its choice of strategies in `strategies`) and the BSDF (or phase function) sample
/// that continues the path, with roulette. False when the path ends there.
fn scatter<R: Recorder>(
    ctx: &Context,
    path: &mut PathState,
    strategies: &mut Option<Strategies>,
    event: Event,
    s: &mut SampleStream,
    out: &mut PathSample,
    recorder: &mut R,
) -> bool {
    let phase;
    let (p, ng, bsdf) = match event {
        Event::Surface(hit) => {
            let Some((p, ng, material)) = surface_emission(ctx, path, strategies, &hit, out) else {
                return false;
            };
            (p, ng, &material.bsdf)
        }
        Event::Collision { medium, at } => {
            let (emitted, scattered) = medium.collision(at);
            out.gather(path.beta * emitted, path.lit_through, 0);
            path.beta *= scattered;
            phase = medium_vertex(path, out, at, medium.anisotropy, medium.albedo());
            (path.ray.at(at), -path.ray.dir, &phase)
        }
        Event::Scattered {
            at,
            anisotropy,
            albedo,
        } => {
            phase = medium_vertex(path, out, at, anisotropy, albedo);
            (path.ray.at(at), -path.ray.dir, &phase)
        }
    };
    scatter_at::<true, R>(ctx, path, strategies, p, ng, bsdf, s, out, recorder)
}

/// A scattering point `at` along the path's ray in a medium: recorded for the AOVs; its
/// phase function is the "BSDF", whose frame's "normal" faces where the path came from
/// (wo = +z).
fn medium_vertex(path: &PathState, out: &mut PathSample, at: f32, g: f32, albedo: Vec3) -> Bsdf {
    path.first_hit(out, at, -path.ray.dir, albedo, NO_OBJECT);
    Bsdf::Phase { g }
}

/// The surface `hit` of the path's ray: records it for the AOVs and gathers its emission;
/// returns its point, geometric normal and material, or `None` when the path met the black
/// back of a one-sided material, where it ends.
fn surface_emission<'a>(
    ctx: &Context<'a>,
    path: &PathState,
    strategies: &Option<Strategies>,
    hit: &Hit,
    out: &mut PathSample,
) -> Option<(Vec3, Vec3, &'a Material)> {
    let (dir, time) = (path.ray.dir, path.ray.time);
    let surface = ctx.scene.surface(hit, time);
    let (p, ng) = (surface.p, surface.ng);
    let material = ctx.scene.material(hit.triangle);
    let cos_o = -dir.dot(ng);
    let black = material.black_from(cos_o);
    // Checked here too, so later bounces skip the albedo and object lookups.
    if path.bounce == 0 {
        let facing = if cos_o >= 0.0 { ng } else { -ng };
        let object = ctx.scene.object_of(hit.triangle);
        let albedo = if black {
            Vec3::ZERO
        } else {
            material.bsdf.albedo()
        };
        path.first_hit(out, hit.t, facing, albedo, object);
    }
    if material.emits() {
        let le = material.emitted(cos_o);
        if le != Vec3::ZERO {
            let found = Found::Triangle {
                triangle: hit.triangle,
                area_scale: surface.area_scale,
                normal: ng,
            };
            let weight = path.emission_weight(ctx, strategies.as_ref(), found, hit.t, Some(p));
            let group = ctx.scene.triangle_light_group(hit.triangle);
            out.gather(path.beta * le * weight, path.lit_through, group);
        }
    }
    (!black).then_some((p, ng, material))
}

/// A free-flight distance through `medium` for the path's ray, whose surface lies at `hit_t`
/// (`None`: it escapes): the distance of a collision before it, or `None`.
fn free_flight(medium: &Medium, hit_t: Option<f32>, s: &mut SampleStream) -> Option<f32> {
    let [u_channel, u_distance, ..] = s.uniform_4d();
    match medium.sample_flight(u_channel, u_distance, hit_t.unwrap_or(f32::INFINITY)) {
        Flight::Collision(at) => Some(at),
        Flight::Through => None,
    }
}

/// Media boundaries a path may cross in a row before it is taken to be caught on one.
const MAX_BOUNDARY_CROSSINGS: u32 = 256;

/// The path's ray passes the boundary of bounded medium `medium` at `hit` without scattering:
/// it goes on from there in the medium on the other side. False when it has crossed too many
/// in a row.
fn cross_boundary(ctx: &Context, path: &mut PathState, hit: &Hit, medium: u32) -> bool {
    path.crossings += 1;
    if path.crossings > MAX_BOUNDARY_CROSSINGS {
        return false;
    }
    let ray = path.ray;
    let surface = ctx.scene.surface(hit, ray.time);
    let ng = surface.ng;
    path.inside = ctx.scene.media.crossed(medium, ray.dir, ng);
    path.travelled += hit.t;
    let origin = offset_origin(surface.p, if ray.dir.dot(ng) > 0.0 { ng } else { -ng });
    path.ray = Ray {
        origin,
        t_min: (ray.t_min - hit.t).max(0.0),
        t_max: ray.t_max - hit.t,
        ..ray
    };
    true
}

/// Light sampling at the point `p` the path's ray reached (geometric normal `ng`, or the
/// direction back along the ray in a medium), leaving its choice of strategies in
/// `strategies`, and the BSDF sample that continues the path (with roulette). False when the
/// path ends there. `FULL` is false in a scene of surfaces and lamps alone
/// ([`Scene::only_surfaces_and_lamps`]), which leaves out the strategies through openings.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn scatter_at<const FULL: bool, R: Recorder>(
    ctx: &Context,
    path: &mut PathState,
    strategies: &mut Option<Strategies>,
    p: Vec3,
    ng: Vec3,
    bsdf: &Bsdf,
    s: &mut SampleStream,
    out: &mut PathSample,
    recorder: &mut R,
) -> bool {
    let (dir, time) = (path.ray.dir, path.ray.time);
    // Dimensions of this bounce, drawn whether or not they are used. Which of the set's four
    // goes where matters: of the 24 orders, this one gave the lowest error on the Cornell box
    // at 256 spp with three seeds (relMSE 3% below the plain order, whose light point took the
    // set's first two; orders putting the light on the third and fourth were 15 to 40% worse),
    // and 2% less variance on the showcase.
    let [by, ly, bx, lx] = s.next_4d();
    let [u_roulette, u_lobe, u_strategy, u_technique] = s.uniform_4d();
    let (u_light, u_bsdf) = (glam::Vec2::new(lx, ly), glam::Vec2::new(bx, by));
    if ctx
        .scene
        .settings
        .max_bounces
        .is_some_and(|m| path.bounce >= m)
    {
        return false;
    }

    // Shade on the side the path arrived from.
    let (n, side) = if -dir.dot(ng) >= 0.0 {
        (ng, Side::Front)
    } else {
        (-ng, Side::Back)
    };
    let frame = Frame::new(n);
    let wo = frame.to_local(-dir);
    let receiver = Receiver {
        p,
        n: (!bsdf.transmits()).then_some(n),
        time,
    };

    let shading = Shading {
        receiver: &receiver,
        ng,
        frame: &frame,
        wo,
        bsdf,
        side,
    };
    if bsdf.is_delta() {
        *strategies = None;
    } else {
        if FULL {
            match &ctx.through {
                Some(view) => Strategies::update(strategies, view, &receiver),
                None => *strategies = None,
            }
        }
        let (space, q) = match (&*strategies, &ctx.through) {
            (Some(strategies), Some(view)) => strategies.pick(view, u_strategy),
            _ => (None, 1.0),
        };
        let through = path.lit_through || space.is_some_and(|s| s.chain.teleports() > 0);
        let space = space.as_ref();
        let (light, group) =
            next_event::<FULL, R>(ctx, &shading, space, q, u_light, u_technique, recorder);
        out.gather(path.beta * light, through, group);
        let branches = ctx.scene.settings.indirect_samples;
        if path.bounce == 0 && branches > 1 && !R::RECORDS {
            split::<FULL, R>(ctx, path, strategies, &shading, branches, s, out, recorder);
            let (u_bsdf, u_lobe, u_roulette) = branch_numbers(s);
            return continue_path(path, &shading, u_bsdf, u_lobe, u_roulette);
        }
    }
    continue_path(path, &shading, u_bsdf, u_lobe, u_roulette)
}

/// The numbers a branch of a split path draws for its BSDF sample: the direction from the
/// bounce's stratified set (the light point's two are the unsplit path's), lobe and roulette
/// from the hashed stream.
fn branch_numbers(s: &mut SampleStream) -> (glam::Vec2, f32, f32) {
    let [by, _, bx, _] = s.next_4d();
    let [u_roulette, u_lobe, ..] = s.uniform_4d();
    (glam::Vec2::new(bx, by), u_lobe, u_roulette)
}

/// Splits `path`, at its first scattering event `at`, into `n` branches that each carry 1/n
/// of its throughput (roulette still weighs the whole): branches 1 to n − 1 are traced to
/// their ends here, each with its own sample stream ([`SampleStream::branch`]); branch 0 is
/// left to the caller, in `path` and `s`.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn split<const FULL: bool, R: Recorder>(
    ctx: &Context,
    path: &mut PathState,
    strategies: &Option<Strategies>,
    at: &Shading,
    n: u32,
    s: &mut SampleStream,
    out: &mut PathSample,
    recorder: &mut R,
) {
    path.beta /= n as f32;
    path.eta_scale *= n as f32;
    for k in 1..n {
        let mut branch = *path;
        let mut stream = s.branch(k, n);
        let (u_bsdf, u_lobe, u_roulette) = branch_numbers(&mut stream);
        if !ctx.scene.media.grids.is_empty() {
            branch.rng = grid_rng(&mut stream);
        }
        if continue_path(&mut branch, at, u_bsdf, u_lobe, u_roulette) {
            follow::<FULL, R>(ctx, branch, *strategies, &mut stream, out, recorder);
        }
    }
    *s = s.branch(0, n);
}

/// The BSDF sample at `at` that continues the path, drawn with `u_bsdf` and `u_lobe`, then
/// roulette with `u_roulette`. False when the path ends there.
#[inline(always)]
fn continue_path(
    path: &mut PathState,
    at: &Shading,
    u_bsdf: glam::Vec2,
    u_lobe: f32,
    u_roulette: f32,
) -> bool {
    let Some(bs) = at.bsdf.sample(at.wo, u_bsdf, u_lobe, at.side) else {
        return false;
    };
    path.beta *= bs.weight;
    path.eta_scale *= bs.eta * bs.eta;
    path.prev_pdf = bs.pdf;
    path.prev_delta = bs.delta;
    path.prev_receiver = *at.receiver;
    // The side comes from the direction before its normalisation, which has the same sign,
    // so the new origin does not wait on the square root.
    let (p, ng) = (at.receiver.p, at.ng);
    let towards = at.frame.to_world(bs.wi);
    let origin = offset_origin(p, if towards.dot(ng) > 0.0 { ng } else { -ng });
    let dir = towards.normalize();
    path.ray = Ray::new(origin, dir, f32::INFINITY, at.receiver.time);
    path.chain = Chain::default();
    path.coins = 1.0;
    path.travelled = 0.0;
    path.crossings = 0;
    path.bounce += 1;
    if path.bounce >= ROULETTE_AFTER {
        let survive = (path.beta.max_element() * path.eta_scale / ROULETTE_THRESHOLD)
            .min(ROULETTE_MAX_SURVIVAL);
        if survive <= 0.0 || u_roulette >= survive {
            return false;
        }
        path.beta /= survive;
    }
    true
}

/// A surface point being shaded, as next-event estimation needs it.
struct Shading<'a> {
    /// The point, with its normal when it only reflects.
    receiver: &'a Receiver,
    /// Geometric normal.
    ng: Vec3,
    /// Shading frame (around the normal on the side the path arrived from).
    frame: &'a Frame,
    /// Direction towards where the path came from, local.
    wo: Vec3,
    bsdf: &'a Bsdf,
    side: Side,
}

/// Next-event estimation: light arriving at `at` (at its time) from one sample drawn with `u`
/// and `u_technique`, in the space beyond the openings of `space` (`None`: ordinary light
/// sampling), the strategy picked with probability `q`; MIS weighted against BSDF sampling
/// (power heuristic), before the path throughput. `FULL` as for [`scatter_at`].
fn next_event<const FULL: bool, R: Recorder>(
    ctx: &Context,
    at: &Shading,
    space: Option<&Space>,
    q: f32,
    u: glam::Vec2,
    u_technique: f32,
    recorder: &mut R,
) -> (Vec3, u8) {
    const NONE: (Vec3, u8) = (Vec3::ZERO, 0);
    if q <= 0.0 {
        return NONE;
    }
    // Training paths record every light sample (see `crate::prepare::training`), out of line:
    // the emitter a sample took is found again from `u` (none for a point on an opening's
    // aperture).
    let mut learn = |value: f32| {
        if FULL && R::RECORDS {
            let on_aperture = space.is_some_and(|s| u_technique < s.aperture);
            let receiver = space.map_or(at.receiver, |s| &s.receiver);
            record_light_sample(ctx, receiver, (!on_aperture).then_some(u), value, recorder);
        }
    };
    let Some(incoming) = incoming(ctx, at.receiver, space, u, u_technique) else {
        learn(0.0);
        return NONE;
    };
    let wi = at.frame.to_local(incoming.dir);
    let f = at.bsdf.eval(at.wo, wi, at.side);
    if f == Vec3::ZERO {
        learn(0.0);
        return NONE;
    }
    // The shadow ray leaves from the side of the surface it goes to.
    let ng = at.ng;
    let dir = incoming.dir;
    let from = offset_origin(at.receiver.p, if dir.dot(ng) > 0.0 { ng } else { -ng });
    let visible = if FULL {
        let chain = space.map_or(Chain::default(), |s| s.chain);
        shadow(ctx, &chain, from, dir, incoming.end, at.receiver.time)
    } else {
        plain_shadow(ctx, from, dir, incoming.end, at.receiver.time)
    };
    let Some((tint, coins)) = visible else {
        learn(0.0);
        return NONE;
    };
    let pdf_light = q * incoming.pdf;
    let weight = if incoming.bsdf_can_find {
        power_heuristic(pdf_light, at.bsdf.pdf(at.wo, wi, at.side) * coins)
    } else {
        1.0
    };
    if FULL && R::RECORDS {
        // What light sampling must bring: its MIS weight leaves out what BSDF sampling finds
        // well (a wide sky, a big lamp close by).
        let brought = f * incoming.radiance * tint * (weight * coins / incoming.pdf);
        learn(crate::color::luminance(brought));
    }
    let light = f * incoming.radiance * tint * (weight * coins / pdf_light);
    (light, incoming.group)
}

/// One sample of light that may reach a point, before its shadow ray.
pub(crate) struct Incoming {
    /// Unit direction at the point.
    pub dir: Vec3,
    pub radiance: Vec3,
    /// Where the shadow ray must reach (off the emitter's surface, beyond the openings).
    pub end: ShadowEnd,
    /// Solid-angle pdf (of all the strategy's techniques that could draw it).
    pub pdf: f32,
    /// False when rays that scatter cannot see the emitter, so BSDF sampling cannot find it.
    bsdf_can_find: bool,
    /// The light group of the emitter.
    pub group: u8,
}

/// Records a training path's light sample at `receiver` (where light selection saw it), drawn
/// with `u` from the light sampler (`None`: on an opening's aperture), which brought `value`
/// (luminance over its density, shadow ray included).
#[cold]
#[inline(never)]
fn record_light_sample<R: Recorder>(
    ctx: &Context,
    receiver: &Receiver,
    u: Option<glam::Vec2>,
    value: f32,
    recorder: &mut R,
) {
    let lights = &ctx.lights;
    recorder.light_sample(LightRecord {
        receiver: *receiver,
        took: u.and_then(|u| lights.picked(u, receiver, &ctx.scene.strands)),
        value,
    });
}

/// Draws light for `at` with the strategy of `space` (`None`: ordinary light sampling): a
/// point on its first opening for the sky beyond when `u_technique` falls in its aperture
/// share, else a light sample as seen from `at`'s image beyond the chain.
pub(crate) fn incoming(
    ctx: &Context,
    at: &Receiver,
    space: Option<&Space>,
    u: glam::Vec2,
    u_technique: f32,
) -> Option<Incoming> {
    if let Some(space) = space
        && u_technique < space.aperture
    {
        return sky_through_aperture(ctx, at, space, u);
    }
    // The point light selection sees: the shading point, or its image beyond the openings.
    let receiver = space.map_or(at, |s| &s.receiver);
    let time = receiver.time;
    let light = ctx.lights.sample(
        u,
        receiver,
        |e| ctx.scene.world_triangle(e.triangle, e.instance, time),
        &ctx.scene.strands,
    )?;
    let arrival = arrival(ctx, &light, receiver)?;
    match space {
        None => Some(arrival),
        Some(space) => Some(brought_back(ctx, at, space, arrival)),
    }
}

/// One ordinary light sample for `at`, traced with its shadow ray, as the scene's
/// measurements draw them ([`crate::through::light_visibility`], [`crate::prepare::exits`]); `None` when
/// it brings nothing.
pub fn probe_light(scene: &Scene, at: &Receiver, u: glam::Vec2) -> Option<Probe> {
    let ctx = &Context::plain(scene);
    let light = incoming(ctx, at, None, u, 0.0)?;
    let weight = (crate::color::luminance(light.radiance) / light.pdf) as f64;
    if !weight.is_finite() || weight <= 0.0 {
        return None;
    }
    let none = Chain::default();
    let transmitted = shadow(ctx, &none, at.p, light.dir, light.end, at.time)
        .map_or(0.0, |(_, coins)| coins as f64);
    Some(Probe {
        dir: light.dir,
        weight,
        transmitted,
        sky: light.end.target.is_none(),
    })
}

/// What [`probe_light`] found.
pub struct Probe {
    /// Unit direction at the point.
    pub dir: Vec3,
    /// Luminance over solid-angle pdf.
    pub weight: f64,
    /// The share of it the shadow ray lets through (0 when blocked).
    pub transmitted: f64,
    /// It came from the environment.
    pub sky: bool,
}

/// A light sample drawn beyond the chain of `space`, as it arrives at the shading point `at`.
/// Kept out of line, with [`sky_through_aperture`]: scenes without openings never run them,
/// and inlined they slowed the Cornell box by 2%.
#[inline(never)]
fn brought_back(ctx: &Context, at: &Receiver, space: &Space, arrival: Incoming) -> Incoming {
    let dir = space.direction_back(arrival.dir);
    let sky = arrival.end.target.is_none().then_some((at, dir));
    Incoming {
        dir,
        pdf: space.density(&ctx.scene.portals, arrival.pdf, sky),
        ..arrival
    }
}

/// The sky beyond the chain of `space`, in the direction of a uniform point on its first
/// opening.
#[inline(never)]
fn sky_through_aperture(
    ctx: &Context,
    at: &Receiver,
    space: &Space,
    u: glam::Vec2,
) -> Option<Incoming> {
    let sky = ctx.scene.lights.environment.as_ref()?;
    let (dir, pdf_aperture) =
        aperture_sampling::sample(&ctx.scene.portals, space.first(), at.time, at.p, u)?;
    let beyond = space.direction_beyond(dir);
    let pdf_light = ctx.lights.pdf_environment(beyond, &space.receiver);
    Some(Incoming {
        dir,
        radiance: sky.radiance(beyond),
        end: ShadowEnd::SKY,
        pdf: space.mixture(pdf_light, pdf_aperture),
        bsdf_can_find: true,
        group: ctx.scene.environment_group,
    })
}

/// How `light` reaches `at`: its direction, target and solid-angle pdf there; `None` when it
/// sends nothing that way (its back, or culled).
#[inline]
fn arrival(ctx: &Context, light: &LightSample, at: &Receiver) -> Option<Incoming> {
    let time = at.time;
    let (bsdf_can_find, group) = match light.place {
        LightPlace::Point {
            source: LightSource::Triangle(triangle),
            ..
        } => (
            ctx.scene.visibility.sees(triangle, RayClass::Indirect),
            ctx.scene.triangle_light_group(triangle),
        ),
        LightPlace::Point {
            source: LightSource::Strand(segment),
            ..
        } => (
            ctx.scene.strand_sees(segment, RayClass::Indirect),
            ctx.scene.strand_light_group(segment),
        ),
        LightPlace::Direction(_) => (true, ctx.scene.environment_group),
    };
    match light.place {
        LightPlace::Direction(dir) => Some(Incoming {
            dir,
            radiance: light.radiance,
            end: ShadowEnd::SKY,
            pdf: light.pdf,
            bsdf_can_find,
            group,
        }),
        LightPlace::Point {
            point,
            normal,
            two_sided,
            source,
        } => {
            if let LightSource::Triangle(triangle) = source
                && ctx.scene.visibility.culled(triangle, point, time)
            {
                return None;
            }
            let cos_raw = (at.p - point).dot(normal);
            if !(cos_raw > 0.0 || (two_sided && cos_raw < 0.0)) {
                return None;
            }
            let light_side = if cos_raw > 0.0 { normal } else { -normal };
            let to = point - at.p;
            let dist2 = to.length_squared();
            let dir = to / dist2.sqrt();
            Some(Incoming {
                dir,
                radiance: light.radiance,
                end: ShadowEnd {
                    target: Some(offset_target(point, light_side)),
                    strand: match source {
                        LightSource::Strand(segment) => Some(segment),
                        LightSource::Triangle(_) => None,
                    },
                },
                pdf: light.pdf * dist2 / dir.dot(light_side).abs(),
                bsdf_can_find,
                group,
            })
        }
    }
}

/// Where a shadow ray ends.
#[derive(Clone, Copy)]
pub(crate) struct ShadowEnd {
    /// The point just off the emitter; `None`: infinitely far.
    pub target: Option<Vec3>,
    /// The strand segment the point lies on, which the ray is not tested against. Light
    /// sampling spreads points over the side of a cylinder facing the ray, which the segment
    /// cannot block; testing it would only find where its taper puts the round surface a hair
    /// outside that cylinder (which darkened the showcase by 0.01%), and it is the costliest
    /// test a shadow ray makes, since the ray ends on its surface where no quick distance
    /// test decides.
    pub strand: Option<u32>,
}

impl ShadowEnd {
    /// Infinitely far: the sky.
    const SKY: Self = Self {
        target: None,
        strand: None,
    };
}

/// [`shadow`] without openings, in a scene of surfaces and lamps alone.
#[inline(always)]
fn plain_shadow(
    ctx: &Context,
    from: Vec3,
    dir: Vec3,
    end: ShadowEnd,
    time: f64,
) -> Option<(Vec3, f32)> {
    let ray = match end.target {
        Some(target) => segment(from, target, time),
        None => Ray::new(from, dir, f32::INFINITY, time),
    };
    (!ctx.scene.occluded_by_surfaces(&ray)).then_some((Vec3::ONE, 1.0))
}

/// The shadow ray from `from` to `target` as the segment between them, over t in (0, 1), for
/// the tests that take a direction of any length (triangles and openings; not strands or
/// media). Making it unit would put a square root and a division on the way to the
/// occlusion query: 3% of the Cornell box's time.
#[inline(always)]
fn segment(from: Vec3, target: Vec3, time: f64) -> Ray {
    Ray::new(from, target - from, 1.0, time)
}

/// Follows a shadow ray from `from` at `time` along `dir` through the openings of `chain` in
/// order (each must be the one it meets, inside its mask at the ray's time, with nothing in
/// front), then on to `end` beyond the last (or to infinity); an empty chain goes straight
/// there. Returns the openings' tint and the probability of the coin flips a path along it
/// makes (opacity per teleport, 1 − opacity per opening passed), or `None` when it is blocked
/// or leaves the chain.
pub(crate) fn shadow(
    ctx: &Context,
    chain: &Chain,
    from: Vec3,
    dir: Vec3,
    end: ShadowEnd,
    time: f64,
) -> Option<(Vec3, f32)> {
    let portals = &ctx.scene.portals;
    let mut ray = Ray::new(from, dir, f32::INFINITY, time);
    let (mut tint, mut coins) = (Vec3::ONE, 1.0f32);
    let media = (!ctx.scene.media.is_empty()).then_some(&ctx.scene.media);
    for i in chain.openings() {
        let hit = portals.intersect_one(i, &ray)?;
        if let Some(media) = media {
            tint *= media.transmittance(ray.origin, ray.dir, hit.t, ray.time);
        }
        // Up to the opening (which wins a tie with a wall it is set in), nothing may block.
        let before = Ray {
            t_max: hit.t,
            ..ray
        };
        coins *= portals.transmittance(&before);
        if coins == 0.0
            || ctx.scene.occluded(
                &Ray {
                    t_max: hit.t * (1.0 - PORTAL_TIE),
                    ..ray
                },
                None,
            )
        {
            return None;
        }
        let look = portals.look(i);
        coins *= look.opacity;
        tint *= look.tint;
        let exit_time = portals.exit_time(i, ray.time);
        let next = portals.teleport(&hit, ray.dir, exit_time)?;
        ray = Ray::new(next.origin, next.direction, f32::INFINITY, exit_time);
    }
    if let Some(target) = end.target {
        // Beyond openings the target lies on the teleported line; it must lie past the last
        // exit.
        let to = target - ray.origin;
        if chain.teleports() > 0 && to.dot(ray.dir) <= 0.0 {
            return None;
        }
        ray = if media.is_none() && ctx.scene.strands.is_empty() {
            segment(ray.origin, target, ray.time)
        } else {
            let dist = to.length();
            Ray::new(ray.origin, to / dist, dist, ray.time)
        };
    }
    if let Some(media) = media {
        tint *= media.transmittance(ray.origin, ray.dir, ray.t_max, ray.time);
        if tint == Vec3::ZERO {
            return None;
        }
    }
    coins *= portals.transmittance(&ray);
    (coins != 0.0 && !ctx.scene.occluded(&ray, end.strand)).then_some((tint, coins))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rift_fx::Shot;
    use crate::sampling::hash32;

    /// The Cornell box of `examples/`, with `materials` added to (or replacing) its own.
    fn cornell_box(dir: &std::path::Path, materials: &str) -> Scene {
        let examples = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples");
        let shot = std::fs::read_to_string(format!("{examples}/cornell.toml")).unwrap();
        let shot = shot.replace("\"cornell.obj\"", &format!("\"{examples}/cornell.obj\""));
        let path = dir.join("box.toml");
        std::fs::write(&path, format!("{shot}\n{materials}")).unwrap();
        Scene::load(&Shot::load(&path).unwrap(), 1).unwrap()
    }

    /// A number in [0, 1) hashed from `i`.
    fn unit(i: u32) -> f32 {
        (hash32(i) >> 8) as f32 / (1 << 24) as f32
    }

    /// The bits of everything a path returns.
    fn bits(sample: &PathSample) -> Vec<u32> {
        let mut bits: Vec<u32> = [sample.radiance, sample.through]
            .iter()
            .chain(&sample.groups)
            .flat_map(|v| v.to_array())
            .map(f32::to_bits)
            .collect();
        bits.push(sample.portal_depth);
        if let Some(first) = sample.first {
            bits.extend(
                [first.t, first.normal.x, first.normal.y, first.normal.z].map(f32::to_bits),
            );
            bits.extend(first.albedo.to_array().map(f32::to_bits));
            bits.push(first.object);
        }
        bits
    }

    #[test]
    fn the_plain_loop_traces_the_paths_of_the_full_one_to_the_bit() {
        let dir = tempfile::tempdir().unwrap();
        let glossy = r#"
[[material]]
name = "white"
type = "dielectric"
ior = 1.5
roughness = 0.2
[[material]]
name = "red"
type = "conductor"
reflectance = [0.9, 0.3, 0.2]
roughness = 0.4
[[material]]
name = "green"
type = "conductor"
reflectance = [0.6, 0.9, 0.6]
roughness = 0.0
"#;
        let cases = [
            ("", 1, "diffuse"),
            (glossy, 1, "glass and metal"),
            ("", 3, "diffuse, split in three"),
        ];
        for (materials, branches, what) in cases {
            let mut scene = cornell_box(dir.path(), materials);
            scene.settings.indirect_samples = branches;
            assert!(scene.only_surfaces_and_lamps(), "{what}");
            let (mut lit, mut bounced) = (0, 0);
            for i in 0..4000 {
                let dir = Vec3::new(0.7 * unit(2 * i) - 0.35, 0.7 * unit(2 * i + 1) - 0.35, -1.0);
                let ray = Ray::new(
                    Vec3::new(0.0, 0.0, 3.9),
                    dir.normalize(),
                    f32::INFINITY,
                    0.0,
                );
                let ctx = &Context::plain(&scene);
                let (plain, full) = (
                    trace_plain(ctx, ray, &mut SampleStream::new(i % 64, i)),
                    trace_full(ctx, ray, &mut SampleStream::new(i % 64, i), &mut NoRecorder),
                );
                assert_eq!(bits(&plain), bits(&full), "{what}, path {i}");
                lit += (plain.radiance != Vec3::ZERO) as u32;
                bounced += (plain.first.is_some_and(|f| f.albedo != Vec3::ZERO)) as u32;
            }
            // The paths compared found light and surfaces, not only the dark.
            assert!(lit > 2000 && bounced > 2000, "{what}: {lit} lit, {bounced}");
        }
    }
}
