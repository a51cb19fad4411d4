//! Watertight ray/triangle intersection (Woop, Benthin and Wald, JCGT 2013): the ray is sheared so
//! it runs along +Z, and the hit test becomes three 2-D edge functions evaluated in a way that
//! gives the same answer for an edge shared by two triangles, so rays never slip between them.
//! Edge functions that come out exactly zero are recomputed in f64.

use glam::Vec3;

/// A triangle's vertices in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    pub v: [Vec3; 3],
}

impl Triangle {
    /// Geometric normal (not normalised), counter-clockwise winding is the front.
    pub fn normal(&self) -> Vec3 {
        (self.v[1] - self.v[0]).cross(self.v[2] - self.v[0])
    }

    /// Area.
    pub fn area(&self) -> f32 {
        0.5 * self.normal().length()
    }

    /// The point at barycentric (b1, b2).
    pub fn point(&self, b1: f32, b2: f32) -> Vec3 {
        self.v[0] * (1.0 - b1 - b2) + self.v[1] * b1 + self.v[2] * b2
    }
}

/// A ray prepared for watertight tests: the axis permutation and shear that map its direction to +Z.
#[derive(Clone, Copy, Debug)]
pub struct ShearedRay {
    origin: Vec3,
    kx: usize,
    ky: usize,
    kz: usize,
    sx: f32,
    sy: f32,
    sz: f32,
}

impl ShearedRay {
    /// Prepares `direction` (need not be normalised).
    #[inline]
    pub fn new(origin: Vec3, direction: Vec3) -> Self {
        let a = direction.abs();
        let kz = if a.x > a.y {
            if a.x > a.z { 0 } else { 2 }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if direction[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        // One division: every triangle sees the same shear, which is all watertightness needs.
        let sz = 1.0 / direction[kz];
        Self {
            origin,
            kx,
            ky,
            kz,
            sx: direction[kx] * sz,
            sy: direction[ky] * sz,
            sz,
        }
    }
}

/// Distance along the ray to the triangle (in units of the direction's length), with the
/// barycentrics (b1, b2) of the hit, if hit within (0, t_max).
#[inline(always)]
pub fn intersect_watertight(
    ray: &ShearedRay,
    tri: &Triangle,
    t_max: f32,
) -> Option<(f32, f32, f32)> {
    // Vertices relative to the origin, permuted so the ray's dominant axis comes last, then
    // sheared onto the ray.
    let permute = |v: Vec3| {
        let v = v.to_array();
        [v[ray.kx], v[ray.ky], v[ray.kz]]
    };
    let [ax, ay, az] = permute(tri.v[0] - ray.origin);
    let [bx, by, bz] = permute(tri.v[1] - ray.origin);
    let [cx, cy, cz] = permute(tri.v[2] - ray.origin);
    let (ax, ay) = (ax - ray.sx * az, ay - ray.sy * az);
    let (bx, by) = (bx - ray.sx * bz, by - ray.sy * bz);
    let (cx, cy) = (cx - ray.sx * cz, cy - ray.sy * cz);
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        let (ax, ay, bx, by, cx, cy) = (
            ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64,
        );
        u = (cx * by - cy * bx) as f32;
        v = (ax * cy - ay * cx) as f32;
        w = (bx * ay - by * ax) as f32;
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let (az, bz, cz) = (ray.sz * az, ray.sz * bz, ray.sz * cz);
    let t_scaled = u * az + v * bz + w * cz;
    // Compare t against (0, t_max) without dividing, with det's sign folded in.
    let sign = det.signum();
    if t_scaled * sign <= 0.0 || t_scaled * sign > t_max * det * sign {
        return None;
    }
    let inv = 1.0 / det;
    Some((t_scaled * inv, v * inv, w * inv))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_inside_and_misses_outside() {
        let tri = Triangle {
            v: [
                Vec3::new(-1.0, -1.0, 0.0),
                Vec3::new(1.0, -1.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
            ],
        };
        let ray = ShearedRay::new(Vec3::new(0.0, 0.0, 5.0), Vec3::new(0.0, 0.0, -1.0));
        let (t, b1, b2) = intersect_watertight(&ray, &tri, f32::INFINITY).unwrap();
        assert!((t - 5.0).abs() < 1e-6);
        assert!((tri.point(b1, b2) - Vec3::ZERO).length() < 1e-6);
        let miss = ShearedRay::new(Vec3::new(0.9, 0.9, 5.0), Vec3::new(0.0, 0.0, -1.0));
        assert!(intersect_watertight(&miss, &tri, f32::INFINITY).is_none());
        assert!(
            intersect_watertight(&ray, &tri, 4.0).is_none(),
            "beyond t_max"
        );
        let behind = ShearedRay::new(Vec3::new(0.0, 0.0, -5.0), Vec3::new(0.0, 0.0, -1.0));
        assert!(intersect_watertight(&behind, &tri, f32::INFINITY).is_none());
    }

    #[test]
    fn shared_edges_leak_no_rays() {
        // A quad split along its diagonal, hit by rays aimed exactly at the diagonal from many
        // directions: every ray hits at least one of the two triangles.
        let p = [
            Vec3::new(-1.3, -0.7, 0.2),
            Vec3::new(1.1, -0.9, -0.1),
            Vec3::new(0.9, 1.2, 0.3),
            Vec3::new(-1.0, 1.0, 0.0),
        ];
        let t0 = Triangle {
            v: [p[0], p[1], p[2]],
        };
        let t1 = Triangle {
            v: [p[0], p[2], p[3]],
        };
        let mut leaks = 0;
        for i in 0..=2000 {
            let s = i as f32 / 2000.0;
            let target = p[0].lerp(p[2], s);
            let origin = Vec3::new(0.37 * (i as f32).sin(), 0.29 * (i as f32 * 1.7).cos(), 3.0);
            let ray = ShearedRay::new(origin, target - origin);
            let hit = intersect_watertight(&ray, &t0, f32::INFINITY).is_some()
                || intersect_watertight(&ray, &t1, f32::INFINITY).is_some();
            leaks += !hit as u32;
        }
        assert_eq!(leaks, 0);
    }
}
