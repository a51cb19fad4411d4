//! Child boxes of a wide BVH made again from other primitive boxes, its layout kept: a moving
//! ring keeps its tree's nodes once for each time slice, refit to where the segments are at
//! the slice's start and at its end, both on one grid per node, and a ray at any time in the
//! slice sees boxes moved linearly between the two (see [`super::wide_bvh::Swept`]). Boxes
//! over a whole slice grow by the motion (a fast ring's segment sweeps several times its
//! length), which made a moving ring's queries test twice as many segments as a still one's.
//! The two plane sets share the node's layout and grid, so a visit reads one node of two
//! cache lines.

use super::wide_bvh::{SweptNode, inner_child, leaf_slots};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::node::CwBvhNode;

/// The largest quantized plane: a node's grid has 255 steps across its box.
const STEPS: f64 = 255.0;

/// The nodes of `bvh` for a slice whose primitives have the boxes `start` at its start and
/// `end` at its end (one per primitive, as `bvh.primitive_indices` names them): a leaf's boxes
/// hold its primitives' boxes, an inner child's its node's, each quantized outward on a grid
/// spanning the node at both ends. Nothing else changes, so the result traverses with
/// `bvh`'s topology and primitive order.
pub fn refit_slice(bvh: &CwBvh, start: &[Aabb], end: &[Aabb]) -> Vec<SweptNode> {
    let mut nodes: Vec<SweptNode> = bvh
        .nodes
        .iter()
        .map(|&node| SweptNode {
            start: node,
            end: [[0; 8]; 6],
        })
        .collect();
    let mut whole = vec![[Aabb::empty(); 2]; nodes.len()];
    // Children come after their parent in the layout, so a backward pass meets every child
    // before the node that holds it.
    for index in (0..nodes.len()).rev() {
        let layout = &bvh.nodes[index];
        let children = [(start, 0), (end, 1)].map(|(boxes, side)| {
            std::array::from_fn(|slot| child_box(bvh, layout, slot, boxes, &whole, side))
        });
        let [at_start, at_end] = children.map(|c: [Option<Aabb>; 8]| {
            c.iter()
                .flatten()
                .fold(Aabb::empty(), |all, b| all.union(b))
        });
        let node = &mut nodes[index];
        if let Some(grid) = Grid::spanning(&at_start.union(&at_end)) {
            grid.place(&mut node.start);
            grid.quantize(&children[0], plane_rows_mut(&mut node.start));
            grid.quantize(&children[1], node.end.each_mut());
        }
        whole[index] = [at_start, at_end];
    }
    nodes
}

/// The box of `node`'s child in `slot` (`None` when the slot is empty) at one end of the
/// slice (`side` 0 the start, 1 the end): its primitives' `boxes` for a leaf, its node's
/// (already refit, in `whole`) for an inner child.
fn child_box(
    bvh: &CwBvh,
    node: &CwBvhNode,
    slot: usize,
    boxes: &[Aabb],
    whole: &[[Aabb; 2]],
    side: usize,
) -> Option<Aabb> {
    let meta = node.child_meta[slot];
    if meta == 0 {
        return None;
    }
    if node.imask & (1 << slot) != 0 {
        return whole.get(inner_child(node, slot) as usize).map(|b| b[side]);
    }
    let run = leaf_slots(node, slot);
    let leaf = bvh
        .primitive_indices
        .get(run.start as usize..run.end as usize)?;
    Some(
        leaf.iter()
            .fold(Aabb::empty(), |all, &i| all.union(&boxes[i as usize])),
    )
}

