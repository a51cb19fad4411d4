//! Which openings a ray may meet: a wide BVH over the boxes of the openings that stand still,
//! so a ray's portal test visits the few openings near it rather than every opening of the
//! shot. Openings that move are tested one after another, as are a shot's one or two still
//! openings, where the tree's set-up costs more than the tests it saves.

use crate::geometry::build::wide_bvh;
use crate::geometry::ray::Ray;
use crate::geometry::wide_bvh::{BoxRay, Fixed, any_hit, closest_hit};
use glam::Vec3;
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::cwbvh::CwBvh;

/// Still openings from which a tree is built. On a wall of openings (96×96, 128 spp, one
/// thread), the list cost 0.94× the tree with one opening, 1.03× with two, 1.13× with three,
/// 1.24× with four, 1.6× with eight, 2.2× with sixteen and 6.5× with sixty-four; the showcase,
/// whose two ringed openings a ray meets less often than the wall's, rendered 4% slower with
/// a tree over its two.
pub const TREE_OPENINGS: usize = 3;

/// The openings as a ray's portal tests visit them.
#[derive(Clone, Debug, Default)]
pub enum OpeningTree {
    /// Every opening in turn (fewer than [`TREE_OPENINGS`] stand still).
    #[default]
    List,
    /// The still ones through a tree, the moving ones in turn.
    Tree {
        bvh: CwBvh,
        /// The opening of each of the tree's primitives.
        still: Vec<u32>,
        /// Openings whose frames change over the times rays can have.
        moving: Vec<u32>,
    },
}

/// The tree's leaf tests read openings through `still`, so there is nothing to fetch ahead by
/// slot (and the tree is small).
const NOTHING_TO_FETCH: &[u32] = &[];

impl OpeningTree {
    /// Over the openings of `bounds`: the box of each that stands still, `None` for each that
    /// moves.
    pub fn new(bounds: &[Option<Aabb>]) -> Self {
        let (still, moving): (Vec<u32>, Vec<u32>) =
            (0..bounds.len() as u32).partition(|&i| bounds[i as usize].is_some());
        if still.len() < TREE_OPENINGS {
            return Self::List;
        }
        let boxes: Vec<Aabb> = bounds.iter().flatten().copied().collect();
        let bvh = wide_bvh(&boxes, BvhBuildParams::medium_build());
        Self::Tree { bvh, still, moving }
    }

    /// The nearest opening along `ray` within (t_min, t_max): `meets(opening, limit)` tests
    /// one within (t_min, limit) and returns where it is met. Returns what the nearest meeting
    /// returned.
    #[inline]
    pub fn nearest<H: Copy>(
        &self,
        count: usize,
        ray: &Ray,
        mut meets: impl FnMut(usize, f32) -> Option<(f32, H)>,
    ) -> Option<H> {
        let mut best: Option<(f32, H)> = None;
        let in_turn: &[u32] = match self {
            Self::List => {
                for i in 0..count {
                    nearer(&mut meets, &mut best, i, ray.t_max);
                }
                return best.map(|b| b.1);
            }
            Self::Tree { bvh, still, moving } => {
                closest_hit(
                    &bvh.nodes,
                    &Fixed,
                    &BoxRay::new(ray.origin, ray.dir),
                    ray.t_max,
                    NOTHING_TO_FETCH,
                    false,
                    |slot, range| {
                        let i = still[bvh.primitive_indices[slot] as usize];
                        let hit = meets(i as usize, range)?;
                        best = Some(hit);
                        Some(hit.0)
                    },
                );
                moving
            }
        };
        for &i in in_turn {
            nearer(&mut meets, &mut best, i as usize, ray.t_max);
        }
        best.map(|b| b.1)
    }

    /// Calls `met(opening)` for each opening `ray` may meet within its range (a superset: the
    /// caller tests each), until it returns true; true when it did.
    #[inline]
    pub fn each(&self, count: usize, ray: &Ray, mut met: impl FnMut(usize) -> bool) -> bool {
        match self {
            Self::List => (0..count).any(met),
            Self::Tree { bvh, still, moving } => {
                any_hit(
                    &bvh.nodes,
                    &Fixed,
                    &BoxRay::new(ray.origin, ray.dir),
                    ray.t_max,
                    NOTHING_TO_FETCH,
                    false,
                    |slot| met(still[bvh.primitive_indices[slot] as usize] as usize),
                ) || moving.iter().any(|&i| met(i as usize))
            }
        }
    }
}

/// Tests opening `i` with `meets` within the nearest meeting so far (`best`, else `t_max`),
/// keeping it when it is nearer.
#[inline(always)]
fn nearer<H>(
    meets: &mut impl FnMut(usize, f32) -> Option<(f32, H)>,
    best: &mut Option<(f32, H)>,
    i: usize,
    t_max: f32,
) {
    let limit = best.as_ref().map_or(t_max, |b| b.0);
    if let Some(hit) = meets(i, limit) {
        *best = Some(hit);
    }
}

/// The box around a still opening: its bounding disk of `radius` about `centre`, facing
/// `normal` (unit), widened by `pad` on every side.
pub fn disk_box(centre: Vec3, normal: Vec3, radius: f32, pad: f32) -> Aabb {
    let reach = (Vec3::ONE - normal * normal).max(Vec3::ZERO).sqrt() * radius + pad;
    Aabb::new((centre - reach).into(), (centre + reach).into())
}
