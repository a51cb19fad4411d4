//! A deforming mesh: triangles whose corners move, from a cache of their positions at sample
//! times (the frames and sub-frames of a mesh sequence), with or without velocities. A ray at
//! time t sees each corner between the two samples around t: along the straight line without
//! velocities, along the cubic whose ends have the cache's positions and velocities with them
//! (so fast deformation blurs along its path, not across the chord).
//!
//! One tree layout serves every time: it is built once over each triangle's box across all
//! samples, and its nodes are refit for each segment between two samples, to the boxes at the
//! segment's start and at its end (as a moving ring's are, [`super::moving_bvh`]). A ray in
//! the segment sees the boxes moved linearly between the two; a corner's cubic leaves that
//! straight path by at most what the cubic's Bézier control points say, and the boxes are
//! widened by that. No tree is built per ray or per time.
//!
//! The cache is in object space and shared (`Arc`) by every copy of the object: copies
//! through openings place it with their own transform and read it at their own time. Where
//! every sample gives its corners' normals, they deform with it: a hit's shading normal is
//! read between the two samples around its time, so a bending limb shades smoothly.

use super::PackedNormal;
use super::build::wide_bvh;
use super::moving_bvh::refit_slice;
use super::triangle::{ShearedRay, Triangle, intersect_watertight};
use super::triangle_bvh::TriangleHit;
use super::wide_bvh::{BoxRay, Swept, SweptNode, any_hit, closest_hit};
use glam::{Vec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;

/// A mesh's corner positions at sample times, and the tree that finds its triangles at any
/// time between.
pub struct Deformation {
    /// Sample times, seconds, strictly increasing (at least one).
    times: Vec<f64>,
    /// Per sample, each triangle's corners in object space, in the tree's leaf order (so the
    /// triangles a leaf tests lie together in memory).
    corners: Vec<Vec<[Vec3; 3]>>,
    /// Per sample, each corner's velocity in units per second, in leaf order; empty without.
    velocities: Vec<Vec<[Vec3; 3]>>,
    /// Per sample, each corner's unit shading normal, in leaf order; empty without.
    normals: Vec<Vec<[PackedNormal; 3]>>,
    /// Per segment between two samples (one for a single sample), the tree's nodes refit to it.
    slices: Vec<Vec<SweptNode>>,
    /// The triangle (index into the mesh as given) of each leaf slot.
    leaf_triangles: Vec<u32>,
    /// The leaf slot of each triangle of the mesh as given.
    slot_of: Vec<u32>,
    /// The object-space box of every corner at every time.
    pub bounds: Aabb,
}

/// What a deformation's samples are, checked by [`Deformation::new`].
pub struct Samples {
    pub times: Vec<f64>,
    pub corners: Vec<Vec<[Vec3; 3]>>,
    /// Empty, or one list per sample as long as its corners.
    pub velocities: Vec<Vec<[Vec3; 3]>>,
    /// Empty, or one list of unit normals per sample as long as its corners.
    pub normals: Vec<Vec<[Vec3; 3]>>,
}

/// Where a time falls among the samples: the segment, the fraction through it, and its length
/// in seconds (which scales the velocities).
#[derive(Clone, Copy, Debug)]
struct At {
    segment: usize,
    s: f32,
    length: f32,
}

impl Deformation {
    /// The deformation through `samples` (times increasing, every sample with the same
    /// triangles); its tree is built here.
    pub fn new(samples: Samples) -> Self {
        let Samples {
            times,
            corners,
            velocities,
            normals,
        } = samples;
        assert!(!times.is_empty() && times.len() == corners.len());
        assert!(corners.iter().all(|c| c.len() == corners[0].len()));
        assert!(times.windows(2).all(|w| w[0] < w[1]));
        assert!(velocities.is_empty() || velocities.len() == corners.len());
        assert!(normals.is_empty() || normals.len() == corners.len());
        let normals = (normals.iter())
            .map(|sample| sample.iter().map(|c| c.map(PackedNormal::pack)).collect())
            .collect();
        let mut this = Self {
            times,
            corners,
            velocities,
            normals,
            slices: Vec::new(),
            leaf_triangles: Vec::new(),
            slot_of: Vec::new(),
            bounds: Aabb::empty(),
        };
        this.build_tree();
        this
    }

    /// True when its samples give normals, which deform with it.
    pub fn has_normals(&self) -> bool {
        !self.normals.is_empty()
    }

    /// Triangles in the mesh.
    pub fn triangle_count(&self) -> usize {
        self.corners[0].len()
    }

    /// Bytes held: corner samples, velocities and every segment's nodes.
    pub fn bytes(&self) -> usize {
        let samples: usize = self
            .corners
            .iter()
            .chain(&self.velocities)
            .map(|c| c.len())
            .sum();
        let nodes: usize = self.slices.iter().map(|s| s.len()).sum();
        let normals: usize = self.normals.iter().map(|n| n.len()).sum();
        samples * size_of::<[Vec3; 3]>()
            + normals * size_of::<[PackedNormal; 3]>()
            + nodes * size_of::<SweptNode>()
            + (self.leaf_triangles.len() + self.slot_of.len()) * 4
    }

    /// Segments between samples (one for a single sample).
    fn segments(&self) -> usize {
        (self.times.len() - 1).max(1)
    }

    /// The layout over each triangle's box across every segment, then its nodes refit to each
    /// segment's ends.
    fn build_tree(&mut self) {
        let triangles = self.triangle_count();
        if triangles == 0 {
            return;
        }
        let ends: Vec<[Vec<Aabb>; 2]> = (0..self.segments())
            .map(|k| [0, 1].map(|end| (0..triangles).map(|i| self.end_box(k, end, i)).collect()))
            .collect();
        let whole: Vec<Aabb> = (0..triangles)
            .map(|i| {
                ends.iter()
                    .flatten()
                    .fold(Aabb::empty(), |b, boxes| b.union(&boxes[i]))
            })
            .collect();
        self.bounds = whole.iter().fold(Aabb::empty(), |b, t| b.union(t));
        let params = BvhBuildParams::medium_build();
        let bvh = wide_bvh(&whole, params);
        self.slices = ends
            .iter()
            .map(|[start, end]| refit_slice(&bvh, start, end))
            .collect();
        self.leaf_triangles = bvh.primitive_indices;
        self.slot_of = vec![0; triangles];
        for (slot, &i) in self.leaf_triangles.iter().enumerate() {
            self.slot_of[i as usize] = slot as u32;
        }
        let order = &self.leaf_triangles;
        for sample in self.corners.iter_mut().chain(&mut self.velocities) {
            *sample = order.iter().map(|&i| sample[i as usize]).collect();
        }
        for sample in &mut self.normals {
            *sample = order.iter().map(|&i| sample[i as usize]).collect();
        }
    }

    /// Triangle `i`'s box at one end (`end` 0 the start, 1 the end) of segment `k`, widened by
    /// how far its corners' cubics stray from the straight paths the boxes move along.
    fn end_box(&self, k: usize, end: usize, i: usize) -> Aabb {
        let sample = (k + end).min(self.times.len() - 1);
        let mut b = Aabb::empty();
        for (c, &p) in self.corners[sample][i].iter().enumerate() {
            let (lo, hi) = self.stray(k, i, c);
            b.extend(Vec3A::from(p + lo));
            b.extend(Vec3A::from(p + hi));
        }
        b
    }

    /// The least and greatest offset (per axis) of corner `c` of triangle `i` from the chord
    /// of segment `k`: the cubic minus the chord is a cubic Bézier curve with control points
    /// 0, (h·v0 − Δ)/3, (Δ − h·v1)/3, 0, and lies within their box.
    fn stray(&self, k: usize, i: usize, c: usize) -> (Vec3, Vec3) {
        if self.velocities.is_empty() || self.times.len() < 2 {
            return (Vec3::ZERO, Vec3::ZERO);
        }
        let h = (self.times[k + 1] - self.times[k]) as f32;
        let delta = self.corners[k + 1][i][c] - self.corners[k][i][c];
        let first = (self.velocities[k][i][c] * h - delta) / 3.0;
        let second = (delta - self.velocities[k + 1][i][c] * h) / 3.0;
        (
            first.min(second).min(Vec3::ZERO),
            first.max(second).max(Vec3::ZERO),
        )
    }

    /// Where time `t` (seconds) falls: before the first sample the mesh holds its first
    /// shape, after the last its last.
    fn at(&self, t: f64) -> At {
        let last = self.times.len() - 1;
        if last == 0 {
            return At {
                segment: 0,
                s: 0.0,
                length: 0.0,
            };
        }
        let segment = self.times.partition_point(|&x| x <= t).clamp(1, last) - 1;
        let (a, b) = (self.times[segment], self.times[segment + 1]);
        At {
            segment,
            s: ((t - a) / (b - a)).clamp(0.0, 1.0) as f32,
            length: (b - a) as f32,
        }
    }

    /// Corner `c` of the triangle in leaf slot `i` at `at`.
    #[inline]
    fn corner(&self, at: At, i: usize, c: usize) -> Vec3 {
        let k = at.segment;
        let p0 = self.corners[k][i][c];
        let Some(next) = self.corners.get(k + 1) else {
            return p0;
        };
        let p1 = next[i][c];
        if self.velocities.is_empty() {
            return p0.lerp(p1, at.s);
        }
        // Cubic Hermite: positions and velocities (per second, so scaled by the segment's
        // length) at both ends.
        let (v0, v1) = (
            self.velocities[k][i][c] * at.length,
            self.velocities[k + 1][i][c] * at.length,
        );
        let s = at.s;
        let (s2, s3) = (s * s, s * s * s);
        p0 * (2.0 * s3 - 3.0 * s2 + 1.0)
            + v0 * (s3 - 2.0 * s2 + s)
            + p1 * (-2.0 * s3 + 3.0 * s2)
            + v1 * (s3 - s2)
    }

    /// Triangle `i` (of the mesh as given) at time `t`, in object space.
    pub fn triangle(&self, i: u32, t: f64) -> Triangle {
        self.triangle_at(self.at(t), self.slot_of[i as usize] as usize)
    }

    /// The shading normal of triangle `i` (of the mesh as given) at time `t` and barycentrics
    /// `b1`, `b2`, in object space and not yet unit length: each corner's normal turned
    /// between the two samples around `t` (unit length, as a still mesh's are), then blended
    /// across the triangle. `None` without normals.
    pub fn normal(&self, i: u32, t: f64, b1: f32, b2: f32) -> Option<Vec3> {
        if self.normals.is_empty() {
            return None;
        }
        let (at, slot) = (self.at(t), self.slot_of[i as usize] as usize);
        let corner = |c: usize| {
            let n0 = self.normals[at.segment][slot][c].unpack();
            match self.normals.get(at.segment + 1) {
                Some(next) => n0.lerp(next[slot][c].unpack(), at.s).normalize_or(n0),
                None => n0,
            }
        };
        Some(corner(0) * (1.0 - b1 - b2) + corner(1) * b1 + corner(2) * b2)
    }

    #[inline]
    fn triangle_at(&self, at: At, i: usize) -> Triangle {
        Triangle {
            v: [0, 1, 2].map(|c| self.corner(at, i, c)),
        }
    }

    /// Closest hit along `origin + t·dir` (object space), t in (0, t_max), at time `time`,
    /// among the triangles `accept(first_id + i, t)` admits; scene-wide indices from `first_id`.
    pub fn intersect(
        &self,
        (origin, dir): (Vec3, Vec3),
        t_max: f32,
        time: f64,
        first_id: u32,
        accept: &impl Fn(u32, f32) -> bool,
    ) -> Option<TriangleHit> {
        let at = self.at(time);
        let nodes = self.slices.get(at.segment)?;
        let sheared = ShearedRay::new(origin, dir);
        let mut found = None;
        closest_hit(
            nodes,
            &Swept { at: at.s },
            &BoxRay::new(origin, dir),
            t_max,
            NOTHING_TO_FETCH,
            false,
            |slot, range| {
                let tri = self.triangle_at(at, slot);
                let (t, b1, b2) = intersect_watertight(&sheared, &tri, range)?;
                let triangle = first_id + self.leaf_triangles[slot];
                accept(triangle, t).then_some(())?;
                found = Some(TriangleHit {
                    t,
                    triangle,
                    b1,
                    b2,
                });
                Some(t)
            },
        );
        found
    }

    /// True when an admitted triangle lies along `origin + t·dir`, t in (0, t_max), at `time`.
    pub fn occluded(
        &self,
        (origin, dir): (Vec3, Vec3),
        t_max: f32,
        time: f64,
        first_id: u32,
        accept: &impl Fn(u32, f32) -> bool,
    ) -> bool {
        let at = self.at(time);
        let Some(nodes) = self.slices.get(at.segment) else {
            return false;
        };
        let sheared = ShearedRay::new(origin, dir);
        any_hit(
            nodes,
            &Swept { at: at.s },
            &BoxRay::new(origin, dir),
            t_max,
            NOTHING_TO_FETCH,
            false,
            |slot| {
                let tri = self.triangle_at(at, slot);
                intersect_watertight(&sheared, &tri, t_max)
                    .is_some_and(|(t, ..)| accept(first_id + self.leaf_triangles[slot], t))
            },
        )
    }
}

/// Bytes `meshes` hold, each counted once however many copies share it.
pub fn shared_bytes<'a>(
    meshes: impl IntoIterator<Item = &'a std::sync::Arc<Deformation>>,
) -> usize {
    let mut seen: Vec<*const Deformation> = Vec::new();
    let mut bytes = 0;
    for mesh in meshes {
        if !seen.contains(&std::sync::Arc::as_ptr(mesh)) {
            seen.push(std::sync::Arc::as_ptr(mesh));
            bytes += mesh.bytes();
        }
    }
    bytes
}

