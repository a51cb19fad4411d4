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
/// Every path vertex offsets twice (its shadow ray and its next ray), so on x86-64 the three
/// coordinates go through SSE2 (every x86-64 has it) as one vector: a quarter of the
/// instructions of [`offset_origin_portable`], which it matches to the bit.
#[inline]
pub fn offset_origin(p: Vec3, n: Vec3) -> Vec3 {
    #[cfg(target_arch = "x86_64")]
    {
        offset_origin_sse2(p, n)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        offset_origin_portable(p, n)
    }
}

/// [`offset_origin`] a coordinate at a time.
#[inline]
pub fn offset_origin_portable(p: Vec3, n: Vec3) -> Vec3 {
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

/// [`offset_origin_portable`] in one SSE2 register. The float-to-integer conversion truncates
/// as `as i32` does for a unit normal's 256 steps at most; a normal that is not a number
/// (which `as i32` takes as 0) only meets the coordinates it already spoils near the origin.
#[cfg(target_arch = "x86_64")]
#[inline]
fn offset_origin_sse2(p: Vec3, n: Vec3) -> Vec3 {
    use std::arch::x86_64::*;
    let (p, n) = (glam::Vec3A::from(p), glam::Vec3A::from(n));
    let (pv, nv): (__m128, __m128) = (p.into(), n.into());
    // SAFETY: SSE2 is part of x86-64.
    let moved = unsafe {
        let steps = _mm_cvttps_epi32(_mm_mul_ps(nv, _mm_set1_ps(INT_SCALE)));
        // Steps away from zero: negated where the coordinate is negative (−0.0 is not).
        let negative = _mm_castps_si128(_mm_cmplt_ps(pv, _mm_setzero_ps()));
        let steps = _mm_sub_epi32(_mm_xor_si128(steps, negative), negative);
        let stepped = _mm_castsi128_ps(_mm_add_epi32(_mm_castps_si128(pv), steps));
        let nudged = _mm_add_ps(pv, _mm_mul_ps(_mm_set1_ps(FLOAT_SCALE), nv));
        let magnitude = _mm_andnot_ps(_mm_set1_ps(-0.0), pv);
        let near_origin = _mm_cmplt_ps(magnitude, _mm_set1_ps(ORIGIN));
        _mm_or_ps(
            _mm_and_ps(near_origin, nudged),
            _mm_andnot_ps(near_origin, stepped),
        )
    };
    Vec3::from(glam::Vec3A::from(moved))
}

/// The most [`offset_origin`] may move each coordinate of `p` per unit of the normal's
/// component: the fixed step near the origin, 256 ULPs elsewhere.
#[inline]
pub fn offset_steps(p: Vec3) -> Vec3 {
    (p.abs() * (INT_SCALE * f32::EPSILON)).max(Vec3::splat(FLOAT_SCALE))
}

/// How far [`offset_origin`] may move `p` along the unit normal `n`, at most: each
/// coordinate moves by its step times the normal's component.
#[inline]
pub fn offset_reach(p: Vec3, n: Vec3) -> f32 {
    (n * n).dot(offset_steps(p))
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
            assert!(
                // (Its own rounding aside.)
                (q - p).dot(n) <= offset_reach(p, n) * (1.0 + 1e-5),
                "scale {scale}: moved {} beyond its reach {}",
                (q - p).dot(n),
                offset_reach(p, n)
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

    /// The vector form moves every point as the portable one does, to the bit: points near
    /// the origin, far from it, either sign, −0.0, and normals along the axes and between.
    #[test]
    fn both_forms_of_the_origin_offset_agree_to_the_bit() {
        let unit = |i: u32| crate::sampling::hash32(i) as f32 / 2_147_483_648.0 - 1.0;
        for i in 0..20_000u32 {
            let scale = [0.0, 1e-3, 0.02, 0.5, 1.0, 40.0, 1e4, 1e6][(i % 8) as usize];
            let mut p = Vec3::new(unit(6 * i), unit(6 * i + 1), unit(6 * i + 2)) * scale;
            if i % 11 == 0 {
                p.y = -0.0;
            }
            let n = match i % 5 {
                0 => Vec3::AXES[(i / 5 % 3) as usize] * unit(i).signum(),
                _ => Vec3::new(unit(6 * i + 3), unit(6 * i + 4), unit(6 * i + 5)).normalize(),
            };
            let (fast, plain) = (offset_origin(p, n), offset_origin_portable(p, n));
            assert_eq!(
                fast.to_array().map(f32::to_bits),
                plain.to_array().map(f32::to_bits),
                "p {p}, n {n}"
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
