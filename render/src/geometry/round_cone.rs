//! The round curve primitive: one linear segment of a strand with a radius at each end, swept
//! as a sphere along the segment (a "round cone": the convex hull of the two end spheres). A
//! strand of such segments is watertight at its vertices, because neighbouring segments share
//! the sphere there.
//!
//! The surface has three pieces: the two end spheres and the cone tangent to both. In the plane
//! through the axis, the cone's side is a line at distance `r_a` from `a` whose normal makes a
//! constant angle θ with the perpendicular to the axis, sin θ = (r_a − r_b) / L. A point of the
//! cone belongs to the hull when the sphere it touches has its centre within the segment; a
//! point of an end sphere belongs to it when its normal leans outward past that angle. The hull
//! is convex, so a ray meets it in one interval, and the first surface point within the ray's
//! range is the smallest valid root above `t_min` (which also covers rays starting inside).
//!
//! The roots are found in f64, with the ray origin first moved along the ray to the point
//! nearest the segment, so thin strands far from the ray origin or from the world origin keep
//! their precision.

use glam::{DVec3, Vec3};

/// One segment: end points and radii.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoundCone {
    pub a: Vec3,
    pub b: Vec3,
    pub radius_a: f32,
    pub radius_b: f32,
}

/// A ray meeting a segment's surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoundConeHit {
    /// Ray parameter, in units of the direction's length.
    pub t: f32,
    /// Unit outward normal.
    pub normal: Vec3,
    /// Where along the segment the touched sphere's centre lies, 0 at `a` to 1 at `b` (for
    /// interpolating per-vertex data).
    pub s: f32,
}

impl RoundCone {
    /// The first surface point of `origin + t·dir` with t in (t_min, t_max).
    pub fn intersect(
        &self,
        origin: Vec3,
        dir: Vec3,
        t_min: f32,
        t_max: f32,
    ) -> Option<RoundConeHit> {
        if self.nearest_approach(origin, dir, t_min, t_max) == Approach::Misses {
            return None;
        }
        let d = dir.as_dvec3();
        let dd = d.length_squared();
        if dd == 0.0 {
            return None;
        }
        let (a, b) = (self.a.as_dvec3(), self.b.as_dvec3());
        let (ra, rb) = (self.radius_a as f64, self.radius_b as f64);
        // Move the origin to the ray's closest approach to the segment's middle.
        let shift = (0.5 * (a + b) - origin.as_dvec3()).dot(d) / dd;
        let o = origin.as_dvec3() + d * shift;
        let axis = b - a;
        let (lo, hi) = (t_min as f64 - shift, t_max as f64 - shift);
        let length = axis.length();
        let mut best: Option<(f64, DVec3, f64)> = None;
        let mut consider = |t: f64, normal: DVec3, s: f64| {
            if t > lo && t < hi && best.is_none_or(|b| t < b.0) {
                best = Some((t, normal, s));
            }
        };
        if length <= (ra - rb).abs() {
            // One sphere holds the other: the hull is the larger sphere.
            let (c, r, s) = if ra >= rb { (a, ra, 0.0) } else { (b, rb, 1.0) };
            for t in sphere_roots(o - c, d, r).into_iter().flatten() {
                consider(t, (o + d * t - c) / r, s);
            }
        } else {
            let w = axis / length;
            let sin = (ra - rb) / length;
            let cos = (1.0 - sin * sin).sqrt();
            for (c, r, s, keep) in [(a, ra, 0.0, -1.0), (b, rb, 1.0, 1.0)] {
                for t in sphere_roots(o - c, d, r).into_iter().flatten() {
                    let n = (o + d * t - c) / r;
                    // The sphere's part of the hull: normals leaning out past the cone's.
                    if keep * (n.dot(w) - sin) >= 0.0 {
                        consider(t, n, s);
                    }
                }
            }
            // The cone: in axis coordinates (z along w, ρ from the axis), the side is
            // z·sin θ + ρ·cos θ = r_a, i.e. cos²θ·(|q|² − z²) = (r_a − z·sin θ)² with the right
            // side's base non-negative.
            let q0 = o - a;
            let (z0, zd) = (q0.dot(w), d.dot(w));
            let c2 = cos * cos;
            let qa = c2 * (dd - zd * zd) - sin * sin * zd * zd;
            let qb = 2.0 * (c2 * (q0.dot(d) - z0 * zd) + (ra - z0 * sin) * sin * zd);
            let qc = c2 * (q0.length_squared() - z0 * z0) - (ra - z0 * sin).powi(2);
            for t in quadratic_roots(qa, qb, qc).into_iter().flatten() {
                let q = q0 + d * t;
                let z = q.dot(w);
                if ra - z * sin < 0.0 {
                    continue;
                }
                let radial = q - w * z;
                let rho = radial.length();
                // Centre of the sphere this point touches.
                let centre = z - rho * sin / cos;
                if !(0.0..=length).contains(&centre) || rho == 0.0 {
                    continue;
                }
                let n = radial / rho * cos + w * sin;
                consider(t, n, centre / length);
            }
        }
        best.map(|(t, n, s)| RoundConeHit {
            t: (t + shift) as f32,
            normal: n.normalize().as_vec3(),
            s: s as f32,
        })
    }