/// What a ray query through `nodes` (one time slice's) is expected to cost, by the surface
/// area heuristic: each child box's area, the mean of the slice's two ends, over `reference`'s
/// area (so a random ray through `reference` meets it that often), times what meeting it costs:
/// a node visit for an inner child, a test for each of a leaf's primitives.
pub fn expected_cost(nodes: &[SweptNode], reference: &Aabb) -> f64 {
    let whole = reference.half_area() as f64;
    if nodes.is_empty() || whole.is_nan() || whole <= 0.0 {
        return 0.0;
    }
    let mut cost = 1.0;
    for node in nodes {
        let layout = &node.start;
        let step = layout.e.map(|e| ((e as i32 - 127) as f64).exp2());
        let rows = [plane_rows(layout), node.end.each_ref()];
        for slot in 0..8 {
            let meta = layout.child_meta[slot];
            if meta == 0 {
                continue;
            }
            let area: f64 = rows
                .iter()
                .map(|rows| {
                    let extent = |a: usize| {
                        (rows[2 * a + 1][slot] as f64 - rows[2 * a][slot] as f64) * step[a]
                    };
                    let (x, y, z) = (extent(0), extent(1), extent(2));
                    x * y + y * z + z * x
                })
                .sum::<f64>()
                * 0.5;
            let meets = if layout.imask & (1 << slot) != 0 {
                1.0
            } else {
                (meta >> 5).count_ones() as f64
            };
            cost += meets * area / whole;
        }
    }
    cost
}

/// `node`'s plane rows, in [`Grid::quantize`]'s order.
fn plane_rows(node: &CwBvhNode) -> [&[u8; 8]; 6] {
    [
        &node.child_min_x,
        &node.child_max_x,
        &node.child_min_y,
        &node.child_max_y,
        &node.child_min_z,
        &node.child_max_z,
    ]
}

/// A node's origin and, per axis, the power-of-two step of its 255-step grid.
struct Grid {
    origin: glam::Vec3,
    exponents: [i32; 3],
}

impl Grid {
    /// The finest grid from `all`'s lower corner that spans it; `None` for an empty box.
    fn spanning(all: &Aabb) -> Option<Self> {
        let (lo, hi) = (glam::Vec3::from(all.min), glam::Vec3::from(all.max));
        if !lo.cmple(hi).all() {
            return None;
        }
        Some(Self {
            origin: lo,
            exponents: std::array::from_fn(|a| grid_exponent(hi[a] as f64 - lo[a] as f64)),
        })
    }

    /// Writes the grid into `node`'s origin and exponents.
    fn place(&self, node: &mut CwBvhNode) {
        node.p = self.origin;
        node.e = self.exponents.map(|e| (e + 127) as u8);
    }

    /// Writes the planes of the boxes `children` into `rows` (lower x, upper x, lower y, ...),
    /// rounded outward in double precision, where the grid's steps are exact, so a decoded box
    /// always holds its child.
    fn quantize(&self, children: &[Option<Aabb>; 8], rows: [&mut [u8; 8]; 6]) {
        for (r, row) in rows.into_iter().enumerate() {
            let (axis, upper) = (r / 2, r % 2 == 1);
            let low = self.origin[axis] as f64;
            let step = (self.exponents[axis] as f64).exp2();
            for (slot, child) in children.iter().enumerate() {
                row[slot] = child.map_or(0, |b| {
                    let steps = if upper {
                        ((b.max[axis] as f64 - low) / step).ceil()
                    } else {
                        ((b.min[axis] as f64 - low) / step).floor()
                    };
                    steps.clamp(0.0, STEPS) as u8
                });
            }
        }
    }
}

/// `node`'s plane rows, writable, in [`Grid::quantize`]'s order.
fn plane_rows_mut(node: &mut CwBvhNode) -> [&mut [u8; 8]; 6] {
    [
        &mut node.child_min_x,
        &mut node.child_max_x,
        &mut node.child_min_y,
        &mut node.child_max_y,
        &mut node.child_min_z,
        &mut node.child_max_z,
    ]
}

