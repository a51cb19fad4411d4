//! Colour: rift's radiance is linear Rec. 709 RGB throughout.

use glam::{DVec3, Vec3};

/// Rec. 709 luminance of a linear colour.
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// [`luminance`] in double precision, for sums over many samples.
#[inline]
pub fn luminance_f64(c: DVec3) -> f64 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}