    /// True when `origin + t·dir` meets the surface for some t in (t_min, t_max): what a
    /// shadow ray asks, the same answer as [`Self::intersect`]'s. Most hits are decided in f32
    /// without the roots: a ray piece that starts outside the hull and passes inside the
    /// thinner end's sphere swept along the segment must cross the surface on the way in.
    pub fn occludes(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> bool {
        match self.nearest_approach(origin, dir, t_min, t_max) {
            Approach::Misses => false,
            Approach::EntersFromOutside => true,
            Approach::Undecided => self.intersect(origin, dir, t_min, t_max).is_some(),
        }
    }

    /// What f32 distances alone say of the ray piece `origin + t·dir`, t in [t_min, t_max],
    /// with a margin for f32 rounding at the coordinates' magnitude on each side: the hull
    /// lies within the larger radius of the segment (a piece passing farther misses: most
    /// candidates a BVH hands over end here) and holds everything within the smaller one.
    #[inline]
    fn nearest_approach(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Approach {
        let magnitude = origin.abs().max_element() + self.a.abs().max_element();
        let margin = 1e-5 * magnitude;
        let reach = self.radius_a.max(self.radius_b) + margin;
        let (e, q) = (self.b - self.a, origin - self.a);
        let closest = ray_segment_distance_squared(q, dir, e, t_min, t_max);
        if closest > reach * reach {
            return Approach::Misses;
        }
        let within = self.radius_a.min(self.radius_b) - margin;
        if within > 0.0 && closest < within * within && t_min.is_finite() {
            let start = q + dir * t_min;
            let ee = e.length_squared();
            let s = if ee > 0.0 {
                (start.dot(e) / ee).clamp(0.0, 1.0)
            } else {
                0.0
            };
            if (start - e * s).length_squared() > reach * reach {
                return Approach::EntersFromOutside;
            }
        }
        Approach::Undecided
    }

    /// The segment's bounding box.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let (ra, rb) = (Vec3::splat(self.radius_a), Vec3::splat(self.radius_b));
        (
            (self.a - ra).min(self.b - rb),
            (self.a + ra).max(self.b + rb),
        )
    }
}

/// What a ray piece does near a round cone, as far as f32 distances tell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Approach {
    /// It passes outside the larger radius: no surface point.
    Misses,
    /// It starts outside the hull and passes inside the smaller radius: it crosses the
    /// surface on the way in.
    EntersFromOutside,
    /// The roots decide.
    Undecided,
}

