//! Robust ray origins: moving a hit point off its surface by an amount that scales with the
//! coordinates' magnitude (Wächter and Binder, Ray Tracing Gems ch. 6). Near the origin a fixed
//! epsilon is used; elsewhere the float is stepped by a number of ULPs, so a surface 10 km from the
//! origin is left as reliably as one at the origin.

use glam::Vec3;

const ORIGIN: f32 = 1.0 / 32.0;
const FLOAT_SCALE: f32 = 1.0 / 65536.0;
const INT_SCALE: f32 = 256.0;

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_to_the_normal_side_at_any_magnitude() {
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
        }
    }
}
