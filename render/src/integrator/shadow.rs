//! Shadow rays: from a shading point to a light sample's point (or the sky), through the
//! openings of a chain in order, each met inside its mask at the ray's time.

use super::Context;
use super::PORTAL_TIE;
use crate::geometry::Ray;
use crate::through::Chain;
use glam::Vec3;

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
    pub(super) const SKY: Self = Self {
        target: None,
        strand: None,
    };
}

/// [`shadow`] without openings, in a scene of surfaces and lamps alone.
#[inline(always)]
pub(super) fn plain_shadow(
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
#[inline]
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