/// Squared distance between the ray piece `q + t·d`, t in [lo, hi] (q relative to the
/// segment's start), and the segment from 0 to `e`. The squared distance is convex in (t, s):
/// the free line's nearest point to the clamped segment is the answer when its t lies in
/// range; otherwise the minimum lies on the edge of the range that t passed (t = lo below it,
/// t = hi above). Either way it is measured between a point of the piece and one of the
/// segment, so rounding in choosing them only lengthens it. NaN when the two are too nearly
/// parallel to choose (every comparison then fails, so it neither rules the segment out nor
/// in).
#[inline]
fn ray_segment_distance_squared(q: Vec3, d: Vec3, e: Vec3, lo: f32, hi: f32) -> f32 {
    let (dd, de, ee) = (d.dot(d), d.dot(e), e.dot(e));
    let (dq, eq) = (d.dot(q), e.dot(q));
    let denominator = dd * ee - de * de;
    if denominator <= 1e-6 * dd * ee {
        return f32::NAN;
    }
    let s = ((dd * eq - de * dq) / denominator).clamp(0.0, 1.0);
    let t = (de * s - dq) / dd;
    if t >= lo && t <= hi {
        return (q + d * t - e * s).length_squared();
    }
    // The segment's nearest point to the end of the ray piece that t passed (finite: t lies
    // beyond it; a NaN t, from NaN input, decides nothing).
    let edge = if t > hi {
        hi
    } else if t < lo {
        lo
    } else {
        return f32::NAN;
    };
    let p = q + d * edge;
    let s = if ee > 0.0 {
        (p.dot(e) / ee).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - e * s).length_squared()
}

/// The roots of |q + t·d|² = r².
fn sphere_roots(q: DVec3, d: DVec3, r: f64) -> [Option<f64>; 2] {
    quadratic_roots(
        d.length_squared(),
        2.0 * q.dot(d),
        q.length_squared() - r * r,
    )
}

