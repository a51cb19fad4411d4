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

use crate::geometry::offset_origin;
use crate::lights::{LightPlace, LightSource, Receiver};
use crate::material::{Bsdf, Side};
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

/// Traces one path from `origin` along unit `dir` at time `time` (seconds). The camera ray
/// sees only ray parameters within `camera_range` (its clipping interval).
pub fn trace(
    scene: &Scene,
    mut origin: Vec3,
    mut dir: Vec3,
    mut time: f64,
    camera_range: (f32, f32),
    s: &mut SampleStream,
) -> PathSample {
    let mut out = PathSample::default();
    let mut beta = Vec3::ONE;
    // Solid-angle pdf of the BSDF sample that produced `dir` (MIS against light sampling);
    // camera rays and specular bounces count as delta.
    let mut prev_pdf = 0.0f32;
    let mut prev_delta = true;
    // The last scattering point, as light selection saw it (for the MIS weight of emitters
    // that BSDF sampling finds).
    let mut prev_receiver = Receiver {
        p: origin,
        n: None,
        time,
    };
    let mut bounce = 0u32;
    // Product of η² over refractions, so roulette sees the throughput without the radiance
    // compression of entering or leaving glass.
    let mut eta_scale = 1.0f32;
    // Ray parameters the current ray may hit (clipping applies to the camera ray only).
    let mut range = camera_range;
    // Teleports since the last scattering event, and the camera ray's distance to its first
    // opening.
    let mut chain = 0u32;
    let mut opening_t: Option<f32> = None;
    let portals = &scene.portals;
    'path: loop {
        let class = match (bounce, chain) {
            (0, 0) => RayClass::Camera,
            (0, _) => RayClass::ThroughPortal,
            _ => RayClass::Indirect,
        };
        let hit = intersect_range(scene, origin, dir, range, time, class);
        if !portals.is_empty() {
            // Openings before the surface: each teleports with its opacity's probability.
            let limit = hit.map_or(range.1, |h| h.t() * (1.0 + PORTAL_TIE));
            let mut from = range.0;
            while let Some(ph) = portals.intersect(origin, dir, from, limit, time) {
                let look = portals.look(ph.opening);
                if look.opacity < 1.0 && s.uniform() >= look.opacity {
                    from = ph.t;
                    continue;
                }
                if bounce == 0 && opening_t.is_none() {
                    opening_t = Some(ph.t);
                }
                if chain >= scene.settings.max_portal_depth {
                    if bounce == 0 {
                        out.first = Some(FirstHit {
                            t: opening_t.unwrap_or(ph.t),
                            normal: -dir,
                            albedo: Vec3::ZERO,
                        });
                    }
                    break 'path;
                }
                time = portals.exit_time(ph.opening, time);
                let Some(next) = portals.teleport(&ph, dir, time) else {
                    break 'path;
                };
                beta *= look.tint;
                chain += 1;
                if bounce == 0 {
                    out.portal_depth += 1;
                }
                (origin, dir) = (next.origin, next.direction);
                range = (0.0, f32::INFINITY);
                continue 'path;
            }
        }
        // Emission found by BSDF sampling gets the full weight when light sampling could not
        // have found it: after a delta bounce, or through an opening.
        let unweighted = prev_delta || chain > 0;
        let Some(hit) = hit else {
            if let Some(env) = &scene.lights.environment {
                let weight = if unweighted {
                    1.0
                } else {
                    power_heuristic(prev_pdf, scene.lights.pdf_environment(dir))
                };
                out.radiance += beta * env.radiance(dir) * weight;
            }
            break;
        };
        let hit = match hit {
            SceneHit::Surface(h) => h,
            SceneHit::Strand(h) => {
                // Strands glow and absorb: their emission ends the path.
                let weight = if unweighted {
                    1.0
                } else {
                    let pdf_area = scene.lights.pdf_strand(
                        h.segment,
                        h.s,
                        h.normal,
                        &prev_receiver,
                        &scene.strands,
                    );
                    power_heuristic(prev_pdf, pdf_area * h.t * h.t / h.normal.dot(dir).abs())
                };
                out.radiance += beta * scene.strands.radiance(h.segment, h.s) * weight;
                if bounce == 0 {
                    out.first = Some(FirstHit {
                        t: opening_t.unwrap_or(h.t),
                        normal: if h.normal.dot(dir) <= 0.0 {
                            h.normal
                        } else {
                            -h.normal
                        },
                        albedo: Vec3::ZERO,
                    });
                }
                break;
            }
        };
        let surface = scene.surface(&hit, time);
        let (p, ng) = (surface.p, surface.ng);
        let material = scene.material(hit.triangle);
        let cos_o = -dir.dot(ng);
        if bounce == 0 {
            out.first = Some(FirstHit {
                t: opening_t.unwrap_or(hit.t),
                normal: if cos_o >= 0.0 { ng } else { -ng },
                albedo: material.bsdf.albedo(),
            });
        }

        if material.emits() {
            let le = material.emitted(cos_o);
            if le != Vec3::ZERO {
                let weight = if unweighted {
                    1.0
                } else {
                    let pdf_light =
                        scene
                            .lights
                            .pdf_triangle(hit.triangle, surface.area_scale, &prev_receiver)
                            * hit.t
                            * hit.t
                            / cos_o.abs();
                    power_heuristic(prev_pdf, pdf_light)
                };
                out.radiance += beta * le * weight;
            }
        }
        // Dimensions of this bounce, drawn whether or not they are used.
        let [lx, ly, bx, by] = s.next_4d();
        let [u_roulette, u_lobe, _, _] = s.uniform_4d();
        let (u_light, u_bsdf) = (glam::Vec2::new(lx, ly), glam::Vec2::new(bx, by));
        if scene.settings.max_bounces.is_some_and(|m| bounce >= m) {
            break;
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
            out.radiance += beta * next_event(scene, &shading, u_light);
        }
        let Some(bs) = bsdf.sample(wo, u_bsdf, u_lobe, side) else {
            break;
        };
        beta *= bs.weight;
        eta_scale *= bs.eta * bs.eta;
        prev_pdf = bs.pdf;
        prev_delta = bs.delta;
        prev_receiver = receiver;
        dir = frame.to_world(bs.wi).normalize();
        origin = offset_origin(p, if dir.dot(ng) > 0.0 { ng } else { -ng });
        range = (0.0, f32::INFINITY);
        chain = 0;
        bounce += 1;
        if bounce >= ROULETTE_AFTER {
            let survive =
                (beta.max_element() * eta_scale / ROULETTE_THRESHOLD).min(ROULETTE_MAX_SURVIVAL);
            if survive <= 0.0 || u_roulette >= survive {
                break;
            }
            beta /= survive;
        }
    }
    out
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
    let through = if scene.portals.is_empty() {
        1.0
    } else {
        scene.portals.transmittance(from, shadow_dir, dist, time)
    };
    if through == 0.0 || scene.occluded(from, shadow_dir, dist, time) {
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

/// The closest surface or strand a ray of `class` sees along `origin + t·dir` for t within
/// `range`.
#[inline]
fn intersect_range(
    scene: &Scene,
    origin: Vec3,
    dir: Vec3,
    range: (f32, f32),
    time: f64,
    class: RayClass,
) -> Option<SceneHit> {
    if range.0 <= 0.0 {
        return scene.intersect(origin, dir, range.1, time, class);
    }
    let hit = scene.intersect(origin + dir * range.0, dir, range.1 - range.0, time, class)?;
    Some(match hit {
        SceneHit::Surface(mut h) => {
            h.t += range.0;
            SceneHit::Surface(h)
        }
        SceneHit::Strand(mut h) => {
            h.t += range.0;
            SceneHit::Strand(h)
        }
    })
}
