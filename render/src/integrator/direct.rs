//! Next-event estimation: one light sample for a shading point, drawn by ordinary light
//! sampling or in the space beyond a chain of openings ([`crate::through`]), its shadow ray
//! traced ([`super::shadow`]), weighed against BSDF sampling by MIS.

use super::shadow::{ShadowEnd, plain_shadow, shadow};
use super::{Context, LightRecord, Recorder};
use crate::geometry::{Hit, offset_origin, offset_target};
use crate::lights::SkyPart;
use crate::lights::emitters::{LightPlace, LightSample, LightSource, Receiver};
use crate::material::bsdf::{Bsdf, Side};
use crate::portals::Portals;
use crate::portals::visibility::RayClass;
use crate::sampling::{Frame, power_heuristic};
use crate::scene::Scene;
use crate::through::{Aim, aperture_sampling};
use crate::through::{Chain, Space};
use glam::{Vec3, Vec3A};

/// A surface point being shaded, as next-event estimation needs it.
pub(super) struct Shading<'a> {
    /// The point, with its normal when it only reflects.
    pub(super) receiver: &'a Receiver,
    /// Geometric normal.
    pub(super) ng: Vec3,
    /// Shading frame (around the normal on the side the path arrived from, or a normal map's
    /// normal bent towards it).
    pub(super) frame: &'a Frame,
    /// The frame is a normal map's: directions must be checked against the geometric normal.
    pub(super) bent: bool,
    /// Direction towards where the path came from, local.
    pub(super) wo: Vec3,
    pub(super) bsdf: &'a Bsdf,
    pub(super) side: Side,
    /// Where its bounces are aimed at openings ([`crate::through::bounce_guide`]).
    pub(super) aim: Option<&'a Aim>,
    /// What a bounce here was seen to bring back per unit of throughput (0: unknown), for
    /// roulette.
    pub(super) brought: f32,
    /// The surface hit the point is on (`None` in a medium).
    pub(super) hit: Option<&'a Hit>,
}

impl Shading<'_> {
    /// True when the direction `wi` (local) and `world` (world space) lie on different sides
    /// of the surface in the shading frame and in the geometry: a normal map would carry light
    /// through the surface or into it there, so none goes.
    #[inline]
    pub(super) fn crosses_wrongly(&self, wi: Vec3, world: Vec3) -> bool {
        (wi.z > 0.0) != (world.dot(self.facing_normal()) > 0.0)
    }

    /// The geometric normal on the side the path arrived from.
    #[inline]
    fn facing_normal(&self) -> Vec3 {
        if self.side == Side::Front {
            self.ng
        } else {
            -self.ng
        }
    }

    /// The point just off the surface on the side of the world-space direction `world` (any
    /// length): where a ray that way leaves from.
    #[inline]
    pub(super) fn origin_towards(&self, world: Vec3) -> Vec3 {
        let ng = self.ng;
        offset_origin(self.receiver.p, if world.dot(ng) > 0.0 { ng } else { -ng })
    }

    /// Where a shadow ray towards `wi` (local; `world` in world space) leaves from: the point
    /// just off the surface on the side the ray goes to, and false. Where the shading frame
    /// puts the direction above the surface and the geometry under it (light grazing a coarse
    /// smooth mesh), the smooth surface's point over the hit ([`Scene::smooth_point`]) nudged
    /// off the triangle, and true: the ray then sees past the neighbouring triangles as it
    /// would from that surface (Hanika's terminator offset; Cycles offsets its shadow rays
    /// the same way). `None` where there is no such point (a flat triangle whose normal map
    /// put the direction there) or the frame puts the direction under the surface and the
    /// geometry above it: no light comes from there.
    #[inline]
    pub(super) fn shadow_origin(
        &self,
        scene: &Scene,
        wi: Vec3,
        world: Vec3,
    ) -> Option<(Vec3, bool)> {
        if !(self.bent && self.crosses_wrongly(wi, world)) {
            return Some((self.origin_towards(world), false));
        }
        if wi.z <= 0.0 {
            return None;
        }
        let up = self.facing_normal();
        let smooth = scene.smooth_point(self.hit?, self.receiver.time, up)?;
        Some((offset_origin(smooth, up), true))
    }

    /// The density with which a bounce here draws direction `wi` (local; `world` in world
    /// space): the BSDF's, mixed with the aim at openings where there is one.
    #[inline]
    pub(super) fn bounce_pdf(&self, portals: &Portals, wi: Vec3, world: Vec3) -> f32 {
        let pdf = self.bsdf.pdf(self.wo, wi, self.side);
        match self.aim {
            None => pdf,
            Some(aim) => {
                let (p, time) = (self.receiver.p, self.receiver.time);
                aim.mixed(pdf, aim.pdf(portals, time, p, world))
            }
        }
    }
}

