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
//! Shadow rays cannot follow a teleport yet, so a teleport region blocks them in proportion to
//! its opacity, and light reached by BSDF sampling after a teleport gets the full MIS weight
//! (light sampling could not have found it): the estimate stays unbiased, only noisier.

use crate::geometry::Hit;
use crate::geometry::offset_origin;
use crate::lights::{Found, LightPlace, LightSource, Receiver};
use crate::material::{Bsdf, Side};
use crate::ray::Ray;
use crate::sampling::{Frame, SampleStream, power_heuristic};
use crate::scene::{Scene, SceneHit};
use crate::visibility::RayClass;
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

/// What one camera path returns.
#[derive(Clone, Copy, Debug, Default)]
pub struct PathSample {
    pub radiance: Vec3,
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
}

/// A path between events: the ray it follows and what it carries from its last scattering
/// event.
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
    /// Teleports since the last scattering event.
    chain: u32,
    /// The camera ray's distance to its first opening.
    opening_t: Option<f32>,
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
            chain: 0,
            opening_t: None,
        }
    }

    /// Who the current ray is, for visibility flags.
    fn class(&self) -> RayClass {
        match (self.bounce, self.chain) {
            (0, 0) => RayClass::Camera,
            (0, _) => RayClass::ThroughPortal,
            _ => RayClass::Indirect,
        }
    }

    /// The MIS weight of emission the current ray found, whose light-sampling solid-angle pdf
    /// `pdf_light` gives. It is 1 when light sampling could not have found it: after a delta
    /// bounce, or through an opening.
    fn emission_weight(&self, pdf_light: impl FnOnce() -> f32) -> f32 {
        if self.prev_delta || self.chain > 0 {
            1.0
        } else {
            power_heuristic(self.prev_pdf, pdf_light())
        }
    }

    /// Records the camera ray's first surface (or opening) for the AOVs.
    fn first_hit(&self, out: &mut PathSample, t: f32, normal: Vec3, albedo: Vec3) {
        if self.bounce == 0 {
            out.first = Some(FirstHit {
                t: self.opening_t.unwrap_or(t),
                normal,
                albedo,
            });
        }
    }
}

/// What became of a ray at the openings in front of its hit.
enum Crossing {
    /// It passed every opening (or met none): the hit stands.
    Passed,
    /// It teleported: the path continues along the new ray.
    Teleported,
    /// The path ends at an opening (the depth limit, or total reflection at its exit).
    Ended,
}

/// Follows the path's ray through the openings before `hit_t` (its hit, or `None` if it
/// escapes): each meets a teleport with its opacity's probability, else the ray passes. A
/// teleport updates the path's ray, time, throughput and chain.
fn cross_openings(
    scene: &Scene,
    path: &mut PathState,
    hit_t: Option<f32>,
    s: &mut SampleStream,
    out: &mut PathSample,
) -> Crossing {
    let portals = &scene.portals;
    if portals.is_empty() {
        return Crossing::Passed;
    }
    let ray = path.ray;
    let limit = hit_t.map_or(ray.t_max, |t| t * (1.0 + PORTAL_TIE));
    let mut from = ray.t_min;
    while let Some(ph) = portals.intersect(&ray.between(from, limit)) {
        let look = portals.look(ph.opening);
        if look.opacity < 1.0 && s.uniform() >= look.opacity {
            from = ph.t;
            continue;
        }
        if path.bounce == 0 && path.opening_t.is_none() {
            path.opening_t = Some(ph.t);
        }
        if path.chain >= scene.settings.max_portal_depth {
            path.first_hit(out, ph.t, -ray.dir, Vec3::ZERO);
            return Crossing::Ended;
        }
        let time = portals.exit_time(ph.opening, ray.time);
        let Some(next) = portals.teleport(&ph, ray.dir, time) else {
            return Crossing::Ended;
        };
        path.beta *= look.tint;
        path.chain += 1;
        if path.bounce == 0 {
            out.portal_depth += 1;
        }
        path.ray = Ray::new(next.origin, next.direction, f32::INFINITY, time);
        return Crossing::Teleported;
    }
    Crossing::Passed
}

