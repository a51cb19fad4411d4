//! One bottom-level acceleration structure: an obvhs compressed wide BVH (CWBVH) over a run of
//! triangles (a static scene part in world space, or one moving object in its own space), with
//! closest-hit and occlusion queries using the watertight triangle test.

use super::build::wide_bvh;
use super::triangle::{PackedTriangles, ShearedRay, Triangle};
use super::wide_bvh::{BoxRay, LeafTest, node_bytes, traverse_compiled, worth_fetching_ahead};
use glam::Vec3;
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::cwbvh::CwBvh;

/// Meshes up to this many triangles get obvhs' slow build (a wider search for neighbours to
/// pair, more reinsertion): 0.13 s at this size against 0.09 s. The Cornell box renders 3%
/// faster with it; on 2M triangles it doubles the build time (1.5 to 3 s) for no measurable
/// gain in tracing, so large meshes keep the medium build.
const CAREFUL_BUILD_TRIANGLES: usize = 1 << 17;

/// The compressed wide BVH over `triangles` (its primitive indices index them).
pub(crate) fn build_cwbvh(triangles: &[Triangle]) -> CwBvh {
    let boxes: Vec<Aabb> = triangles
        .iter()
        .map(|t| {
            let (lo, hi) = (
                t.v[0].min(t.v[1]).min(t.v[2]),
                t.v[0].max(t.v[1]).max(t.v[2]),
            );
            Aabb::new(lo.into(), hi.into())
        })
        .collect();
    // obvhs' splitting of large triangles (`pre_split`) does not apply to boxes: it gained
    // nothing on the Cornell box and stored a split triangle once per piece.
    let params = if triangles.len() <= CAREFUL_BUILD_TRIANGLES {
        BvhBuildParams::slow_build()
    } else {
        BvhBuildParams::medium_build()
    };
    wide_bvh(&boxes, params)
}

/// A closest hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    /// Ray parameter: distance in units of the ray direction's length.
    pub t: f32,
    /// Scene-wide index of the triangle.
    pub triangle: u32,
    /// Barycentrics of the hit: p = (1 − b1 − b2)·v0 + b1·v1 + b2·v2.
    pub b1: f32,
    pub b2: f32,
}

/// BVH plus triangles in leaf order.
pub struct TriangleBvh {
    bvh: Option<CwBvh>,
    /// Triangles in the BVH's primitive order.
    leaf_triangles: PackedTriangles,
    /// Scene-wide index of each leaf triangle.
    leaf_ids: Vec<u32>,
}

impl TriangleBvh {
    /// Builds over `triangles` (any count, including none), whose scene-wide indices start at
    /// `first_id`.
    pub fn build(triangles: &[Triangle], first_id: u32) -> Self {
        if triangles.is_empty() {
            return Self {
                bvh: None,
                leaf_triangles: PackedTriangles::new(std::iter::empty()),
                leaf_ids: Vec::new(),
            };
        }
        let mut bvh = build_cwbvh(triangles);
        bvh.nodes = crate::platform::huge_pages::adopt(bvh.nodes);
        let leaf_triangles =
            PackedTriangles::new(bvh.primitive_indices.iter().map(|&i| triangles[i as usize]));
        let leaf_ids = crate::platform::huge_pages::collect(
            bvh.primitive_indices.iter().map(|&i| i + first_id),
        );
        Self {
            bvh: Some(bvh),
            leaf_triangles,
            leaf_ids,
        }
    }

    /// Closest hit along `origin + t·dir` for t in (0, t_max) among the triangles that
    /// `accept(scene-wide index, t)` admits (the others are looked through).
    pub fn intersect(
        &self,
        origin: Vec3,
        dir: Vec3,
        t_max: f32,
        accept: &impl Fn(u32, f32) -> bool,
    ) -> Option<TriangleHit> {
        crate::platform::cpu::run(Query::<_, true> {
            bvh: self,
            origin,
            dir,
            t_max,
            accept,
        })
        .nearest
    }

    /// True when an admitted triangle lies along `origin + t·dir` for t in (0, t_max).
    pub fn occluded(
        &self,
        origin: Vec3,
        dir: Vec3,
        t_max: f32,
        accept: &impl Fn(u32, f32) -> bool,
    ) -> bool {
        crate::platform::cpu::run(Query::<_, false> {
            bvh: self,
            origin,
            dir,
            t_max,
            accept,
        })
        .blocked
    }
}

/// A query of one tree along `origin + t·dir`, t in (0, t_max), for the nearest admitted hit
/// (`NEAREST`) or any: the ray set-up, traversal and leaf tests in one compilation
/// ([`crate::platform::cpu::run`]).
struct Query<'a, A, const NEAREST: bool> {
    bvh: &'a TriangleBvh,
    origin: Vec3,
    dir: Vec3,
    t_max: f32,
    accept: &'a A,
}

/// What a [`Query`] found.
struct Found {
    nearest: Option<TriangleHit>,
    blocked: bool,
}

