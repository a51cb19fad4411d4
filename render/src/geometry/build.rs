//! How every wide BVH is built: obvhs' PLOC clustering, its reinsertion pass and its conversion
//! to the compressed wide layout, with one change. PLOC first orders the primitives along a
//! Morton curve, and obvhs takes the codes in the scene's box with each axis normalised on its
//! own; a flat scene (a height field, a ring of strands, a grid of loops) then has its thin
//! axis stretched to the length of the others, and every third bit of the code splits the
//! primitives by height alone. Clusters pair primitives from all over the plane, and a ray
//! meets overlapping boxes at every level. Here the codes are taken in the cube around the
//! box, so every axis counts by its length. On `rift bench scaling`'s grid of loops (10⁶ strand
//! segments) a ray visited 26 nodes of the still grid and 29 of the spinning one with obvhs'
//! codes (10 with its slowest build), and visits 7.8 and 8.4 with the cube, at the same build
//! cost: from 10² to 10⁶ segments 1.8, 3.2, 5.0, 6.4, 7.8, the logarithmic growth a BVH
//! promises. A query on the spinning grid took 1.0 µs and takes 0.33.

use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::node::Bvh2Node;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh;
use obvhs::ploc::{PlocBuilder, PlocSearchDistance};

/// The compressed wide BVH over `boxes` (its primitive indices index them), built as `params`
/// say: search distance, search depth threshold, sort precision, reinsertion and leaf size
/// (`pre_split` does not apply to boxes and is ignored).
pub fn wide_bvh(boxes: &[Aabb], params: BvhBuildParams) -> CwBvh {
    let mut bvh2 = clustered(boxes, params);
    ReinsertionOptimizer::default().run(&mut bvh2, params.reinsertion_batch_ratio, None);
    bvh2_to_cwbvh(&bvh2, params.max_prims_per_leaf.clamp(1, 3), true, false)
}

/// PLOC's binary tree over `boxes`, with the codes in [`cube_around`] them. The builder's
/// buffers (three as long as `boxes`) are freed on return, before the steps that follow
/// allocate theirs: held through them, they raised the peak of a 10⁷-triangle build by 0.9 GB.
fn clustered(boxes: &[Aabb], params: BvhBuildParams) -> Bvh2 {
    let count = boxes.len();
    let mut bvh2 = Bvh2::zeroed(count);
    bvh2.reset_for_reuse(count, Some((0..count as u32).collect()));
    // Without preallocation: the leaves are this vector, and the builder sizes the rest.
    let mut builder = PlocBuilder::new();
    builder.current_nodes = boxes
        .iter()
        .zip(0u32..)
        .map(|(b, i)| Bvh2Node::new(*b, 1, i))
        .collect();
    let cube = cube_around(boxes);
    let (precision, threshold) = (params.sort_precision, params.search_depth_threshold);
    macro_rules! ploc {
        ($distance:literal) => {
            builder
                .build_ploc_from_leaves::<$distance, false>(&mut bvh2, cube, precision, threshold)
        };
    }
    // obvhs' own search distances for each setting.
    match params.ploc_search_distance {
        PlocSearchDistance::Minimum => ploc!(1),
        PlocSearchDistance::VeryLow => ploc!(2),
        PlocSearchDistance::Low => ploc!(6),
        PlocSearchDistance::Medium => ploc!(14),
        PlocSearchDistance::High => ploc!(24),
        PlocSearchDistance::VeryHigh => ploc!(32),
    }
    bvh2
}

/// The cube centred on the box around `boxes`, as wide as its longest side (empty for none).
fn cube_around(boxes: &[Aabb]) -> Aabb {
    let total = boxes.iter().fold(Aabb::empty(), |all, b| all.union(b));
    if boxes.is_empty() {
        return total;
    }
    let half = glam::Vec3A::splat(0.5 * total.diagonal().max_element());
    let centre = total.center();
    Aabb::new(centre - half, centre + half)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Boxes of `n`×`n` small tiles spread over a wide, thin slab.
    fn flat_tiles(n: usize) -> Vec<Aabb> {
        let mut boxes = Vec::new();
        for i in 0..n {
            for j in 0..n {
                let (x, y) = (i as f32, j as f32);
                let z = 0.01 * ((i * 7 + j * 3) % 5) as f32;
                let lo = glam::Vec3A::new(x, y, z);
                boxes.push(Aabb::new(lo, lo + glam::Vec3A::new(0.8, 0.8, 0.001)));
            }
        }
        boxes
    }

    /// Summed half-areas of every node's child boxes over the root's: what a ray through the
    /// scene expects to test, up to constants (the surface area heuristic).
    fn expected_tests(bvh: &CwBvh) -> f64 {
        let half_area = |b: &Aabb| b.half_area() as f64;
        let root = bvh.total_aabb;
        bvh.nodes
            .iter()
            .map(|node| {
                (0..8)
                    .filter(|&k| !node.is_child_empty(k))
                    .map(|k| half_area(&node.child_aabb(k)))
                    .sum::<f64>()
            })
            .sum::<f64>()
            / half_area(&root)
    }

    #[test]
    fn every_box_is_a_primitive_once_and_flat_scenes_cluster_by_place() {
        let boxes = flat_tiles(64);
        let bvh = wide_bvh(&boxes, BvhBuildParams::medium_build());
        let mut seen = bvh.primitive_indices.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..boxes.len() as u32).collect::<Vec<_>>());
        // obvhs' own build, whose codes stretch the thin axis, expects more box tests.
        let stretched = obvhs::cwbvh::builder::build_cwbvh(
            &boxes,
            BvhBuildParams::medium_build(),
            &mut Default::default(),
        );
        let (cubic, own) = (expected_tests(&bvh), expected_tests(&stretched));
        assert!(cubic < 0.8 * own, "cube {cubic:.1}, per-axis {own:.1}");
    }

    #[test]
    fn no_boxes_make_an_empty_tree() {
        assert!(
            wide_bvh(&[], BvhBuildParams::medium_build())
                .primitive_indices
                .is_empty()
        );
    }
}
