//! The path loop: a camera path from hit to hit (through the openings and media on the way),
//! its emission found by BSDF sampling with MIS weights, light sampling at each scattering
//! event ([`super::direct`]), the BSDF sample that continues it, and roulette.

use super::direct::{Shading, next_event, sky_group};
use super::{Context, FirstHit, NoRecorder, PORTAL_TIE, PathSample, Recorder};
use crate::geometry::{Hit, Met, Ray, offset_origin};
use crate::lights::emitters::{Found, Receiver};
use crate::material::Lookup;
use crate::material::bsdf::{Bsdf, BsdfSample, Side};
use crate::material::surface::Material;
use crate::media::grid::{Rng, Tracked};
use crate::media::homogeneous::{Flight, Medium};
use crate::media::volumes::Inside;
use crate::portals::Portals;
use crate::portals::visibility::RayClass;
use crate::sampling::{Frame, SampleStream, power_heuristic};
use crate::scene::light_groups::MAX_LIGHT_GROUPS;
use crate::scene::{NO_OBJECT, Scene, SceneHit};
use crate::through::{Aim, Chain, Strategies};
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
/// The most roulette's threshold moves, either way, by what training learned a bounce is
/// worth where the path is against where its pixel's camera path first bounced. With the least
/// survival below keeping the survivors' weights bounded, following paths far into bright
/// places costs more than it brings: on `bounce_through` (160×90, 64 spp) 100, 30, 10, 3, 2
/// and 1 gave efficiencies of 14.6, 15.5, 16.3, 18.1, 17.5 and 13.5 (2.8 against 2.3 for 3
/// against 100 at the shot's 480×270, 16 spp); `lit_through` and `hall_of_mirrors` with guiding
/// were unmoved (1.02×, 1.00×).
const ROULETTE_MOST_WORTH: f32 = 3.0;
/// The least survival probability of a path whose roulette follows what the bounce guide
/// learned ([`roulette_terms`]), so a survivor's weight grows at most fivefold there. Measured
/// on `bounce_through` (160×90, 64 spp, two seeds in each of three alternated rounds, against
/// 2,048 spp) before the two constants around it were retuned: least survivals of 0 (none),
/// 0.1, 0.2, 0.3 and 0.5 gave efficiencies of 9.4, 11.8, 12.8, 12.6 and 12.4, the rounds of 0.2
/// spreading 12.2-12.9 instead of 7.7-11.1. Most of the gain is the guide's: its second
/// training pass, which follows the first one's guide, reaches more regions (716 learned, 476
/// aiming, against 689 and 321), and the render takes a fifth less time for the same noise.
/// Shots without a guide render as before, to the bit.
const ROULETTE_GUIDED_LEAST_SURVIVAL: f32 = 0.2;
/// The most roulette's threshold is lowered for a pixel whose camera path first bounced where
/// bounces bring back far less than in the scene's brightest places (a dark room lit through a
/// window): see [`roulette_terms`]. With the two constants above, 8, 16, 32 and 64 gave
/// efficiencies of 14.3, 17.9, 19.2 and 18.3 on `bounce_through` (160×90, 64 spp; 32 against
/// 16 at 480×270, 16 spp: 3.1 against 2.8); `lit_through` and `hall_of_mirrors` with guiding
/// were unmoved.
const ROULETTE_MOST_LOWERED: f32 = 32.0;
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
    /// The ray cone's width where the path last scattered (world units) and its spread
    /// (radians): the footprint textures are filtered over (kept only where there are
    /// textures).
    width: f32,
    spread: f32,
    /// The static triangle the path last scattered at when it touches another object's
    /// surface (see [`crate::geometry::Contacts`]), else [`NOT_TOUCHING`]: the next ray first
    /// looks there.
    touching: u32,
    /// The shading normal of the surface just reached (world space, on its front side): its
    /// mesh's smooth normal, bent by its normal map, for [`scatter_at`]'s shading frame;
    /// `None` for a flat surface without a map.
    mapped_normal: Option<Vec3>,
    /// The camera path has met only mirror-like surfaces (smooth glass, mirrors) since the
    /// camera: the next surface it meets gives the albedo and normal guides a denoiser reads,
    /// as what the camera sees in a mirror or through glass is that surface.
    guides_follow: bool,
    /// What a bounce was seen to bring back where the camera path first scattered (0:
    /// unknown): what its pixel is worth, for roulette.
    pixel_worth: f32,
}