/// Traces one path along `camera_ray`, whose range is the camera's clipping interval.
pub fn trace(scene: &Scene, camera_ray: Ray, s: &mut SampleStream) -> PathSample {
    let mut out = PathSample::default();
    let mut path = PathState::camera(camera_ray);
    loop {
        let hit = scene.intersect(&path.ray, path.class());
        match cross_openings(scene, &mut path, hit.map(|h| h.t()), s, &mut out) {
            Crossing::Passed => {}
            Crossing::Teleported => continue,
            Crossing::Ended => break,
        }
        let dir = path.ray.dir;
        let Some(hit) = hit else {
            if let Some(env) = &scene.lights.environment {
                let weight = path.emission_weight(|| scene.lights.pdf_environment(dir));
                out.radiance += path.beta * env.radiance(dir) * weight;
            }
            break;
        };
        let hit = match hit {
            SceneHit::Surface(h) => h,
            SceneHit::Strand(h) => {
                // Strands glow and absorb: their emission ends the path.
                let found = Found::Strand {
                    segment: h.segment,
                    s: h.s,
                    normal: h.normal,
                };
                let weight = path.emission_weight(|| {
                    scene
                        .lights
                        .pdf_found(found, &path.prev_receiver, dir, h.t, &scene.strands)
                });
                out.radiance += path.beta * scene.strands.radiance(h.segment, h.s) * weight;
                let facing = if h.normal.dot(dir) <= 0.0 {
                    h.normal
                } else {
                    -h.normal
                };
                path.first_hit(&mut out, h.t, facing, Vec3::ZERO);
                break;
            }
        };
        if !scatter(scene, &mut path, &hit, s, &mut out) {
            break;
        }
    }
    out
}

/// Shades the surface `hit` of the path's ray: its emission, light sampling, and the BSDF
/// sample that continues the path (with roulette). False when the path ends there.
fn scatter(
    scene: &Scene,
    path: &mut PathState,
    hit: &Hit,
    s: &mut SampleStream,
    out: &mut PathSample,
) -> bool {
    let (dir, time) = (path.ray.dir, path.ray.time);
    let surface = scene.surface(hit, time);
    let (p, ng) = (surface.p, surface.ng);
    let material = scene.material(hit.triangle);
    let cos_o = -dir.dot(ng);
    path.first_hit(
        out,
        hit.t,
        if cos_o >= 0.0 { ng } else { -ng },
        material.bsdf.albedo(),
    );

    if material.emits() {
        let le = material.emitted(cos_o);
        if le != Vec3::ZERO {
            let found = Found::Triangle {
                triangle: hit.triangle,
                area_scale: surface.area_scale,
                normal: ng,
            };
            let weight = path.emission_weight(|| {
                scene
                    .lights
                    .pdf_found(found, &path.prev_receiver, dir, hit.t, &scene.strands)
            });
            out.radiance += path.beta * le * weight;
        }
    }
    // Dimensions of this bounce, drawn whether or not they are used.
    let [lx, ly, bx, by] = s.next_4d();
    let [u_roulette, u_lobe, _, _] = s.uniform_4d();
    let (u_light, u_bsdf) = (glam::Vec2::new(lx, ly), glam::Vec2::new(bx, by));
    if scene.settings.max_bounces.is_some_and(|m| path.bounce >= m) {
        return false;
    }

    // Shade on the side the path arrived from.
    let (n, side) = if cos_o >= 0.0 {
        (ng, Side::Front)
    } else {
        (-ng, Side::Back)
    };
    let frame = Frame::new(n);
    let wo = frame.to_local(-dir);
    let bsdf = &material.bsdf;
    let receiver = Receiver {
        p,
        n: (!bsdf.transmits()).then_some(n),
        time,
    };

    if !bsdf.is_delta() {
        let shading = Shading {
            receiver,
            ng,
            frame: &frame,
            wo,
            bsdf,
            side,
        };
        out.radiance += path.beta * next_event(scene, &shading, u_light);
    }
    let Some(bs) = bsdf.sample(wo, u_bsdf, u_lobe, side) else {
        return false;
    };
    path.beta *= bs.weight;
    path.eta_scale *= bs.eta * bs.eta;
    path.prev_pdf = bs.pdf;
    path.prev_delta = bs.delta;
    path.prev_receiver = receiver;
    let dir = frame.to_world(bs.wi).normalize();
    let origin = offset_origin(p, if dir.dot(ng) > 0.0 { ng } else { -ng });
    path.ray = Ray::new(origin, dir, f32::INFINITY, time);
    path.chain = 0;
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
    receiver: Receiver,
    /// Geometric normal.
    ng: Vec3,
    /// Shading frame (around the normal on the side the path arrived from).
    frame: &'a Frame,
    /// Direction towards where the path came from, local.
    wo: Vec3,
    bsdf: &'a Bsdf,
    side: Side,
}

