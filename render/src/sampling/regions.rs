//! Places of the scene cut into regions, each holding what was learned there: the k-d tree
//! that learned light selection ([`crate::lights::guide`]) and bounces aimed at openings
//! ([`crate::through::bounce_guide`]) keep their per-region values in.
//!
//! The regions are the leaves of a k-d tree over the places training paths recorded something,
//! halved at the middle of their longest side until each holds no more than a number of
//! them its user chooses, so regions are small where shading is dense. A lookup, made at every shading point
//! that reads them, starts from a regular grid over the regions' box that names the deepest
//! node holding each cell (`GRID_LEVELS`).

use glam::Vec3;
use rayon::prelude::*;
use std::ops::Range;

/// Deepest halving of the regions.
const MAX_DEPTH: u32 = 48;
/// Halvings of the regions' box that a lookup skips through a regular grid of 2^this cells
/// (64 KiB): each cell names the deepest node whose region holds it whole, where the lookup
/// goes on. A lookup is made at every light pick and pmf, and descending from the root had been
/// a chain of a dozen dependent loads, a fifth of a ring-lit pick. On the showcase 9 of 10
/// cells name a leaf; 2^10 cells left a third of the lookups' time (and were 3% slower).
const GRID_LEVELS: u32 = 14;

/// Per-region values `F` over a box of the scene.
#[derive(Clone, Debug, PartialEq)]
pub struct RegionTree<F> {
    /// The box the regions cover.
    lower: Vec3,
    upper: Vec3,
    /// The regions' k-d tree, its root first.
    nodes: Vec<RegionNode>,
    values: Vec<F>,
    /// Where a lookup starts in `nodes`, by cell of a regular grid over the box.
    grid: Grid,
}

/// A regular grid over a [`RegionTree`]'s box (see [`GRID_LEVELS`]).
#[derive(Clone, Debug, Default, PartialEq)]
struct Grid {
    /// Cells along each axis.
    cells: [u32; 3],
    /// Cells per unit of length along each axis (0 across a flat axis).
    scale: Vec3,
    /// Per cell, x fastest: the node a lookup of a point in it starts from.
    start: Vec<u32>,
}

impl Grid {
    /// The index in `start` of the cell holding the point `offset` from the box's lower
    /// corner (points on the upper faces in the last cells).
    #[inline]
    fn cell(&self, offset: Vec3) -> usize {
        let [nx, ny, _] = self.cells;
        let cell = (offset * self.scale)
            .as_uvec3()
            .min(glam::UVec3::from(self.cells) - 1);
        (cell.x + nx * (cell.y + ny * cell.z)) as usize
    }
}

/// A node of the regions' k-d tree, eight bytes.
#[derive(Clone, Copy, Debug, PartialEq)]
struct RegionNode {
    /// Where a split node halves its box.
    at: f32,
    /// A split node: its axis in the top two bits, below them the index of its lower half (the
    /// upper half follows it). A leaf ([`LEAF`] in the top bits): its value's index, or
    /// [`NOTHING_LEARNED`].
    bits: u32,
}

/// The top two bits of a leaf node.
const LEAF: u32 = 3 << 30;
/// A leaf's index when its region saw too few samples to learn from.
const NOTHING_LEARNED: u32 = !LEAF;

impl RegionNode {
    fn leaf(value: u32) -> Self {
        Self {
            at: 0.0,
            bits: LEAF | value,
        }
    }
}

impl<F: Send> RegionTree<F> {
    /// One region over the box from `lower` to `upper` that has learned nothing.
    fn unsplit(lower: Vec3, upper: Vec3) -> Self {
        RegionTree {
            lower,
            upper,
            nodes: vec![RegionNode::leaf(NOTHING_LEARNED)],
            values: Vec::new(),
            grid: Grid::default(),
        }
    }