impl<A: Fn(u32, f32) -> bool, const NEAREST: bool> crate::platform::cpu::TwoWays
    for Query<'_, A, NEAREST>
{
    type Output = Found;

    #[inline(always)]
    unsafe fn run<const AVX2: bool>(self) -> Found {
        let Query {
            bvh: this,
            origin,
            dir,
            t_max,
            accept,
        } = self;
        let mut found = Found {
            nearest: None,
            blocked: false,
        };
        let Some(bvh) = this.bvh.as_ref() else {
            return found;
        };
        let (ray, sheared) = (BoxRay::new(origin, dir), ShearedRay::new(origin, dir));
        let fetch_ahead = worth_fetching_ahead(node_bytes(bvh));
        let (nodes, leaves) = (&bvh.nodes, &this.leaf_triangles);
        let mut range = t_max;
        // SAFETY (both): `AVX2` comes from `crate::platform::cpu::run`.
        if NEAREST {
            let mut test = NearestTriangle {
                sheared,
                bvh: this,
                accept,
                fetch_ahead,
                nearest: None,
            };
            unsafe {
                traverse_compiled::<AVX2, _>(
                    nodes,
                    &ray,
                    &mut range,
                    leaves,
                    fetch_ahead,
                    &mut test,
                );
            }
            found.nearest = test.nearest.map(|(slot, b1, b2)| TriangleHit {
                t: range,
                triangle: this.leaf_ids[slot],
                b1,
                b2,
            });
        } else {
            let mut test = AnyTriangle {
                sheared,
                bvh: this,
                accept,
                t_max,
            };
            found.blocked = unsafe {
                traverse_compiled::<AVX2, _>(
                    nodes,
                    &ray,
                    &mut range,
                    leaves,
                    fetch_ahead,
                    &mut test,
                )
            };
        }
        found
    }
}

/// The closest-hit leaf test: the watertight triangle test, then the filter.
struct NearestTriangle<'a, A> {
    sheared: ShearedRay,
    bvh: &'a TriangleBvh,
    accept: &'a A,
    /// Whether the tree is big enough that its data is fetched ahead.
    fetch_ahead: bool,
    /// The nearest admitted hit so far: its slot and barycentrics.
    nearest: Option<(usize, f32, f32)>,
}

impl<A: Fn(u32, f32) -> bool> LeafTest for NearestTriangle<'_, A> {
    #[inline(always)]
    fn test(&mut self, slot: usize, range: &mut f32) -> bool {
        if let Some((t, b1, b2)) = self
            .bvh
            .leaf_triangles
            .intersect(slot, &self.sheared, *range)
            && (self.accept)(self.bvh.leaf_ids[slot], t)
        {
            *range = t;
            self.nearest = Some((slot, b1, b2));
            // The hit's scene-wide index is read once the traversal ends; on a big mesh it
            // would wait on memory then (about 5% of a closest-hit query's time).
            if self.fetch_ahead {
                crate::platform::prefetch::prefetch(&self.bvh.leaf_ids[slot..=slot]);
            }
        }
        false
    }
}

/// The occlusion leaf test: any admitted hit within `t_max` stops the traversal.
struct AnyTriangle<'a, A> {
    sheared: ShearedRay,
    bvh: &'a TriangleBvh,
    accept: &'a A,
    t_max: f32,
}

