//! Robust ray origins: moving a hit point off its surface by an amount that scales with the
//! coordinates' magnitude (Wächter and Binder, Ray Tracing Gems ch. 6). Near the origin a fixed
//! epsilon is used; elsewhere the float is stepped by a number of ULPs, so a surface 10 km from the
//! origin is left as reliably as one at the origin.

use glam::Vec3;

const ORIGIN: f32 = 1.0 / 32.0;
const FLOAT_SCALE: f32 = 1.0 / 65536.0;
const INT_SCALE: f32 = 256.0;
/// ULPs (of the point's largest coordinate, at least 1) that the far end of a shadow ray moves
/// off its emitter. Every occluder closer to the emitter than this is missed, so it is far
/// smaller than a ray origin's offset: at 256 ULPs (1 mm, 40 m from the origin) a ring of
/// overlapping strands 8 cm wide, which hide much of one another within a millimetre of their
/// surfaces, came out 14% too bright. It scales with the largest coordinate, not each
/// coordinate's own, because that is what the shadow ray's intersection error follows: a
/// light's face at z = 0.1 but x = 30 has to be left by ULPs of 30.
const TARGET_ULPS: f32 = 8.0;

/// Moves `p` off the surface with geometric normal `n` (unit), to the side `n` points to.
#[inline]
pub fn offset_origin(p: Vec3, n: Vec3) -> Vec3 {
    let of_i = (n * INT_SCALE).as_ivec3();
    let step = |x: f32, o: i32| {
        let bits = x.to_bits() as i32;
        f32::from_bits((bits + if x < 0.0 { -o } else { o }) as u32)
    };
    let p_i = Vec3::new(step(p.x, of_i.x), step(p.y, of_i.y), step(p.z, of_i.z));
    let pick = |x: f32, xi: f32, nx: f32| {
        if x.abs() < ORIGIN {
            x + FLOAT_SCALE * nx
        } else {
            xi
        }
    };
    Vec3::new(
        pick(p.x, p_i.x, n.x),
        pick(p.y, p_i.y, n.y),
        pick(p.z, p_i.z, n.z),
    )
}

/// Moves the point `p` a light sampler chose on an emitter (geometric normal `n`, unit) off
/// it towards `n`, as the end of a shadow ray: `TARGET_ULPS`, far less than
/// [`offset_origin`].
#[inline]
pub fn offset_target(p: Vec3, n: Vec3) -> Vec3 {
    let magnitude = p.abs().max_element().max(1.0);
    let ulp = f32::from_bits(magnitude.to_bits() + 1) - magnitude;
    p + n * (TARGET_ULPS * ulp)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_to_the_normal_side_at_any_magnitude_and_targets_less() {
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        for scale in [0.0, 1e-3, 1.0, 1e3, 1e4, 1e6] {
            let p = Vec3::new(0.7, -0.2, 0.4) * scale;
            let q = offset_origin(p, n);
            assert!(
                (q - p).dot(n) > 0.0,
                "scale {scale}: not moved to the front"
            );
            assert!(
                (q - p).length() <= 1e-3 * (1.0 + p.abs().max_element()),
                "scale {scale}: moved too far"
            );
            // The light end of a shadow ray moves off too, but far less.
            let target = offset_target(p, n);
            assert!((target - p).dot(n) > 0.0, "scale {scale}: target not moved");
            assert!(
                (target - p).length() * 8.0 <= (q - p).length(),
                "scale {scale}: target moved {} against {}",
                (target - p).length(),
                (q - p).length()
            );
        }
    }

    #[test]
    fn a_target_leaves_by_ulps_of_its_largest_coordinate() {
        // A light's face at z = -0.1, 30 m along x: ULPs of 0.1 would be lost in those of 30.
        let p = Vec3::new(30.0, 1.5, -0.1);
        let moved = (offset_target(p, -Vec3::Z) - p).dot(-Vec3::Z);
        let ulp_30 = f32::from_bits(30f32.to_bits() + 1) - 30.0;
        assert!(
            (4.0 * ulp_30..=16.0 * ulp_30).contains(&moved),
            "moved {moved}"
        );
    }
}
