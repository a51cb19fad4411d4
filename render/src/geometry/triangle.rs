//! Watertight ray/triangle intersection (Woop, Benthin and Wald, JCGT 2013): the ray is sheared so
//! it runs along +Z, and the hit test becomes three 2-D edge functions evaluated in a way that
//! gives the same answer for an edge shared by two triangles, so rays never slip between them.
//! Edge functions that come out exactly zero are recomputed in f64.

use glam::{Vec3, Vec4, Vec4Swizzles};

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
    /// The origin's coordinates in permuted order (kx, ky, kz).
    origin_k: [f32; 3],
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
        // The other two axes in cyclic order, swapped when the ray runs down kz (the sheared
        // frame keeps its handedness). Arrays indexed by axis, not vector components, so
        // choosing costs loads and no branches.
        const CYCLIC: [[usize; 2]; 3] = [[1, 2], [2, 0], [0, 1]];
        let (d, o) = (direction.to_array(), origin.to_array());
        let [kx, ky] = CYCLIC[kz];
        let [kx, ky] = if d[kz] < 0.0 { [ky, kx] } else { [kx, ky] };
        // One division: every triangle sees the same shear, which is all watertightness needs.
        let sz = 1.0 / d[kz];
        Self {
            origin,
            kx,
            ky,
            kz,
            origin_k: [o[kx], o[ky], o[kz]],
            sx: d[kx] * sz,
            sy: d[ky] * sz,
            sz,
        }
    }
}

/// Distance along the ray to the triangle (in units of the direction's length), with the
/// barycentrics (b1, b2) of the hit, if hit within (0, t_max). The plain form of the test, for
/// one triangle; the BVHs run [`PackedTriangles::intersect`], which must agree with it to the
/// bit (its test compares the two).
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
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    let [u, v, w] = if u == 0.0 || v == 0.0 || w == 0.0 {
        edges_f64([ax, bx, cx], [ay, by, cy])
    } else {
        [u, v, w]
    };
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    hit_distance([u, v, w], [ray.sz * az, ray.sz * bz, ray.sz * cz], t_max)
}

/// The three edge functions (u, v, w) of sheared vertices a, b, c (x and y of each) in f64,
/// for when one comes out exactly zero in f32.
#[cold]
fn edges_f64(x: [f32; 3], y: [f32; 3]) -> [f32; 3] {
    let [ax, bx, cx] = x.map(f64::from);
    let [ay, by, cy] = y.map(f64::from);
    [
        (cx * by - cy * bx) as f32,
        (ax * cy - ay * cx) as f32,
        (bx * ay - by * ax) as f32,
    ]
}

/// The hit of a ray whose edge functions (`uvw`, all of one sign) passed, with `z` the
/// vertices' scaled depths along it: distance and barycentrics, if within (0, t_max).
#[inline(always)]
fn hit_distance(uvw: [f32; 3], z: [f32; 3], t_max: f32) -> Option<(f32, f32, f32)> {
    let [u, v, w] = uvw;
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let t_scaled = u * z[0] + v * z[1] + w * z[2];
    // Compare t against (0, t_max) without dividing, with det's sign folded in.
    let sign = det.signum();
    if t_scaled * sign <= 0.0 || t_scaled * sign > t_max * det * sign {
        return None;
    }
    let inv = 1.0 / det;
    Some((t_scaled * inv, v * inv, w * inv))
}

/// Triangles laid out for [`PackedTriangles::intersect`]: per triangle, the x of its three
/// vertices, then their y, then their z. One vector load then brings an axis of all three
/// vertices, so a ray's permutation picks loads rather than shuffling each vertex, and the
/// three edge functions come out of one vector expression: the same arithmetic as
/// [`intersect_watertight`], lane by lane, so the same hits to the bit, in about half the
/// instructions (a Cornell box's tests, counted).
pub struct PackedTriangles {
    /// Nine coordinates a triangle, then [`PADDING`] more, so a four-wide load of the last
    /// triangle's z stays in bounds.
    coords: Vec<f32>,
}

/// Coordinates after the last triangle (read into a vector lane the test ignores).
const PADDING: usize = 1;

impl PackedTriangles {
    pub fn new(triangles: impl ExactSizeIterator<Item = Triangle>) -> Self {
        let count = triangles.len();
        let mut coords = crate::platform::huge_pages::with_capacity(9 * count + PADDING);
        for t in triangles {
            for axis in 0..3 {
                coords.extend(t.v.iter().map(|v| v[axis]));
            }
        }
        coords.extend([0.0; PADDING]);
        Self { coords }
    }