    /// Regions over `count` sample places (`place` gives each one's position; those that are
    /// not finite are left out), halved while they hold more than `most` places, each region's
    /// value learned by `learn` from the indices of its places (`None`: it learned nothing);
    /// `None` without a finite place.
    pub fn learn(
        count: usize,
        most: usize,
        place: impl Fn(u32) -> Vec3 + Sync,
        learn: impl Fn(&[u32]) -> Option<F> + Sync,
    ) -> Option<Self> {
        let mut kept: Vec<u32> = (0..count as u32)
            .filter(|&i| place(i).is_finite())
            .collect();
        let (lower, upper) = kept.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), &i| {
                let p = place(i);
                (lo.min(p), hi.max(p))
            },
        );
        if kept.is_empty() {
            return None;
        }
        let mut tree = RegionTree::unsplit(lower, upper);
        let mut regions = Regions {
            most,
            nodes: &mut tree.nodes,
            place: &place,
            kept: &mut kept,
            leaves: Vec::new(),
        };
        regions.split(0, 0..regions.kept.len(), [lower, upper], 0);
        let leaves = regions.leaves;
        let learned: Vec<Option<F>> = leaves
            .par_iter()
            .map(|(_, members)| learn(&kept[members.clone()]))
            .collect();
        for ((node, _), value) in leaves.iter().zip(learned) {
            if let Some(value) = value {
                tree.nodes[*node] = RegionNode::leaf(tree.values.len() as u32);
                tree.values.push(value);
            }
        }
        Some(tree.with_grid())
    }

    /// The value at `p` (its region's); `None` outside the regions or where nothing was
    /// learned.
    #[inline]
    pub fn at(&self, p: Vec3) -> Option<&F> {
        if !(p.cmpge(self.lower).all() && p.cmple(self.upper).all()) {
            return None;
        }
        let start = *self.grid.start.get(self.grid.cell(p - self.lower))?;
        self.region_from(start as usize, p)
    }

    /// The value of the region holding `p`, found by descending from node `start`.
    #[inline]
    fn region_from(&self, start: usize, p: Vec3) -> Option<&F> {
        let p = p.to_array();
        let mut node = *self.nodes.get(start)?;
        while node.bits & LEAF != LEAF {
            let axis = (node.bits >> 30) as usize;
            let below = (node.bits & !LEAF) as usize;
            node = *self.nodes.get(below + (p[axis] >= node.at) as usize)?;
        }
        self.values.get((node.bits & !LEAF) as usize)
    }

    /// `self` with the grid its lookups start from built over its regions.
    fn with_grid(mut self) -> Self {
        let extent = self.upper - self.lower;
        let mut cells = [1u32; 3];
        let mut halved = extent;
        for _ in 0..GRID_LEVELS {
            let axis = halved.max_position();
            cells[axis] *= 2;
            halved[axis] *= 0.5;
        }
        let counts = Vec3::from(cells.map(|c| c as f32));
        let scale = Vec3::select(extent.cmpgt(Vec3::ZERO), counts / extent, Vec3::ZERO);
        let corner = |cell: Vec3| self.lower + extent * (cell / counts);
        let mut start = Vec::with_capacity(cells.iter().product::<u32>() as usize);
        for z in 0..cells[2] {
            for y in 0..cells[1] {
                for x in 0..cells[0] {
                    let cell = Vec3::new(x as f32, y as f32, z as f32);
                    start.push(self.deepest_holding(corner(cell), corner(cell + 1.0)));
                }
            }
        }
        self.grid = Grid {
            cells,
            scale,
            start,
        };
        self
    }

    /// The deepest node whose region holds the whole box from `lo` to `hi` (its lower half
    /// takes what lies below a split, the upper half the rest).
    fn deepest_holding(&self, lo: Vec3, hi: Vec3) -> u32 {
        let mut index = 0u32;
        while let Some(node) = self.nodes.get(index as usize)
            && node.bits & LEAF != LEAF
        {
            let axis = (node.bits >> 30) as usize;
            let below = node.bits & !LEAF;
            index = if hi[axis] <= node.at {
                below
            } else if lo[axis] >= node.at {
                below + 1
            } else {
                break;
            };
        }
        index
    }

    /// What each region that learned something learned.
    pub fn values(&self) -> &[F] {
        &self.values
    }

    /// Bytes the tree takes.
    pub fn bytes(&self) -> usize {
        std::mem::size_of::<Self>()
            + self.nodes.capacity() * std::mem::size_of::<RegionNode>()
            + self.values.capacity() * std::mem::size_of::<F>()
            + self.grid.start.capacity() * std::mem::size_of::<u32>()
    }

    /// Regions learned from, of all regions.
    pub fn learned(&self) -> (usize, usize) {
        let leaves = self.nodes.iter().filter(|n| n.bits & LEAF == LEAF).count();
        (self.values.len(), leaves)
    }
}

