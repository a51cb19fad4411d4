//! Rays as the BVH library traverses them. Its wide-node test never accepts a child box nearer
//! than t = 1e-4 (a fixed epsilon in its traversal), which for unit directions drops whatever
//! lies within 0.1 mm of a ray's origin: a box 0.1 mm across vanished, and light leaked into
//! crevices narrower than that. The library is handed the direction scaled by 2^-8, so the cut
//! falls at 0.4 µm; a power-of-two scale is exact, so the comparisons it makes are otherwise
//! the same. (Not further: it clamps direction components below f32::EPSILON, so the scale
//! would bend the boxes' slabs for every nearly axis-parallel ray: 2^-16 missed strands.)
//! Distances cross the boundary through [`to_box_t`] and [`from_box_t`].
//!
//! The old cut also skipped, for free, the leaf of the surface a bounce ray leaves (its offset
//! puts it some 30 µm out at unit scale); visiting it costs about 4% on the Cornell box. A cut
//! set per ray at twice its origin's offset would win that back and still see a 0.1 mm box.
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