/// Real roots of a·t² + b·t + c = 0 in increasing order, in the cancellation-free form.
fn quadratic_roots(a: f64, b: f64, c: f64) -> [Option<f64>; 2] {
    if a.abs() < 1e-300 {
        return [(b != 0.0).then(|| -c / b), None];
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return [None, None];
    }
    let q = -0.5 * (b + disc.sqrt().copysign(b));
    let (t0, t1) = if q == 0.0 { (0.0, 0.0) } else { (q / a, c / q) };
    [Some(t0.min(t1)), Some(t0.max(t1))]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance from `p` to the round cone: the smallest over the swept spheres, a convex
    /// function of the sphere's position, minimised by golden-section search.
    fn distance(c: &RoundCone, p: DVec3) -> f64 {
        let (a, b) = (c.a.as_dvec3(), c.b.as_dvec3());
        let f = |s: f64| {
            (p - (a + (b - a) * s)).length()
                - (c.radius_a as f64 + (c.radius_b as f64 - c.radius_a as f64) * s)
        };
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        let g = 0.5 * (5f64.sqrt() - 1.0);
        for _ in 0..90 {
            let (x1, x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
            if f(x1) < f(x2) {
                hi = x2;
            } else {
                lo = x1;
            }
        }
        f(0.5 * (lo + hi)).min(f(0.0)).min(f(1.0))
    }

    /// First t where the ray enters the round cone, by sphere tracing the exact distance (the
    /// reference the closed form is checked against).
    fn reference_hit(c: &RoundCone, o: DVec3, d: DVec3, t_max: f64) -> Option<f64> {
        let mut t = 0.0;
        for _ in 0..20000 {
            let step = distance(c, o + d * t);
            if step < 1e-10 {
                return Some(t);
            }
            t += step;
            if t > t_max {
                return None;
            }
        }
        None
    }

    fn cone(a: [f32; 3], b: [f32; 3], ra: f32, rb: f32) -> RoundCone {
        RoundCone {
            a: Vec3::from(a),
            b: Vec3::from(b),
            radius_a: ra,
            radius_b: rb,
        }
    }

    /// Uniform numbers in [0, 1) from a xorshift generator seeded with `state`.
    fn uniform(mut state: u64) -> impl FnMut() -> f64 {
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    #[test]
    fn matches_the_swept_sphere_distance_on_random_rays() {
        let mut next = uniform(0x2545_f491_4f6c_dd1d);
        let shapes = [
            cone([0.0, 0.0, 0.0], [2.0, 0.5, 0.0], 0.4, 0.1),
            cone([0.0, 0.0, 0.0], [0.0, 2.0, 0.0], 0.3, 0.3),
            cone([0.0, 0.0, 0.0], [1.0, 0.0, 1.0], 0.05, 0.6),
            cone([0.0, 0.0, 0.0], [0.3, 0.0, 0.0], 0.5, 0.1),
        ];
        let mut hits = 0;
        for (k, c) in shapes.iter().enumerate() {
            for i in 0..150 {
                let o = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 8.0;
                let target = DVec3::new(next() * 2.0 - 0.5, next() * 2.0 - 0.5, next() - 0.5);
                let d = (target - o).normalize();
                if distance(c, o) <= 0.0 {
                    continue;
                }
                let got = c.intersect(o.as_vec3(), d.as_vec3(), 0.0, f32::INFINITY);
                let want = reference_hit(c, o, d, 20.0);
                match (got, want) {
                    (Some(g), Some(w)) => {
                        hits += 1;
                        assert!(
                            (g.t as f64 - w).abs() < 1e-4,
                            "shape {k} ray {i}: {} vs {w}",
                            g.t
                        );
                        let p = o + d * g.t as f64;
                        assert!(distance(c, p).abs() < 1e-4);
                        assert!(g.normal.as_dvec3().dot(d) < 0.0, "entry faces the ray");
                    }
                    (None, None) => {}
                    // Grazing rays may disagree within the reference's step.
                    (g, w) => {
                        let near = want.or(got.map(|g| g.t as f64)).unwrap();
                        let closest = (0..2000)
                            .map(|j| distance(c, o + d * (near * j as f64 / 1000.0)))
                            .fold(f64::INFINITY, f64::min);
                        assert!(closest.abs() < 1e-3, "shape {k} ray {i}: {g:?} vs {w:?}");
                    }
                }
            }
        }
        assert!(hits > 150, "only {hits} hits");
    }

    #[test]
    fn occlusion_agrees_with_the_roots() {
        // Rays from outside, from inside, along the axis, grazing the silhouette and ending
        // short of, inside or beyond the hull: `occludes` answers as `intersect` does,
        // whether the f32 distances decide or the roots do.
        let mut uniform = uniform(0x9e37_79b9_7f4a_7c15);
        let mut next = || uniform() as f32;
        let shapes = [
            cone([0.0, 0.0, 0.0], [2.0, 0.5, 0.0], 0.4, 0.1),
            cone([0.0, 0.0, 0.0], [0.0, 2.0, 0.0], 0.3, 0.3),
            cone([1e3, 0.0, 1e3], [1e3 + 0.01, 0.0, 1e3], 0.002, 0.0015),
            cone([0.0, 0.0, 0.0], [0.3, 0.0, 0.0], 0.5, 0.1),
        ];
        let (mut decided, mut total) = (0, 0);
        for c in &shapes {
            let (a, e) = (c.a, c.b - c.a);
            let scale = e.length() + c.radius_a.max(c.radius_b);
            for i in 0..4000 {
                let spread = if i % 2 == 0 { 4.0 } else { 0.6 };
                let mut jitter = |k: f32| Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * k;
                let (j0, j1, j2) = (jitter(spread * scale), jitter(0.2 * scale), jitter(scale));
                let (s0, s1) = (next(), next());
                let origin = a + e * s0 + j0;
                let target = match i % 4 {
                    // Along the axis, and towards the silhouette.
                    0 => origin + e,
                    1 => a + e * s1 + j1.normalize() * c.radius_a,
                    _ => a + e * s1 + j2,
                };
                let dir = target - origin;
                let t_max = [f32::INFINITY, 1.0, 0.5 + s1][i % 3];
                let expected = c.intersect(origin, dir, 0.0, t_max).is_some();
                assert_eq!(
                    c.occludes(origin, dir, 0.0, t_max),
                    expected,
                    "{c:?} from {origin} along {dir} to {t_max}"
                );
                total += 1;
                decided += (c.nearest_approach(origin, dir, 0.0, t_max)
                    == Approach::EntersFromOutside) as usize;
            }
        }
        assert!(
            decided > total / 10,
            "f32 decided only {decided} of {total}"
        );
    }

    #[test]
    fn tangent_grazing_caps_inside_thin_and_far() {
        let c = cone([0.0, 0.0, 0.0], [4.0, 0.0, 0.0], 0.5, 0.5);
        // Head-on to the side, and just inside / outside the silhouette.
        let hit = c
            .intersect(Vec3::new(2.0, 0.0, 5.0), -Vec3::Z, 0.0, 100.0)
            .unwrap();
        assert!((hit.t - 4.5).abs() < 1e-6 && (hit.s - 0.5).abs() < 1e-6);
        assert!((hit.normal - Vec3::Z).length() < 1e-6);
        assert!(
            c.intersect(Vec3::new(2.0, 0.49999, 5.0), -Vec3::Z, 0.0, 100.0)
                .is_some()
        );
        assert!(
            c.intersect(Vec3::new(2.0, 0.50001, 5.0), -Vec3::Z, 0.0, 100.0)
                .is_none()
        );
        // Along the axis: the end cap.
        let cap = c
            .intersect(Vec3::new(-3.0, 0.0, 0.0), Vec3::X, 0.0, 100.0)
            .unwrap();
        assert!((cap.t - 2.5).abs() < 1e-6 && cap.s == 0.0);
        assert!((cap.normal + Vec3::X).length() < 1e-6);
        // From inside: the exit, and t_min skips the entry.
        let out = c
            .intersect(Vec3::new(1.0, 0.0, 0.0), Vec3::Y, 0.0, 100.0)
            .unwrap();
        assert!((out.t - 0.5).abs() < 1e-6 && (out.normal - Vec3::Y).length() < 1e-6);
        let far_side = c
            .intersect(Vec3::new(2.0, 0.0, 5.0), -Vec3::Z, 5.0, 100.0)
            .unwrap();
        assert!((far_side.t - 5.5).abs() < 1e-6);
        assert!(
            c.intersect(Vec3::new(2.0, 0.0, 5.0), -Vec3::Z, 0.0, 4.0)
                .is_none()
        );
        // A strand 10 µm thick seen from 100 m.
        let thin = cone([0.0, -1.0, 0.0], [0.0, 1.0, 0.0], 1e-5, 1e-5);
        let hit = thin
            .intersect(Vec3::new(0.0, 0.3, 100.0), -Vec3::Z, 0.0, 1e3)
            .unwrap();
        assert!((hit.t - (100.0 - 1e-5)).abs() < 1e-5);
        assert!(
            thin.intersect(Vec3::new(2e-5, 0.3, 100.0), -Vec3::Z, 0.0, 1e3)
                .is_none()
        );
        // The same segment 10 km from the origin.
        let far = 1e4;
        let moved = cone([far, 0.0, far], [far + 4.0, 0.0, far], 0.01, 0.01);
        let hit = moved
            .intersect(Vec3::new(far + 2.0, 0.0, far + 1.0), -Vec3::Z, 0.0, 10.0)
            .unwrap();
        assert!((hit.t - 0.99).abs() < 2e-3, "{}", hit.t);
        assert!((hit.normal - Vec3::Z).length() < 1e-3);
        // Degenerate: one end sphere inside the other, and a zero direction.
        let ball = cone([0.0, 0.0, 0.0], [0.1, 0.0, 0.0], 1.0, 0.2);
        let hit = ball
            .intersect(Vec3::new(0.0, 0.0, 3.0), -Vec3::Z, 0.0, 10.0)
            .unwrap();
        assert!((hit.t - 2.0).abs() < 1e-6);
        assert!(c.intersect(Vec3::ZERO, Vec3::ZERO, 0.0, 1.0).is_none());
    }
}