/// [`PathState::touching`] when the path did not leave a surface that touches another.
const NOT_TOUCHING: u32 = u32::MAX;

/// The least spread a ray cone takes after scattering off a surface that is not a mirror:
/// rough bounces spread the light they gather, so their textures are read blurred (as pbrt's
/// and other renderers' ray cones and differentials do after the first bounce).
const ROUGH_SPREAD: f32 = 0.1;

/// The smallest cosine a footprint is stretched by at grazing angles.
const GRAZING_COS: f32 = 0.05;

impl PathState {
    /// A camera path along `ray`, whose cone spreads `spread` radians (a pixel's angle).
    fn camera(ray: Ray, spread: f32) -> Self {
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
            width: 0.0,
            spread,
            touching: NOT_TOUCHING,
            mapped_normal: None,
            guides_follow: false,
            pixel_worth: 0.0,
        }
    }

    /// The surface the path's ray meets at once, as it leaves a surface that touches another
    /// (see [`crate::geometry::Contacts`]): asked once per ray. Where the surface it faces is
    /// in optical contact, the ray starts again beyond it and meets nothing at once.
    #[inline]
    fn contact(&mut self, scene: &Scene) -> Option<Hit> {
        if self.touching == NOT_TOUCHING {
            return None;
        }
        let left = std::mem::replace(&mut self.touching, NOT_TOUCHING);
        match meet_touching(scene, left, self.prev_receiver.p, &self.ray, self.class())? {
            Met::Surface(hit) => Some(hit),
            Met::Beyond(origin) => {
                self.ray.origin = origin;
                None
            }
        }
    }

    /// The shading frame where the path arrived, at geometric normal `n` on its `side`
    /// (towards `wo`): around `n`, or around the shading normal the surface gave
    /// ([`Self::mapped_normal`], taken) bent as [`bent_normal`] says, and then true:
    /// directions must be checked against the geometry. `FULL` as for [`scatter_at`].
    #[inline(always)]
    fn shading_frame<const FULL: bool>(&mut self, n: Vec3, side: Side, wo: Vec3) -> (Frame, bool) {
        let mapped = if FULL {
            self.mapped_normal.take()
        } else {
            None
        };
        match mapped {
            None => (Frame::new(n), false),
            Some(mapped) => {
                let mapped = if side == Side::Front { mapped } else { -mapped };
                (Frame::new(bent_normal(mapped, n, wo)), true)
            }
        }
    }

    /// What the path's ray meets first: the surface it touches as it leaves one that touches
    /// another, else the scene's nearest surface or strand (a touching surface's partner when
    /// that lies before it).
    #[inline(always)]
    fn next_hit(&mut self, scene: &Scene) -> Option<SceneHit> {
        if let Some(touching) = self.contact(scene) {
            return Some(SceneHit::Surface(touching));
        }
        match scene.intersect(&self.ray, self.class()) {
            Some(SceneHit::Surface(h)) => Some(SceneHit::Surface(self.first_met(scene, h))),
            other => other,
        }
    }

    /// `hit`, found by the path's ray, or the surface it touches that the ray meets before it
    /// (see [`crate::geometry::Contacts::first_met`]).
    #[inline(always)]
    fn first_met(&self, scene: &Scene, hit: Hit) -> Hit {
        match scene.contacts.touches(&hit) {
            true => first_touching(scene, hit, &self.ray, self.class()),
            false => hit,
        }
    }

    /// Widens the ray cone to the scattering point `p` the path reached and, after a bounce
    /// that is not a mirror's, to at least [`ROUGH_SPREAD`].
    fn widen_cone(&mut self, p: Vec3, delta: bool) {
        let distance = self.travelled + (p - self.ray.origin).length();
        self.width += self.spread * distance;
        if !delta {
            self.spread = self.spread.max(ROUGH_SPREAD);
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
    /// The path ends at an opening at this distance (the depth limit, or total reflection at
    /// its exit).
    Ended(f32),
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
            return Crossing::Ended(ph.t);
        }
        let time = portals.exit_time(ph.opening, ray.time);
        let Some(next) = portals.teleport(&ph, ray.dir, time) else {
            return Crossing::Ended(ph.t);
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
/// What the ray leaving the point `p` of triangle `left` meets at once (see
/// [`PathState::contact`]), among the surfaces rays of `class` see.
#[cold]
#[inline(never)]
fn meet_touching(scene: &Scene, left: u32, p: Vec3, ray: &Ray, class: RayClass) -> Option<Met> {
    let count = scene.static_triangles;
    scene.contacts.meet(
        &scene.triangles[..count],
        &scene.normals[..count],
        left,
        p,
        ray,
        seen_by(scene, class, p, ray.time),
    )
}

/// The surface of `hit` or one it touches, whichever `ray` meets first (see
/// [`PathState::first_met`]).
#[cold]
#[inline(never)]
fn first_touching(scene: &Scene, hit: Hit, ray: &Ray, class: RayClass) -> Hit {
    let count = scene.static_triangles;
    scene.contacts.first_met(
        &scene.triangles[..count],
        &scene.normals[..count],
        hit,
        ray,
        seen_by(scene, class, ray.at(hit.t), ray.time),
    )
}

/// Whether rays of `class` see a triangle near `p` at `time`.
fn seen_by(scene: &Scene, class: RayClass, p: Vec3, time: f64) -> impl Fn(u32) -> bool + '_ {
    let visibility = &scene.visibility;
    move |b| !visibility.hides_anything() || visibility.admits(b, class, p, time)
}

/// [`super::trace`] in a scene of surfaces and lamps alone: the same path, sample for sample, without
/// the tests for openings, media, strands, the sky and hidden objects, none of which it holds.
pub(super) fn trace_plain(ctx: &Context, camera_ray: Ray, s: &mut SampleStream) -> PathSample {
    let mut out = PathSample::default();
    let path = PathState::camera(camera_ray, ctx.pixel_spread);
    follow_plain(ctx, path, s, &mut out);
    out
}

/// Follows `path` in a scene of surfaces and lamps alone to its end.
fn follow_plain(ctx: &Context, mut path: PathState, s: &mut SampleStream, out: &mut PathSample) {
    let mut strategies = None;
    loop {
        // Borrowed where the query left it: moved out, the hit was copied with loads wider
        // than the query's stores of its fields, which had to wait for them.
        let found = ctx.scene.intersect_surfaces(&path.ray);
        let Some(hit) = &found else {
            break;
        };
        let mut textured = None;
        let Some((p, ng, bsdf)) =
            surface_emission::<false>(ctx, &mut path, &strategies, hit, &mut textured, out)
        else {
            break;
        };
        let plain = &mut NoRecorder;
        let at = (p, ng, Some(hit));
        if !scatter_at::<false, _>(ctx, &mut path, &mut strategies, at, bsdf, s, out, plain) {
            break;
        }
    }
}

/// Follows `path` to its end, in the loop that [`super::trace`] chose for the scene.
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

/// [`super::trace`] in any scene.
pub(super) fn trace_full<R: Recorder>(
    ctx: &Context,
    camera_ray: Ray,
    s: &mut SampleStream,
    recorder: &mut R,
) -> PathSample {
    let mut out = PathSample::default();
    let mut path = PathState::camera(camera_ray, ctx.pixel_spread);
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

/// Follows `path` to its end in any scene. `strategies` is how light sampling chose at its
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
        let hit = path.next_hit(ctx.scene);
        let hit_t = hit.map(|h| h.t());
        let medium = ctx.scene.media.medium(path.inside);
        let collision = medium.and_then(|m| free_flight(m, hit_t, s));
        // Where the path scatters next: a collision in a grid or in its medium, or the
        // surface it hit.
        let mut collided = None;
        // Shape lights are transparent: what the ray passes on the way is gathered, with the
        // path as it was before any opening changed it.
        let before =
            (!ctx.scene.lights.shapes.is_empty() && ctx.scene.media.is_empty()).then_some(path);
        let crossing = cross_openings(ctx, &mut path, collision.or(hit_t), s, out);
        if let Some(before) = &before {
            let end = match crossing {
                Crossing::Teleported(at) | Crossing::Ended(at) => at,
                _ => hit_t.unwrap_or(before.ray.t_max),
            };
            shape_lights_along(ctx, before, strategies.as_ref(), end, out);
        }
        match crossing {
            Crossing::Passed => {}
            Crossing::Teleported(at) => {
                // What a bounce brings through an opening is gathered from here on (a lamp on
                // the way to it is not light through it).
                if R::RECORDS && path.bounce > 0 && path.chain.teleports() == 1 {
                    let opening = path.chain.openings().next().unwrap_or_default() as u32;
                    recorder.teleported(opening, path.bounce - 1, out.radiance);
                }
                if let Some(m) = medium {
                    path.beta *= m.passage(at);
                }
                path.inside = ctx.scene.media.at_point(path.ray.origin);
                continue;
            }
            Crossing::Ended(_) | Crossing::InGrid(Tracked::Absorbed { .. }) => break,
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

/// Gathers the shape lights the path's ray passes before `end` that rays of its class see,
/// each weighed against light sampling at the last scattering point (a point light is found
/// by light sampling alone).
#[inline(never)]
fn shape_lights_along(
    ctx: &Context,
    path: &PathState,
    strategies: Option<&Strategies>,
    end: f32,
    out: &mut PathSample,
) {
    let class = path.class();
    let ray = Ray {
        t_max: end,
        ..path.ray
    };
    for (k, light) in ctx.scene.lights.shapes.iter().enumerate() {
        if !light.flags.sees(class) {
            continue;
        }
        let Some((t, found)) = light.intersect(&ray) else {
            continue;
        };
        let point = found.point;
        let kind = Found::Shape {
            light: k as u32,
            point,
            normal: found.normal,
        };
        let weight = path.emission_weight(ctx, strategies, kind, t, Some(point));
        out.gather(
            path.beta * found.radiance * weight,
            path.lit_through,
            light.group,
        );
    }
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
        if let Some(sky) = &ctx.scene.lights.sky {
            let weight =
                path.emission_weight(ctx, strategies, Found::Environment, f32::INFINITY, None);
            let (class, time) = (path.class(), path.ray.time);
            sky.each_part(dir, time, class, |radiance, part| {
                let light = path.beta * radiance * weight;
                out.gather(light, path.lit_through, sky_group(ctx, part));
            });
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
    // Holds the BSDF made for this point (a textured surface's, a medium's phase function).
    let mut made = None;
    let (p, ng, bsdf, hit) = match event {
        Event::Surface(hit) => {
            let Some((p, ng, bsdf)) =
                surface_emission::<true>(ctx, path, strategies, &hit, &mut made, out)
            else {
                return false;
            };
            (p, ng, bsdf, Some(hit))
        }
        Event::Collision { medium, at } => {
            let (emitted, scattered) = medium.collision(at);
            out.gather(path.beta * emitted, path.lit_through, 0);
            path.beta *= scattered;
            let phase = medium_vertex(path, out, at, medium.anisotropy, medium.albedo());
            (path.ray.at(at), -path.ray.dir, &*made.insert(phase), None)
        }
        Event::Scattered {
            at,
            anisotropy,
            albedo,
        } => {
            let phase = medium_vertex(path, out, at, anisotropy, albedo);
            (path.ray.at(at), -path.ray.dir, &*made.insert(phase), None)
        }
    };
    let at = (p, ng, hit.as_ref());
    scatter_at::<true, R>(ctx, path, strategies, at, bsdf, s, out, recorder)
}

/// A scattering point `at` along the path's ray in a medium: recorded for the AOVs; its
/// phase function is the "BSDF", whose frame's "normal" faces where the path came from
/// (wo = +z).
fn medium_vertex(path: &PathState, out: &mut PathSample, at: f32, g: f32, albedo: Vec3) -> Bsdf {
    path.first_hit(out, at, -path.ray.dir, albedo, NO_OBJECT);
    Bsdf::Phase { g }
}

/// The surface `hit` of the path's ray: records it for the AOVs and gathers its emission;
/// returns its point, geometric normal and BSDF (the material's, or with its textures read,
/// made in `textured`), or `None` when the path met the black back of a one-sided material,
/// where it ends. A reference rather than a `Cow`: moving a `Cow<Bsdf>` out through the
/// return stalled the store buffer and slowed the Cornell box by 9%; inlined, so the point
/// and normal stay in registers. `FULL` as for [`scatter_at`]: the plain loop's scenes have no
/// touching surfaces and no normal maps.
#[inline(always)]
fn surface_emission<'b, const FULL: bool>(
    ctx: &'b Context,
    path: &mut PathState,
    strategies: &Option<Strategies>,
    hit: &Hit,
    textured: &'b mut Option<Bsdf>,
    out: &mut PathSample,
) -> Option<(Vec3, Vec3, &'b Bsdf)> {
    let (dir, time) = (path.ray.dir, path.ray.time);
    let surface = ctx.scene.surface(hit, time);
    let (p, ng) = (surface.p, surface.ng);
    let material = ctx.scene.material(hit.triangle);
    let cos_o = -dir.dot(ng);
    let black = material.black_from(cos_o);
    if FULL && ctx.scene.contacts.touches(hit) {
        path.touching = hit.triangle;
    }
    let bsdf = match material.textured() {
        true => textured_bsdf(ctx, path, hit, (ng, surface.area_scale), material, textured),
        false => {
            if FULL {
                path.mapped_normal = ctx.scene.shading_normal(hit, time, ng);
            }
            &material.bsdf
        }
    };
    // Checked here too, so later bounces skip the albedo and object lookups.
    if path.bounce == 0 || path.guides_follow {
        record_first_hit(ctx, path, out, hit, (ng, cos_o, black), bsdf);
    }
    if material.emits() && material.emits_towards(cos_o) {
        let le = match material.emission_map() {
            None => material.emission,
            Some(_) => ctx.scene.emitted_at(hit.triangle, hit.b1, hit.b2),
        };
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
    (!black).then_some((p, ng, bsdf))
}

/// Records the camera path's first hit (`hit`, geometric normal `ng` at cosine `cos_o` with
/// the way back, a `black` back side, `bsdf`) for alpha, depth, object IDs and the guides, or,
/// past mirror-like surfaces, the guides alone: the albedo (times the throughput, which holds
/// the glass's tint) and the shading normal facing the way back.
#[inline(never)]
fn record_first_hit(
    ctx: &Context,
    path: &mut PathState,
    out: &mut PathSample,
    hit: &Hit,
    (ng, cos_o, black): (Vec3, f32, bool),
    bsdf: &Bsdf,
) {
    let shading = path.mapped_normal.unwrap_or(ng);
    let facing = if cos_o >= 0.0 { shading } else { -shading };
    let albedo = if black { Vec3::ZERO } else { bsdf.albedo() };
    if path.bounce == 0 {
        let object = ctx.scene.object_at(hit);
        path.first_hit(out, hit.t, facing, albedo, object);
    } else if let Some(first) = &mut out.first {
        // The throughput without the radiance compression of entering glass.
        first.albedo = (path.beta * path.eta_scale * albedo).min(Vec3::ONE);
        first.normal = facing;
    }
    path.guides_follow = bsdf.is_delta();
}

/// The BSDF of the textured `material` where the path's ray met `hit` (of geometric normal `ng`
/// and `area_scale` there: values, so the caller's surface point stays in registers), its
/// textures read at the hit's UV over the ray cone's footprint there, made in `slot` (the
/// material's own where the mesh has no UVs); the shading normal (the mesh's smooth normal,
/// bent by the normal map around it) goes to [`PathState::mapped_normal`].
#[inline(never)]
fn textured_bsdf<'b>(
    ctx: &'b Context,
    path: &mut PathState,
    hit: &Hit,
    (ng, area_scale): (Vec3, f32),
    material: &'b Material,
    slot: &'b mut Option<Bsdf>,
) -> &'b Bsdf {
    path.mapped_normal = ctx.scene.shading_normal(hit, path.ray.time, ng);
    let Some((uv, per_metre)) = ctx.scene.uv_at(hit, path.ray.time, area_scale) else {
        return &material.bsdf;
    };
    let cos = path.ray.dir.dot(ng).abs().max(GRAZING_COS);
    let footprint = path.width + path.spread * (path.travelled + hit.t);
    let at = Lookup {
        uv,
        width: footprint * per_metre / cos,
    };
    let textures = ctx.scene.textures.list();
    if let Some(local) = material.normal_at(textures, &at) {
        let tangents = ctx.scene.tangents(hit, path.ray.time);
        let around = path.mapped_normal.unwrap_or(ng);
        let mapped = tangents.and_then(|t| tangent_to_world(local, t, around));
        path.mapped_normal = mapped.or(path.mapped_normal);
    }
    slot.insert(material.bsdf_at(textures, &at))
}

/// The tangent-space normal `local` in world space, on the tangent frame of ∂p/∂u and ∂p/∂v
/// made orthonormal around the unit normal `n` (the smooth or geometric normal; keeping the
/// frame's handedness); `None` where the derivatives are degenerate.
fn tangent_to_world(local: Vec3, (dpdu, dpdv): (Vec3, Vec3), n: Vec3) -> Option<Vec3> {
    let t = (dpdu - n * n.dot(dpdu)).try_normalize()?;
    let b = n.cross(t);
    let b = if b.dot(dpdv) < 0.0 { -b } else { b };
    (t * local.x + b * local.y + n * local.z).try_normalize()
}

/// The shading normal from a mapped normal `mapped` (turned to the side `n`, the geometric
/// normal on the side the path arrived from): bent towards `n` as little as needed for the
/// mirror reflection of `wo` (towards where the path came from) to leave above the surface,
/// so a normal map never sends light into the surface or lets it through (Cycles does the
/// same).
fn bent_normal(mapped: Vec3, n: Vec3, wo: Vec3) -> Vec3 {
    let floor = (0.9 * wo.dot(n)).min(0.01);
    let leaves_above = |m: Vec3| {
        let c = wo.dot(m);
        c > 0.0 && (m * (2.0 * c) - wo).dot(n) >= floor
    };
    if leaves_above(mapped) {
        return mapped;
    }
    let towards = |k: f32| mapped.lerp(n, k).normalize_or(n);
    let (mut lo, mut hi) = (0.0f32, 1.0f32);
    for _ in 0..12 {
        let mid = 0.5 * (lo + hi);
        if leaves_above(towards(mid)) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    towards(hi)
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
    (p, ng, hit): (Vec3, Vec3, Option<&Hit>),
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
    if path.bounce == 0 {
        out.emitted = Some(out.radiance);
    }
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
    if ctx.scene.textures.has_any() {
        path.widen_cone(p, bsdf.is_delta());
    }

    // Shade on the side the path arrived from.
    let (n, side) = if -dir.dot(ng) >= 0.0 {
        (ng, Side::Front)
    } else {
        (-ng, Side::Back)
    };
    let (frame, bent) = path.shading_frame::<FULL>(n, side, -dir);
    let wo = frame.to_local(-dir);
    // Light selection sees the shading frame's normal: where it leans over the geometric one
    // (a coarse smooth mesh where light grazes), light from under the triangle's plane still
    // reaches the point ([`Shading::shadow_origin`]), and none comes from under the frame's.
    let receiver = Receiver {
        p,
        n: (!bsdf.transmits()).then_some(frame.n),
        time,
    };

    // Bounces from opaque rough surfaces may be aimed at openings.
    let aims = FULL && !bsdf.is_delta() && !bsdf.transmits();
    let guidance = if FULL {
        ctx.bounce_guide.and_then(|g| g.at(p))
    } else {
        None
    };
    let shading = Shading {
        receiver: &receiver,
        ng,
        frame: &frame,
        bent,
        wo,
        bsdf,
        side,
        aim: guidance.and_then(|g| g.aim.as_ref()).filter(|_| aims),
        brought: guidance.map_or(0.0, |g| g.brought),
        hit,
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
        // The plain loop has no strategies through openings: said outright, its `None` is not
        // copied through the stack with the space it never holds.
        let (space, q) = match (&*strategies, &ctx.through) {
            (Some(strategies), Some(view)) if FULL => strategies.pick(view, u_strategy),
            _ => (None, 1.0),
        };
        let through = path.lit_through || space.is_some_and(|s| s.chain.teleports() > 0);
        let space = space.as_ref();
        let beta = path.beta;
        let gather = |light, group| out.gather(beta * light, through, group);
        next_event::<FULL, R>(
            ctx,
            &shading,
            space,
            q,
            u_light,
            u_technique,
            recorder,
            gather,
        );
        if R::RECORDS && aims {
            recorder.bounce(p, path.bounce, path.beta, out.radiance);
        }
        let branches = ctx.scene.settings.indirect_samples;
        if path.bounce == 0 && branches > 1 && !R::RECORDS {
            split::<FULL, R>(ctx, path, strategies, &shading, branches, s, out, recorder);
            let (u_bsdf, u_lobe, u_roulette) = branch_numbers(s);
            return continue_path::<FULL>(ctx, path, &shading, u_bsdf, u_lobe, u_roulette);
        }
    }
    continue_path::<FULL>(ctx, path, &shading, u_bsdf, u_lobe, u_roulette)
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
        if continue_path::<FULL>(ctx, &mut branch, at, u_bsdf, u_lobe, u_roulette) {
            follow::<FULL, R>(ctx, branch, *strategies, &mut stream, out, recorder);
        }
    }
    *s = s.branch(0, n);
}

/// The bounce at `at` that continues the path, drawn with `u_bsdf` and `u_lobe` (from the
/// BSDF, or aimed at an opening where `at` aims), then roulette with `u_roulette`. False when
/// the path ends there.
#[inline(always)]
fn continue_path<const FULL: bool>(
    ctx: &Context,
    path: &mut PathState,
    at: &Shading,
    u_bsdf: glam::Vec2,
    u_lobe: f32,
    u_roulette: f32,
) -> bool {
    let drawn = match at.aim {
        Some(aim) if FULL => aimed_bounce(&ctx.scene.portals, at, aim, u_bsdf, u_lobe),
        _ => at.bsdf.sample(at.wo, u_bsdf, u_lobe, at.side),
    };
    let Some(bs) = drawn else {
        return false;
    };
    let (wi, weight) = (Vec3::from(bs.wi), Vec3::from(bs.weight));
    path.beta *= weight;
    path.eta_scale *= bs.eta * bs.eta;
    path.prev_pdf = bs.pdf;
    path.prev_delta = bs.delta;
    path.prev_receiver = *at.receiver;
    // The side comes from the direction before its normalisation, which has the same sign,
    // so the new origin does not wait on the square root.
    let towards = at.frame.to_world(wi);
    // A bounce the geometry puts under the surface would meet the surface itself again (a
    // flat face whose normals lean), so it ends; light sampling alone brings light from there
    // ([`Shading::shadow_origin`]).
    if at.bent && at.crosses_wrongly(wi, towards) {
        return false;
    }
    let origin = at.origin_towards(towards);
    let dir = towards.normalize();
    path.ray = Ray::new(origin, dir, f32::INFINITY, at.receiver.time);
    path.chain = Chain::default();
    path.coins = 1.0;
    path.travelled = 0.0;
    path.crossings = 0;
    if FULL && path.bounce == 0 {
        path.pixel_worth = at.brought;
    }
    path.bounce += 1;
    if path.bounce >= ROULETTE_AFTER {
        let terms = match FULL {
            true => roulette_terms(ctx, at.brought, path.pixel_worth),
            false => RouletteTerms::ORDINARY,
        };
        let survive = (path.beta.max_element() * path.eta_scale * terms.worth / terms.threshold)
            .min(ROULETTE_MAX_SURVIVAL);
        if survive <= 0.0 {
            return false;
        }
        let survive = survive.max(terms.least);
        if u_roulette >= survive {
            return false;
        }
        path.beta /= survive;
    }
    true
}

/// What roulette weighs a path's throughput by, the threshold it compares it with and the
/// least survival probability it gives.
struct RouletteTerms {
    worth: f32,
    threshold: f32,
    least: f32,
}

impl RouletteTerms {
    /// The plain rule: throughput against [`ROULETTE_THRESHOLD`], no least survival.
    const ORDINARY: Self = Self {
        worth: 1.0,
        threshold: ROULETTE_THRESHOLD,
        least: 0.0,
    };
}

/// Roulette's terms where what the bounce guide learned is known: a bounce brings back `here`
/// where the path is and `pixel` where its camera path first bounced, each per unit of
/// throughput. The factor is their ratio: roulette keeps a path whose throughput is small but
/// which has reached a much brighter place (a dim room's path that went through a window into a
/// lit one), instead of killing nearly all such paths and giving the few survivors the weight
/// of a firefly, and ends sooner those that wander where little light is. The threshold is
/// lowered for a pixel that is dim against the scene's brightest places: its light comes from
/// long paths into them, which are worth following. On `bounce_through`, lowering it by 1
/// (none), 4, 16, 64 and 1000 gave efficiencies of 1.7, 4.1, 6.4, 6.3 and 1.9 (1/(relMSE·s),
/// 32 spp); on `hall_of_mirrors`, whose pixels are as bright as its brightest places, lowering
/// it by 16 cost 25%. What was learned is an estimate over a region, and where it is low for a
/// path that is about to find light the survivor's weight would be a firefly: survival is at
/// least [`ROULETTE_GUIDED_LEAST_SURVIVAL`] (see there). The ordinary rule where either is
/// unknown. Any survival probability keeps roulette unbiased.
#[inline]
fn roulette_terms(ctx: &Context, here: f32, pixel: f32) -> RouletteTerms {
    let brightest = ctx.bounce_guide.map_or(0.0, |g| g.brightest());
    if !(here > 0.0 && pixel > 0.0) {
        return RouletteTerms::ORDINARY;
    }
    let worth = (here / pixel).clamp(1.0 / ROULETTE_MOST_WORTH, ROULETTE_MOST_WORTH);
    let lowered = (brightest / pixel).clamp(1.0, ROULETTE_MOST_LOWERED);
    RouletteTerms {
        worth,
        threshold: ROULETTE_THRESHOLD / lowered,
        least: ROULETTE_GUIDED_LEAST_SURVIVAL,
    }
}

/// A bounce at `at` from the mixture `aim` sets: towards an opening with probability
/// `aim.share` (the part of `u_lobe` below it picking the opening), else from the BSDF (the
/// rest of `u_lobe` choosing its lobe); its weight and density are the mixture's. A lobe
/// that is a mirror keeps its own delta density, its weight divided by the BSDF's share.
#[inline(never)]
fn aimed_bounce(
    portals: &Portals,
    at: &Shading,
    aim: &Aim,
    u: glam::Vec2,
    u_lobe: f32,
) -> Option<BsdfSample> {
    let (p, time) = (at.receiver.p, at.receiver.time);
    if u_lobe < aim.share {
        let dir = aim.sample(portals, time, p, u_lobe / aim.share, u)?;
        let wi = at.frame.to_local(dir);
        let f = at.bsdf.eval(at.wo, wi, at.side);
        let pdf = at.bounce_pdf(portals, wi, dir);
        return (f != Vec3::ZERO && pdf > 0.0).then_some(BsdfSample {
            wi: wi.into(),
            weight: (f / pdf).into(),
            pdf,
            delta: false,
            eta: 1.0,
        });
    }
    let u_lobe = ((u_lobe - aim.share) / (1.0 - aim.share)).min(ONE_BELOW);
    let mut bs = at.bsdf.sample(at.wo, u, u_lobe, at.side)?;
    if bs.delta {
        bs.weight /= 1.0 - aim.share;
        return Some(bs);
    }
    let f = bs.weight * bs.pdf;
    let dir = at.frame.to_world(bs.wi.into());
    bs.pdf = aim.mixed(bs.pdf, aim.pdf(portals, time, p, dir));
    bs.weight = f / bs.pdf;
    Some(bs)
}

/// The largest f32 below 1.
const ONE_BELOW: f32 = 1.0 - f32::EPSILON / 2.0;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rift_fx::Shot;
    use crate::sampling::hash32;
    use crate::scene::Scene;

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