/// Next-event estimation: light arriving at `at` (at its time) from one sample drawn with `u`
/// and `u_technique`, in the space beyond the openings of `space` (`None`: ordinary light
/// sampling), the strategy picked with probability `q`; MIS weighted against BSDF sampling
/// (power heuristic), before the path throughput, handed to `gather` with its light group
/// (part by part where the sky's parts belong to several). `FULL` as for
/// [`super::path`]'s `scatter_at`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn next_event<const FULL: bool, R: Recorder>(
    ctx: &Context,
    at: &Shading,
    space: Option<&Space>,
    q: f32,
    u: glam::Vec2,
    u_technique: f32,
    recorder: &mut R,
    mut gather: impl FnMut(Vec3, u8),
) {
    if q <= 0.0 {
        return;
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
        return;
    };
    let (dir, radiance) = (Vec3::from(incoming.dir), Vec3::from(incoming.radiance));
    let wi = at.frame.to_local(dir);
    let f = at.bsdf.eval(at.wo, wi, at.side);
    if f == Vec3::ZERO {
        learn(0.0);
        return;
    }
    let Some((from, lifted)) = at.shadow_origin(ctx.scene, wi, dir) else {
        learn(0.0);
        return;
    };
    let visible = if FULL {
        let chain = space.map_or(Chain::default(), |s| s.chain);
        shadow(ctx, &chain, from, dir, incoming.end, at.receiver.time)
    } else {
        plain_shadow(ctx, from, dir, incoming.end, at.receiver.time)
    };
    let Some((tint, coins)) = visible else {
        learn(0.0);
        return;
    };
    let pdf_light = q * incoming.pdf;
    // Bounces never leave under the geometry (they would meet their own surface), so light
    // from a direction reached only from the lifted point is light sampling's alone.
    let weight = if incoming.bsdf_can_find && !lifted {
        power_heuristic(
            pdf_light,
            at.bounce_pdf(&ctx.scene.portals, wi, dir) * coins,
        )
    } else {
        1.0
    };
    if FULL && R::RECORDS {
        // What light sampling must bring: its MIS weight leaves out what BSDF sampling finds
        // well (a wide sky, a big lamp close by).
        let brought = f * radiance * tint * (weight * coins / incoming.pdf);
        learn(crate::color::luminance(brought));
    }
    let k = weight * coins / pdf_light;
    let split_sky = FULL
        && incoming.sky
        && ctx
            .scene
            .lights
            .sky
            .as_ref()
            .is_some_and(|s| !s.dome_only());
    if split_sky {
        // The sky was looked up beyond the openings, at that side's time.
        let (dir, time) = match space {
            Some(space) => (space.direction_beyond(dir), space.receiver.time),
            None => (dir, at.receiver.time),
        };
        sky_parts(ctx, dir, time, |light, group| {
            gather(f * light * tint * k, group)
        })
    } else {
        gather(f * radiance * tint * k, incoming.group)
    }
}

/// Hands `gather` the radiance each part of the sky sends from `dir` at `time`, with the
/// part's light group.
#[inline(never)]
fn sky_parts(ctx: &Context, dir: Vec3, time: f64, mut gather: impl FnMut(Vec3, u8)) {
    if let Some(sky) = &ctx.scene.lights.sky {
        sky.each_part(dir, time, RayClass::Indirect, |light, part| {
            gather(light, sky_group(ctx, part))
        });
    }
}

/// The light group of a part of the sky.
pub(super) fn sky_group(ctx: &Context, part: SkyPart) -> u8 {
    match (part, &ctx.scene.lights.sky) {
        (SkyPart::Sun(i), Some(sky)) => sky.suns[i as usize].group,
        _ => ctx.scene.environment_group,
    }
}