impl<A: Fn(u32, f32) -> bool> LeafTest for AnyTriangle<'_, A> {
    #[inline(always)]
    fn test(&mut self, slot: usize, _: &mut f32) -> bool {
        (self.bvh.leaf_triangles)
            .intersect(slot, &self.sheared, self.t_max)
            .is_some_and(|(t, ..)| (self.accept)(self.bvh.leaf_ids[slot], t))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::triangle::intersect_watertight;

    const ALL: fn(u32, f32) -> bool = |_, _| true;

    fn grid(n: usize) -> Vec<Triangle> {
        let mut out = Vec::new();
        for i in 0..n {
            for j in 0..n {
                let (x, y) = (i as f32, j as f32);
                let p = |dx: f32, dy: f32| Vec3::new(x + dx, y + dy, (x * 0.3 + y * 0.2).sin());
                out.push(Triangle {
                    v: [p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0)],
                });
                out.push(Triangle {
                    v: [p(0.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)],
                });
            }
        }
        out
    }

    #[test]
    fn matches_brute_force() {
        let tris = grid(12);
        let accel = TriangleBvh::build(&tris, 0);
        for k in 0..500 {
            let origin = Vec3::new(
                6.0 + (k as f32 * 0.7).sin() * 5.0,
                6.0 + (k as f32 * 1.3).cos() * 5.0,
                4.0,
            );
            let dir = Vec3::new(
                (k as f32 * 0.37).sin() * 0.4,
                (k as f32 * 0.53).cos() * 0.4,
                -1.0,
            )
            .normalize();
            let sheared = ShearedRay::new(origin, dir);
            let brute = tris
                .iter()
                .enumerate()
                .filter_map(|(i, t)| {
                    intersect_watertight(&sheared, t, f32::INFINITY).map(|h| (h.0, i))
                })
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let hit = accel.intersect(origin, dir, f32::INFINITY, &ALL);
            assert_eq!(
                hit.map(|h| h.triangle as usize),
                brute.map(|b| b.1),
                "ray {k}"
            );
            if let (Some(h), Some(b)) = (hit, brute) {
                // A filter that rejects the nearest triangle reveals the one behind it.
                let behind = tris
                    .iter()
                    .enumerate()
                    .filter(|&(i, _)| i != b.1)
                    .filter_map(|(i, t)| {
                        intersect_watertight(&sheared, t, f32::INFINITY).map(|h| (h.0, i))
                    })
                    .min_by(|a, b| a.0.total_cmp(&b.0));
                let skip_nearest = |tri: u32, _: f32| tri as usize != b.1;
                assert_eq!(
                    accel
                        .intersect(origin, dir, f32::INFINITY, &skip_nearest)
                        .map(|h| h.triangle as usize),
                    behind.map(|b| b.1),
                    "ray {k} behind its nearest hit"
                );
                assert_eq!(
                    accel.occluded(origin, dir, f32::INFINITY, &skip_nearest),
                    behind.is_some()
                );
                assert!((h.t - b.0).abs() < 1e-5);
                assert!(accel.occluded(origin, dir, h.t * 1.001, &ALL));
                assert!(!accel.occluded(origin, dir, h.t * 0.999, &ALL));
            }
        }
        assert!(
            TriangleBvh::build(&[], 0)
                .intersect(Vec3::ZERO, Vec3::X, 1.0, &ALL)
                .is_none()
        );
    }

    /// The baseline compilation (what a processor without AVX2 runs: the portable slab tests
    /// and bookkeeping) finds what the one `crate::platform::cpu::run` picks here finds, to the bit.
    #[test]
    fn both_compilations_find_the_same_hits() {
        let tris = grid(12);
        let accel = TriangleBvh::build(&tris, 0);
        let skip_some = |tri: u32, _: f32| tri % 5 != 2;
        let bits =
            |h: Option<TriangleHit>| h.map(|h| (h.triangle, [h.t, h.b1, h.b2].map(f32::to_bits)));
        let (mut hits, mut blocked) = (0, 0);
        for k in 0..2000 {
            let origin = Vec3::new(
                6.0 + (k as f32 * 0.7).sin() * 7.0,
                6.0 + (k as f32 * 1.3).cos() * 7.0,
                (k as f32 * 0.11).sin() * 3.0,
            );
            let dir = Vec3::new((k as f32 * 0.37).sin(), (k as f32 * 0.53).cos(), -0.6);
            for t_max in [f32::INFINITY, 2.5] {
                let nearest = |bvh: &TriangleBvh| bvh.intersect(origin, dir, t_max, &skip_some);
                let any = |bvh: &TriangleBvh| bvh.occluded(origin, dir, t_max, &skip_some);
                let picked = nearest(&accel);
                let baseline = crate::platform::cpu::with_baseline(|| nearest(&accel));
                assert_eq!(bits(baseline), bits(picked), "ray {k} to {t_max}");
                let picked_any = any(&accel);
                assert_eq!(
                    crate::platform::cpu::with_baseline(|| any(&accel)),
                    picked_any
                );
                hits += picked.is_some() as u32;
                blocked += picked_any as u32;
            }
        }
        assert!(
            hits > 200 && blocked > 200,
            "{hits} hits, {blocked} blocked"
        );
    }

    #[test]
    fn near_triangles_and_axis_aligned_rays_are_hit() {
        // The BVH library's own traversal dropped child boxes nearer than t = 1e-4 and missed flat
        // boxes along −Z (a −0.0 direction component).
        for size in [1e-3f32, 5e-5, 1e-6] {
            let tris: Vec<Triangle> = (0..64)
                .map(|k| {
                    let x = (k % 8) as f32 * size;
                    let y = (k / 8) as f32 * size;
                    Triangle {
                        v: [
                            Vec3::new(x, y, -size),
                            Vec3::new(x + size, y, -size),
                            Vec3::new(x, y + size, -size),
                        ],
                    }
                })
                .collect();
            let bvh = TriangleBvh::build(&tris, 0);
            let origin = Vec3::new(0.25 * size, 0.25 * size, 0.0);
            // Slanted, and exactly along the axis (a zero direction component).
            for dir in [Vec3::new(0.01, 0.02, -1.0).normalize(), -Vec3::Z] {
                let hit = bvh.intersect(origin, dir, f32::INFINITY, &ALL);
                let hit = hit.unwrap_or_else(|| panic!("{size} m along {dir}: missed"));
                assert!(
                    (hit.t * -dir.z - size).abs() < 1e-3 * size,
                    "{size}: t {}",
                    hit.t
                );
                assert!(bvh.occluded(origin, dir, f32::INFINITY, &ALL));
            }
        }
    }
}