    /// The three axes of triangle `slot` in the ray's order (kx, ky, kz), each a vector of
    /// the three vertices' coordinates in lanes 0 to 2 (lane 3 holds whatever follows).
    #[inline(always)]
    fn axes(&self, slot: usize, ray: &ShearedRay) -> [Vec4; 3] {
        let coords = &self.coords[9 * slot..9 * slot + 9 + PADDING];
        // The one bounds check above covers all three loads: an axis starts at 0, 3 or 6.
        [ray.kx, ray.ky, ray.kz].map(|k| {
            let start = 3 * k.min(2);
            Vec4::from_slice(&coords[start..start + 4])
        })
    }

    /// [`intersect_watertight`] on triangle `slot`.
    #[inline(always)]
    pub fn intersect(&self, slot: usize, ray: &ShearedRay, t_max: f32) -> Option<(f32, f32, f32)> {
        let [ox, oy, oz] = ray.origin_k;
        let [px, py, pz] = self.axes(slot, ray);
        let (px, py, pz) = (
            px - Vec4::splat(ox),
            py - Vec4::splat(oy),
            pz - Vec4::splat(oz),
        );
        // Lanes a, b, c: the sheared vertices' x and y.
        let x = px - Vec4::splat(ray.sx) * pz;
        let y = py - Vec4::splat(ray.sy) * pz;
        // (u, v, w) = (cx·by − cy·bx, ax·cy − ay·cx, bx·ay − by·ax).
        let mut uvw = x.zxyw() * y.yzxw() - y.zxyw() * x.yzxw();
        // Lane 3 holds whatever followed the coordinates loaded: never looked at.
        const LANES: u32 = 0b111;
        if uvw.cmpeq(Vec4::ZERO).bitmask() & LANES != 0 {
            let [u, v, w] = edges_f64(x.xyz().to_array(), y.xyz().to_array());
            uvw = Vec4::new(u, v, w, 0.0);
        }
        if uvw.cmplt(Vec4::ZERO).bitmask() & LANES != 0
            && uvw.cmpgt(Vec4::ZERO).bitmask() & LANES != 0
        {
            return None;
        }
        let z = Vec4::splat(ray.sz) * pz;
        hit_distance(uvw.xyz().to_array(), z.xyz().to_array(), t_max)
    }
}

impl super::wide_bvh::LeafData for PackedTriangles {
    #[inline(always)]
    fn prefetch(&self, slots: std::ops::RangeInclusive<usize>) {
        let (first, last) = slots.into_inner();
        if let Some(run) = self.coords.get(9 * first..9 * last + 9) {
            crate::platform::prefetch::prefetch(run);
        }
    }
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

    /// A uniform number in [-1, 1) from a counter.
    fn unit(i: u32) -> f32 {
        crate::sampling::hash32(i) as f32 / 2_147_483_648.0 - 1.0
    }

    fn point(i: u32) -> Vec3 {
        Vec3::new(unit(3 * i), unit(3 * i + 1), unit(3 * i + 2))
    }

    #[test]
    fn packed_triangles_hit_what_the_plain_test_hits_to_the_bit() {
        let triangles: Vec<Triangle> = (0..64)
            .map(|i| Triangle {
                v: [point(9 * i), point(9 * i + 1), point(9 * i + 2)],
            })
            .collect();
        let packed = PackedTriangles::new(triangles.iter().copied());
        assert_eq!(packed.coords.len(), 9 * triangles.len() + PADDING);
        let bits = |h: Option<(f32, f32, f32)>| h.map(|(t, b1, b2)| [t, b1, b2].map(f32::to_bits));
        let (mut hits, mut compared) = (0, 0);
        for r in 0..4000u32 {
            let origin = 3.0 * point(100_000 + r);
            let slot = (r % 64) as usize;
            let tri = &triangles[slot];
            // Rays at random points, at vertices and along edges (where edge functions come
            // out zero and the f64 path decides), and along the axes in both senses.
            let target = match r % 4 {
                0 => point(200_000 + r),
                1 => tri.v[(r / 4 % 3) as usize],
                2 => tri.v[0].lerp(tri.v[1], 0.5 + 0.5 * unit(r)),
                _ => origin + Vec3::AXES[(r / 4 % 3) as usize] * unit(r).signum(),
            };
            let ray = ShearedRay::new(origin, target - origin);
            for t_max in [f32::INFINITY, 1.0, 0.5] {
                let plain = intersect_watertight(&ray, tri, t_max);
                let fast = packed.intersect(slot, &ray, t_max);
                assert_eq!(bits(plain), bits(fast), "ray {r}, t_max {t_max}");
                hits += plain.is_some() as u32;
                compared += 1;
            }
        }
        assert!(hits > compared / 10, "{hits} hits of {compared}");
    }
}