/// The regions' k-d tree as it is built over the sample places.
struct Regions<'a, P> {
    /// A region is halved while it holds more places than this.
    most: usize,
    nodes: &'a mut Vec<RegionNode>,
    /// Each place's position.
    place: &'a P,
    /// Indices of the records used, partitioned in place so each region's are a range.
    kept: &'a mut [u32],
    /// Each leaf's node and its range of `kept`.
    leaves: Vec<(usize, Range<usize>)>,
}

impl<P: Fn(u32) -> Vec3> Regions<'_, P> {
    /// Makes node `slot` the region over `kept[members]` (places inside `bounds`, `depth`
    /// halvings from the root): a leaf, or a split at the middle of its longest side whose
    /// halves follow the nodes made so far.
    fn split(&mut self, slot: usize, members: Range<usize>, bounds: [Vec3; 2], depth: u32) {
        let [lower, upper] = bounds;
        let (axis, at) = middle_of_longest_side(bounds);
        let halves = members.len() > self.most
            && depth < MAX_DEPTH
            && at > lower[axis]
            && at < upper[axis]
            && self.nodes.len() + 2 < NOTHING_LEARNED as usize;
        if !halves {
            self.leaves.push((slot, members));
            return;
        }
        let part = &mut self.kept[members.clone()];
        let mut below = 0;
        for k in 0..part.len() {
            if (self.place)(part[k])[axis] < at {
                part.swap(k, below);
                below += 1;
            }
        }
        let (first, [low, high]) = split_node(self.nodes, slot, bounds, axis, at);
        let middle = members.start + below;
        self.split(first, members.start..middle, low, depth + 1);
        self.split(first + 1, middle..members.end, high, depth + 1);
    }
}

/// Where a region's box is halved: the middle of its longest side (the axis, the coordinate).
fn middle_of_longest_side([lower, upper]: [Vec3; 2]) -> (usize, f32) {
    let extent = upper - lower;
    let axis = extent.max_position();
    (axis, lower[axis] + 0.5 * extent[axis])
}