/// One sample of light that may reach a point, before its shadow ray. Its vectors are kept in
/// 16-byte lanes, as a light sample's ([`LightPlace`]).
pub(crate) struct Incoming {
    /// Unit direction at the point.
    pub dir: Vec3A,
    pub radiance: Vec3A,
    /// Where the shadow ray must reach (off the emitter's surface, beyond the openings).
    pub end: ShadowEnd,
    /// Solid-angle pdf (of all the strategy's techniques that could draw it).
    pub pdf: f32,
    /// False when rays that scatter cannot see the emitter, so BSDF sampling cannot find it.
    bsdf_can_find: bool,
    /// The light group of the emitter.
    pub group: u8,
    /// A sample of the sky that rays can find (not a single direction), whose parts may
    /// belong to several light groups.
    sky: bool,
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
#[inline(always)]
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
        |triangle, b1, b2| ctx.scene.emitted_at(triangle, b1, b2),
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
    let weight = (crate::color::luminance(light.radiance.into()) / light.pdf) as f64;
    if !weight.is_finite() || weight <= 0.0 {
        return None;
    }
    let none = Chain::default();
    let transmitted = shadow(ctx, &none, at.p, light.dir.into(), light.end, at.time)
        .map_or(0.0, |(_, coins)| coins as f64);
    Some(Probe {
        dir: light.dir.into(),
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
    let dir = space.direction_back(arrival.dir.into());
    let sky = arrival.sky.then_some((at, dir));
    Incoming {
        dir: dir.into(),
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
    let sky = ctx.scene.lights.sky.as_ref()?;
    let (dir, pdf_aperture) =
        aperture_sampling::sample(&ctx.scene.portals, space.first(), at.time, at.p, u)?;
    let beyond = space.direction_beyond(dir);
    let time = space.receiver.time;
    let pdf_light = ctx.lights.pdf_environment(beyond, &space.receiver);
    Some(Incoming {
        dir: dir.into(),
        radiance: sky.radiance(beyond, time).into(),
        end: ShadowEnd::SKY,
        pdf: space.mixture(pdf_light, pdf_aperture),
        bsdf_can_find: true,
        group: ctx.scene.environment_group,
        sky: true,
    })
}

/// How `light` reaches `at`: its direction, target and solid-angle pdf there; `None` when it
/// sends nothing that way (its back, or culled).
#[inline]
fn arrival(ctx: &Context, light: &LightSample, at: &Receiver) -> Option<Incoming> {
    let time = at.time;
    match light.place {
        LightPlace::Direction { dir, part, delta } => Some(Incoming {
            dir,
            radiance: light.radiance,
            end: ShadowEnd::SKY,
            pdf: light.pdf,
            bsdf_can_find: !delta,
            group: sky_group(ctx, part),
            sky: !delta,
        }),
        LightPlace::Punctual { point, source } => {
            let point = Vec3::from(point);
            let to = point - at.p;
            let dist2 = to.length_squared();
            (dist2 > 0.0).then(|| Incoming {
                dir: (to / dist2.sqrt()).into(),
                radiance: light.radiance / dist2,
                end: ShadowEnd {
                    target: Some(point),
                    strand: None,
                },
                pdf: light.pdf,
                bsdf_can_find: false,
                group: source_group(ctx, source),
                sky: false,
            })
        }
        LightPlace::Point {
            point,
            normal,
            two_sided,
            source,
        } => {
            let (point, normal) = (Vec3::from(point), Vec3::from(normal));
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
                dir: dir.into(),
                radiance: light.radiance,
                end: ShadowEnd {
                    target: Some(offset_target(point, light_side)),
                    strand: match source {
                        LightSource::Strand(segment) => Some(segment),
                        _ => None,
                    },
                },
                pdf: light.pdf * dist2 / dir.dot(light_side).abs(),
                bsdf_can_find: bsdf_can_find(ctx, source),
                group: source_group(ctx, source),
                sky: false,
            })
        }
    }
}

/// True when rays that scatter can find `source`, so BSDF sampling may draw its light. Shape
/// lights are found along rays only where no medium could have stopped them first.
#[inline]
fn bsdf_can_find(ctx: &Context, source: LightSource) -> bool {
    let scene = ctx.scene;
    match source {
        LightSource::Triangle(triangle) => scene.visibility.sees(triangle, RayClass::Indirect),
        LightSource::Strand(segment) => scene.strand_sees(segment, RayClass::Indirect),
        LightSource::Shape(k) => {
            let light = &scene.lights.shapes[k as usize];
            !light.is_point() && scene.media.is_empty() && light.flags.sees(RayClass::Indirect)
        }
    }
}

/// The light group of the emitter `source`.
#[inline]
fn source_group(ctx: &Context, source: LightSource) -> u8 {
    match source {
        LightSource::Triangle(triangle) => ctx.scene.triangle_light_group(triangle),
        LightSource::Strand(segment) => ctx.scene.strand_light_group(segment),
        LightSource::Shape(k) => ctx.scene.lights.shapes[k as usize].group,
    }
}