/// The power of two (as its exponent) of the finest grid whose 255 steps span `extent`,
/// kept among normal single-precision numbers.
fn grid_exponent(extent: f64) -> i32 {
    let mut exponent = (extent.max(1e-30) / STEPS).log2().ceil() as i32;
    while (exponent as f64).exp2() * STEPS < extent {
        exponent += 1;
    }
    exponent.clamp(-126, 127)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::wide_bvh::{BoxRay, ChildBoxes, Fixed, Swept, WideNode, any_hit};
    use glam::Vec3;
    use obvhs::BvhBuildParams;
    use obvhs::cwbvh::builder::build_cwbvh;

    /// Small boxes scattered through a cube, and the same boxes moved by `shift` each.
    fn scattered(shift: impl Fn(usize) -> Vec3) -> (Vec<Aabb>, Vec<Aabb>) {
        (0..500)
            .map(|i| {
                let f = i as f32;
                let c = Vec3::new((f * 0.37).sin(), (f * 0.71).cos(), (f * 0.13).sin()) * 3.0;
                let r = Vec3::splat(0.01 + 0.02 * (f * 0.5).cos().abs());
                let at = |c: Vec3| Aabb::new((c - r).into(), (c + r).into());
                (at(c), at(c + shift(i)))
            })
            .unzip()
    }

    /// The box of child `slot` of node `index` of `nodes` as a ray test sees it holds `b`: rays
    /// through each of its corners hit the slot.
    fn holds_box<B: ChildBoxes>(boxes: &B, nodes: &[B::Node], index: usize, slot: usize, b: &Aabb) {
        let (lo, hi) = (Vec3::from(b.min), Vec3::from(b.max));
        for corner in 0..8 {
            let pick = |bit: usize, a: f32, z: f32| if corner >> bit & 1 == 0 { a } else { z };
            let p = Vec3::new(
                pick(0, lo.x, hi.x),
                pick(1, lo.y, hi.y),
                pick(2, lo.z, hi.z),
            );
            let from = p + Vec3::new(0.3, 0.2, 1.0) * 100.0;
            let ray = BoxRay::new(from, (p - from).normalize());
            let hits = boxes.slab_hits::<false>(&nodes[index], &ray, f32::INFINITY);
            assert!(
                hits & (1 << slot) != 0,
                "node {index} slot {slot} misses corner {p}"
            );
        }
    }

    /// Checks `nodes` (of `bvh`'s layout) with `boxes` against the boxes `inside(i)` that lie
    /// within primitive i's: every leaf's box holds its primitives', and a ray at each
    /// primitive's centre finds it through every box above.
    fn check<B: ChildBoxes>(
        bvh: &CwBvh,
        nodes: &[B::Node],
        boxes: &B,
        inside: impl Fn(u32) -> Aabb,
    ) {
        for (index, node) in nodes.iter().enumerate() {
            let node = node.layout();
            for slot in 0..8 {
                let meta = node.child_meta[slot];
                if meta == 0 || node.imask & (1 << slot) != 0 {
                    continue;
                }
                for primitive in leaf_slots(node, slot) {
                    let b = inside(bvh.primitive_indices[primitive as usize]);
                    holds_box(boxes, nodes, index, slot, &b);
                }
            }
        }
        for i in 0..bvh.primitive_indices.len() as u32 {
            let b = inside(i);
            let centre = Vec3::from(b.center());
            let from = centre + Vec3::new(-0.4, 1.0, 0.2) * 50.0;
            let ray = BoxRay::new(from, (centre - from).normalize());
            let none: &[Aabb] = &[];
            let found = any_hit(nodes, boxes, &ray, f32::INFINITY, none, false, |slot| {
                bvh.primitive_indices[slot] == i
            });
            assert!(
                found,
                "primitive {i} is not found through the boxes above it"
            );
        }
    }

    /// Every child box, at a slice's start, its end and between, holds its primitives moved
    /// linearly, and every box above holds those; refit to where the primitives stand, the
    /// tree holds them as built.
    #[test]
    fn refit_boxes_hold_their_primitives_at_both_ends_and_between() {
        let (start, end) = scattered(|i| Vec3::new(0.5, -0.2, (i % 7) as f32 * 0.1));
        let bvh = build_cwbvh(
            &start,
            BvhBuildParams::medium_build(),
            &mut Default::default(),
        );
        let slice = refit_slice(&bvh, &start, &end);
        // A box a thousandth smaller than the primitive's at fraction `at`.
        let inside = |i: u32, at: f32| {
            let (a, b) = (&start[i as usize], &end[i as usize]);
            let mix = |x: Vec3, y: Vec3| x + (y - x) * at;
            let (lo, hi) = (
                mix(a.min.into(), b.min.into()),
                mix(a.max.into(), b.max.into()),
            );
            let shrink = |v: Vec3, toward: Vec3| v + (toward - v) * 1e-3;
            Aabb::new(shrink(lo, hi).into(), shrink(hi, lo).into())
        };
        for at in [0.0f32, 0.3, 1.0] {
            check(&bvh, &slice, &Swept { at }, |i| inside(i, at));
        }
        // A slice that stands still: its start planes alone are a tree of fixed boxes.
        let still: Vec<CwBvhNode> = refit_slice(&bvh, &start, &start)
            .iter()
            .map(|node| node.start)
            .collect();
        check(&bvh, &still, &Fixed, |i| inside(i, 0.0));
    }

    /// By Cauchy's formula, a uniformly random line through a convex body meets a convex part
    /// of it with the ratio of their surface areas as probability: lines through the box of
    /// everything, counted through each child box at the slice's two ends (each leaf once per
    /// primitive), meet on average what [`expected_cost`] expects.
    #[test]
    fn expected_cost_is_what_random_lines_through_the_tree_meet() {
        let (start, end) = scattered(|i| Vec3::new(0.4, 0.0, (i % 5) as f32 * 0.2));
        let bvh = build_cwbvh(
            &start,
            BvhBuildParams::medium_build(),
            &mut Default::default(),
        );
        let nodes = refit_slice(&bvh, &start, &end);
        let reference = start
            .iter()
            .chain(&end)
            .fold(Aabb::empty(), |all, b| all.union(b));
        let expected = expected_cost(&nodes, &reference);
        let (lo, hi) = (Vec3::from(reference.min), Vec3::from(reference.max));
        let (centre, radius) = ((lo + hi) * 0.5, (hi - lo).length() * 0.5);
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut uniform = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let (mut met, mut lines) = (0.0f64, 0u32);
        while lines < 20_000 {
            // A uniformly random line meeting the sphere around the box: a direction on the
            // sphere and a point of the disk across it, kept when it meets the box.
            let z = 2.0 * uniform() - 1.0;
            let phi = std::f32::consts::TAU * uniform();
            let r = (1.0 - z * z).max(0.0).sqrt();
            let dir = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            let (u, v) = dir.any_orthonormal_pair();
            let (rho, theta) = (radius * uniform().sqrt(), std::f32::consts::TAU * uniform());
            let through = centre + (u * theta.cos() + v * theta.sin()) * rho;
            let ray = BoxRay::new(through - dir * (4.0 * radius), dir);
            if ray.enters(lo, hi, f32::INFINITY).is_none() {
                continue;
            }
            lines += 1;
            met += 1.0;
            for at in [0.0, 1.0] {
                for node in &nodes {
                    let mut hits = Swept { at }.slab_hits::<false>(node, &ray, f32::INFINITY);
                    while hits != 0 {
                        let slot = hits.trailing_zeros() as usize;
                        hits &= hits - 1;
                        let layout = node.layout();
                        met += 0.5
                            * if layout.imask & (1 << slot) != 0 {
                                1.0
                            } else {
                                leaf_slots(layout, slot).len() as f64
                            };
                    }
                }
            }
        }
        let measured = met / lines as f64;
        assert!(
            (measured / expected - 1.0).abs() < 0.03,
            "random lines meet {measured:.3} boxes, the heuristic expects {expected:.3}"
        );
        assert!(
            expected > 3.0,
            "a tree of 500 boxes expects more than its root"
        );
    }

    #[test]
    fn grids_are_the_finest_power_of_two_that_spans_the_box() {
        for extent in [1e-9, 0.1, 1.0, 255.0, 256.0, 3.7e5] {
            let e = grid_exponent(extent);
            let step = (e as f64).exp2();
            assert!(step * STEPS >= extent, "{extent}: step {step} too fine");
            assert!(
                step * 0.5 * STEPS < extent,
                "{extent}: step {step} too coarse"
            );
        }
    }
}