/// Makes node `slot` a split of the box `bounds` at `at` along `axis`, its halves two new
/// nodes after the others (leaves with nothing learned); returns the first of them and the
/// halves' boxes.
fn split_node(
    nodes: &mut Vec<RegionNode>,
    slot: usize,
    [lower, upper]: [Vec3; 2],
    axis: usize,
    at: f32,
) -> (usize, [[Vec3; 2]; 2]) {
    let first = nodes.len();
    nodes.extend([RegionNode::leaf(NOTHING_LEARNED); 2]);
    nodes[slot] = RegionNode {
        at,
        bits: (axis as u32) << 30 | first as u32,
    };
    let (mut low_upper, mut high_lower) = (upper, lower);
    low_upper[axis] = at;
    high_lower[axis] = at;
    (first, [[lower, low_upper], [high_lower, upper]])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::hash32;

    /// A k-d tree over `[lower, upper]` halved at the middle of the longest side, as training
    /// halves it, to an uneven depth (up to 16 levels), each leaf its own value.
    fn uneven_tree(lower: Vec3, upper: Vec3) -> RegionTree<u32> {
        fn split(tree: &mut RegionTree<u32>, slot: usize, bounds: [Vec3; 2], depth: u32) {
            let stop = depth >= 16 || hash32(slot as u32 ^ 0x5bd1).is_multiple_of(5) && depth > 3;
            if stop {
                tree.nodes[slot] = RegionNode::leaf(tree.values.len() as u32);
                tree.values.push(tree.values.len() as u32);
                return;
            }
            let (axis, at) = middle_of_longest_side(bounds);
            let (first, [low, high]) = split_node(&mut tree.nodes, slot, bounds, axis, at);
            split(tree, first, low, depth + 1);
            split(tree, first + 1, high, depth + 1);
        }
        let mut tree = RegionTree::unsplit(lower, upper);
        split(&mut tree, 0, [lower, upper], 0);
        tree.with_grid()
    }

    #[test]
    fn a_lookup_through_the_grid_finds_the_region_a_descent_from_the_root_finds() {
        let (lower, upper) = (Vec3::new(-3.0, 0.0, -7.5), Vec3::new(4.0, 2.9, 3.0));
        let tree = uneven_tree(lower, upper);
        assert!(tree.values.len() > 1000, "{} regions", tree.values.len());
        let from_root = |p: Vec3| tree.region_from(0, p);
        let mut skipped = 0;
        for i in 0..20_000u32 {
            let u = Vec3::new(
                hash32(3 * i) as f32,
                hash32(3 * i + 1) as f32,
                hash32(3 * i + 2) as f32,
            ) / u32::MAX as f32;
            let p = lower + (upper - lower) * u;
            assert_eq!(tree.at(p), from_root(p), "{p}");
            // The grid skipped levels: the cell's start is below the root.
            skipped += (tree.grid.start[tree.grid.cell(p - lower)] != 0) as u32;
        }
        assert!(
            skipped > 19_000,
            "{skipped} of 20000 lookups skipped levels"
        );
        // The box's far corner and points just outside it.
        assert_eq!(tree.at(upper), from_root(upper));
        assert_eq!(tree.at(upper + 1e-3), None);
    }

    #[test]
    fn points_outside_the_regions_or_in_regions_without_samples_find_nothing() {
        let tree = RegionTree {
            lower: Vec3::ZERO,
            upper: Vec3::ONE,
            nodes: vec![
                RegionNode {
                    at: 0.5,
                    bits: 1 << 30 | 1,
                },
                RegionNode::leaf(0),
                RegionNode::leaf(NOTHING_LEARNED),
            ],
            values: vec![7u32],
            grid: Grid::default(),
        }
        .with_grid();
        assert_eq!(tree.at(Vec3::new(0.5, 0.2, 0.5)), Some(&7));
        assert_eq!(tree.at(Vec3::new(0.5, 0.7, 0.5)), None);
        assert_eq!(tree.at(Vec3::new(1.5, 0.2, 0.5)), None);
        assert_eq!(tree.at(Vec3::splat(f32::NAN)), None);
        assert_eq!(tree.learned(), (1, 2));
    }

    #[test]
    fn regions_are_halved_until_they_hold_few_enough_places() {
        // Places along a line, twice as dense in its first half: each region holds at most
        // `MOST`, and each learns the number of its places.
        const MOST: usize = 512;
        let places: Vec<Vec3> = (0..8 * MOST as u32)
            .map(|i| {
                let x = i as f32 / (8 * MOST) as f32;
                Vec3::new(if i % 3 == 0 { x } else { 0.5 * x }, 0.0, 0.0)
            })
            .collect();
        let tree = RegionTree::learn(
            places.len(),
            MOST,
            |i| places[i as usize],
            |m| Some(m.len()),
        )
        .expect("finite places");
        let (learned, leaves) = tree.learned();
        assert_eq!(learned, leaves);
        assert!(tree.values.iter().all(|&n| n <= MOST), "{:?}", tree.values);
        assert_eq!(tree.values.iter().sum::<usize>(), places.len());
        assert!(leaves >= 8, "{leaves} regions");
        // Every place is in a region that counted it.
        assert!(places.iter().all(|&p| tree.at(p).is_some()));
    }
}