/// Next-event estimation: light arriving at `at` (at its time) from one light sample drawn
/// with `u`, MIS weighted against BSDF sampling (power heuristic), before the path throughput.
fn next_event(scene: &Scene, at: &Shading, u: glam::Vec2) -> Vec3 {
    let time = at.receiver.time;
    let Some(light) = scene.lights.sample(
        u,
        &at.receiver,
        |e| scene.world_triangle(e.triangle, e.instance, time),
        &scene.strands,
    ) else {
        return Vec3::ZERO;
    };
    let p = at.receiver.p;
    // Direction, the point the shadow ray must reach (None: infinitely far) and the solid-angle
    // pdf of the light sample.
    let (wi_world, target, pdf_light) = match light.place {
        LightPlace::Direction(d) => (d, None, light.pdf),
        LightPlace::Point {
            point,
            normal,
            two_sided,
            source,
        } => {
            if let LightSource::Triangle(triangle) = source
                && scene.visibility.culled(triangle, point, time)
            {
                return Vec3::ZERO;
            }
            let cos_raw = (p - point).dot(normal);
            if !(cos_raw > 0.0 || (two_sided && cos_raw < 0.0)) {
                return Vec3::ZERO;
            }
            let light_side = if cos_raw > 0.0 { normal } else { -normal };
            let to = point - p;
            let dist2 = to.length_squared();
            let wi = to / dist2.sqrt();
            (
                wi,
                Some(offset_origin(point, light_side)),
                light.pdf * dist2 / wi.dot(light_side).abs(),
            )
        }
    };
    let wi = at.frame.to_local(wi_world);
    let f = at.bsdf.eval(at.wo, wi, at.side);
    if f == Vec3::ZERO {
        return Vec3::ZERO;
    }
    // The shadow ray leaves from the side of the surface it goes to.
    let ng = at.ng;
    let from = offset_origin(p, if wi_world.dot(ng) > 0.0 { ng } else { -ng });
    let (shadow_dir, dist) = match target {
        Some(t) => {
            let d = t - from;
            let len = d.length();
            (d / len, len)
        }
        None => (wi_world, f32::INFINITY),
    };
    let shadow = Ray::new(from, shadow_dir, dist, time);
    let through = if scene.portals.is_empty() {
        1.0
    } else {
        scene.portals.transmittance(&shadow)
    };
    if through == 0.0 || scene.occluded(&shadow) {
        return Vec3::ZERO;
    }
    // An emitter hidden from indirect rays cannot be found by BSDF sampling.
    let bsdf_can_find = match light.place {
        LightPlace::Point {
            source: LightSource::Triangle(triangle),
            ..
        } => scene.visibility.sees(triangle, RayClass::Indirect),
        LightPlace::Point {
            source: LightSource::Strand(segment),
            ..
        } => scene.strand_sees(segment, RayClass::Indirect),
        LightPlace::Direction(_) => true,
    };
    let weight = if bsdf_can_find {
        power_heuristic(pdf_light, at.bsdf.pdf(at.wo, wi, at.side))
    } else {
        1.0
    };
    f * light.radiance * (weight * through / pdf_light)
}
