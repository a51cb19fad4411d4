//! Rays as the BVH library traverses them. Its wide-node test never accepts a child box nearer
//! than t = 1e-4 (a fixed epsilon in its traversal), which for unit directions drops whatever
//! lies within 0.1 mm of a ray's origin: a box 0.1 mm across vanished, and light leaked into
//! crevices narrower than that. The library is handed the direction scaled by 2^-8, so the cut
//! falls at 0.4 µm; a power-of-two scale is exact, so the comparisons it makes are otherwise
//! the same. (Not further: it clamps direction components below f32::EPSILON, so the scale
//! would bend the boxes' slabs for every nearly axis-parallel ray: 2^-16 missed strands.)
//! Distances cross the boundary through [`to_box_t`] and [`from_box_t`].
//!
//! This costs about 4% on the Cornell box, and not for the reason one would guess: a scale
//! set per ray to put the cut at twice the origin's offset (so a bounce ray skips the leaf of
//! the surface it leaves, as the old cut let it) was slower still. Where the time goes is not
//! yet known; profile before changing it.
//!
//! Negative zeros become positive ones: the library takes a component's side from `d < 0` but
//! the sign of its inverse from the sign bit, so −0.0 made them disagree, and a ray exactly
//! along an axis (−Z, say) missed flat boxes.

use glam::{Vec3, Vec3A};

/// The scale of the direction the library sees.
const SCALE: f32 = 1.0 / 256.0;

/// The ray `origin + t·dir`, t in (0, t_max), as the library traverses it.
#[inline]
pub fn box_ray(origin: Vec3, dir: Vec3, t_max: f32) -> obvhs::ray::Ray {
    obvhs::ray::Ray::new(
        Vec3A::from(origin),
        // Adding +0.0 turns −0.0 into +0.0 and leaves every other value as it is.
        Vec3A::from(dir * SCALE + Vec3::ZERO),
        0.0,
        to_box_t(t_max),
    )
}

/// A ray parameter as the library counts it.
#[inline]
pub fn to_box_t(t: f32) -> f32 {
    t / SCALE
}

/// A ray parameter the library gives back, in the ray's own units.
#[inline]
pub fn from_box_t(t: f32) -> f32 {
    t * SCALE
}