/// The leaf tests read the cache by triangle, not by slot: nothing to fetch ahead.
const NOTHING_TO_FETCH: &[u32] = &[];

#[cfg(test)]
mod tests {
    use super::*;

    /// One triangle in the plane z = 0 moving along +x from x = 0 to x = 2 over one second.
    fn sliding(velocities: bool) -> Deformation {
        let tri = |x: f32| {
            [
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x + 1.0, 0.0, 0.0),
                Vec3::new(x, 1.0, 0.0),
            ]
        };
        let v = Vec3::new(2.0, 0.0, 0.0);
        Deformation::new(Samples {
            times: vec![0.0, 1.0],
            corners: vec![vec![tri(0.0)], vec![tri(2.0)]],
            velocities: if velocities {
                vec![vec![[v; 3]], vec![[v; 3]]]
            } else {
                Vec::new()
            },
            normals: Vec::new(),
        })
    }

    #[test]
    fn a_ray_meets_the_triangle_where_it_is_at_the_rays_time() {
        let mesh = sliding(false);
        let down = (Vec3::new(1.2, 0.2, 1.0), Vec3::NEG_Z);
        // At t = 0 the triangle spans x in [0, 1): x = 1.2 misses; at t = 0.5 it spans
        // [1, 2) and is hit at distance 1.
        assert!(mesh.intersect(down, 10.0, 0.0, 0, &|_, _| true).is_none());
        let hit = mesh.intersect(down, 10.0, 0.5, 7, &|_, _| true).unwrap();
        assert_eq!(hit.triangle, 7);
        assert!((hit.t - 1.0).abs() < 1e-6);
        assert!(mesh.occluded(down, 10.0, 0.5, 0, &|_, _| true));
        assert!(!mesh.occluded(down, 0.5, 0.5, 0, &|_, _| true));
        // Before the first sample and after the last, the mesh holds its end shapes.
        assert_eq!(mesh.triangle(0, -3.0), mesh.triangle(0, 0.0));
        assert_eq!(mesh.triangle(0, 9.0).v[0], Vec3::new(2.0, 0.0, 0.0));
    }

    #[test]
    fn velocities_bend_the_path_and_the_boxes_hold_it() {
        // Still ends but a velocity at each: the corner swings out and back along x.
        let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let v = Vec3::new(4.0, 0.0, 0.0);
        let mesh = Deformation::new(Samples {
            times: vec![0.0, 1.0],
            corners: vec![vec![tri], vec![tri]],
            velocities: vec![vec![[v; 3]], vec![[v; 3]]],
            normals: Vec::new(),
        });
        // Hermite with v0 = v1 = 4: x(s) = 4(s − 2s² + s³) + 4(s³ − s²) = 4s − 12s² + 8s³.
        for s in [0.1f64, 0.3, 0.5, 0.8] {
            let x = mesh.triangle(0, s).v[0].x as f64;
            let expected = 4.0 * s - 12.0 * s * s + 8.0 * s * s * s;
            assert!((x - expected).abs() < 1e-5, "s = {s}: {x} vs {expected}");
            // A ray straight down onto the moved corner's neighbourhood hits at every time.
            let p = mesh.triangle(0, s).point(0.2, 0.2);
            let ray = (p + Vec3::Z, Vec3::NEG_Z);
            assert!(
                mesh.intersect(ray, 2.0, s, 0, &|_, _| true).is_some(),
                "s = {s}"
            );
        }
        // Velocities along the chord give the chord back.
        let straight = sliding(true);
        for s in [0.25, 0.5, 0.75] {
            let a = straight.triangle(0, s).v[0];
            assert!((a.x - 2.0 * s as f32).abs() < 1e-5);
        }
    }

    #[test]
    fn the_filter_is_asked_with_scene_wide_indices() {
        let mesh = sliding(false);
        let down = (Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z);
        assert!(
            mesh.intersect(down, 10.0, 0.0, 40, &|i, _| i != 40)
                .is_none()
        );
        assert!(!mesh.occluded(down, 10.0, 0.0, 40, &|i, _| i != 40));
        assert!(
            mesh.intersect(down, 10.0, 0.0, 40, &|i, _| i == 40)
                .is_some()
        );
    }

    /// Normals deform with the mesh: between two samples a corner's normal turns from one to
    /// the other, across the triangle they blend by the barycentrics, and before the first
    /// sample or after the last they hold; without normals there is none.
    #[test]
    fn normals_are_read_between_the_samples_around_the_time() {
        let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let tilted = Vec3::new(1.0, 0.0, 1.0).normalize();
        let mesh = Deformation::new(Samples {
            times: vec![0.0, 1.0],
            corners: vec![vec![tri], vec![tri]],
            velocities: Vec::new(),
            normals: vec![vec![[Vec3::Z; 3]], vec![[Vec3::Z, tilted, Vec3::Z]]],
        });
        let at = |t: f64, b1: f32| mesh.normal(0, t, b1, 0.0).unwrap().normalize();
        assert!(at(0.5, 0.0).abs_diff_eq(Vec3::Z, 1e-4));
        let half = (Vec3::Z + 0.5 * (tilted - Vec3::Z)).normalize();
        assert!(at(0.5, 1.0).abs_diff_eq(half, 1e-4), "{}", at(0.5, 1.0));
        assert!(at(2.0, 1.0).abs_diff_eq(tilted, 1e-4));
        assert!(at(-1.0, 1.0).abs_diff_eq(Vec3::Z, 1e-4));
        assert!(sliding(false).normal(0, 0.5, 0.2, 0.2).is_none());
    }
}
