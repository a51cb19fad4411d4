//! Light selection learned per region: the light tree's first two choices reweighed, region by
//! region of the scene, by what each branch was seen to bring there
//! ([`crate::prepare::training`] learns it).
//!
//! The regions are the leaves of a k-d tree over the places training paths took light samples,
//! halved at the middle of their longest side until each holds about [`REGION_SAMPLES`] of
//! them, so regions are small where shading is dense. Each region keeps factors for the lanes
//! of the tree's root and of the root's children, and for the split between the environment and
//! the emitters ([`RegionFactors`]); the descent and the replay of its pmf apply the same
//! factors, so the estimate stays unbiased whatever was learned: a poor guide costs noise,
//! never bias. A lookup, made at every light pick and pmf, starts from a regular grid over the
//! regions' box that names the deepest node holding each cell ([`GRID_LEVELS`]).

use crate::lights::tree::PerLane;
use glam::Vec3;
use rayon::prelude::*;
use std::ops::Range;

/// A region is halved while it holds more than this many training samples. On the showcase
/// (320×180, 32 spp, two seeds), 128, 256 and 512 gave 9.40%, 9.02% and 8.98% noise.
const REGION_SAMPLES: usize = 512;
/// Deepest halving of the regions.
const MAX_DEPTH: u32 = 48;
/// Halvings of the regions' box that a lookup skips through a regular grid of 2^this cells
/// (64 KiB): each cell names the deepest node whose region holds it whole, where the lookup
/// goes on. A lookup is made at every light pick and pmf, and descending from the root had been
/// a chain of a dozen dependent loads, a fifth of a ring-lit pick. On the showcase 9 of 10
/// cells name a leaf; 2^10 cells left a third of the lookups' time (and were 3% slower).
const GRID_LEVELS: u32 = 14;

/// Per-region factors for the light tree's top two levels.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LightGuide {
    /// The box the regions cover.
    lower: Vec3,
    upper: Vec3,
    /// The regions' k-d tree, its root first.
    nodes: Vec<RegionNode>,
    factors: Vec<RegionFactors>,
    /// Where a lookup starts in `nodes`, by cell of a regular grid over the box.
    grid: Grid,
}

/// A regular grid over a [`LightGuide`]'s box (see [`GRID_LEVELS`]).
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

/// What one region learned.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RegionFactors {
    /// Factors of the light tree's top two levels' lanes.
    pub lanes: PerLane,
    /// The factor of the environment's weight against the emitters' where the split between
    /// them follows estimates: light sampling takes the environment with probability
    /// `sky·p / (sky·p + 1 − p)` where the estimate gives it `p`.
    pub sky: f32,
}

impl Default for RegionFactors {
    fn default() -> Self {
        Self {
            lanes: PerLane::default(),
            sky: 1.0,
        }
    }
}

/// A node of the regions' k-d tree, eight bytes.
#[derive(Clone, Copy, Debug, PartialEq)]
struct RegionNode {
    /// Where a split node halves its box.
    at: f32,
    /// A split node: its axis in the top two bits, below them the index of its lower half (the
    /// upper half follows it). A leaf ([`LEAF`] in the top bits): its factors' index, or
    /// [`NOTHING_LEARNED`].
    bits: u32,
}

/// The top two bits of a leaf node.
const LEAF: u32 = 3 << 30;
/// A leaf's index when its region saw too few samples to learn from.
const NOTHING_LEARNED: u32 = !LEAF;

impl RegionNode {
    fn leaf(factors: u32) -> Self {
        Self {
            at: 0.0,
            bits: LEAF | factors,
        }
    }
}

impl LightGuide {
    /// Regions over `count` sample places (`place` gives each one's position; those that are
    /// not finite are left out), each region's factors learned by `learn` from the indices of
    /// its places (`None`: it learned nothing); `None` without a finite place.
    pub fn learn(
        count: usize,
        place: impl Fn(u32) -> Vec3 + Sync,
        learn: impl Fn(&[u32]) -> Option<RegionFactors> + Sync,
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
        let mut guide = LightGuide {
            lower,
            upper,
            nodes: vec![RegionNode::leaf(NOTHING_LEARNED)],
            factors: Vec::new(),
            grid: Grid::default(),
        };
        let mut regions = Regions {
            nodes: &mut guide.nodes,
            place: &place,
            kept: &mut kept,
            leaves: Vec::new(),
        };
        regions.split(0, 0..regions.kept.len(), [lower, upper], 0);
        let leaves = regions.leaves;
        let learned: Vec<Option<RegionFactors>> = leaves
            .par_iter()
            .map(|(_, members)| learn(&kept[members.clone()]))
            .collect();
        for ((node, _), factors) in leaves.iter().zip(learned) {
            if let Some(factors) = factors {
                guide.nodes[*node] = RegionNode::leaf(guide.factors.len() as u32);
                guide.factors.push(factors);
            }
        }
        Some(guide.with_grid())
    }

    /// The factors at `p` (its region's); `None` outside the regions or where nothing was
    /// learned.
    #[inline]
    pub fn at(&self, p: Vec3) -> Option<&RegionFactors> {
        if !(p.cmpge(self.lower).all() && p.cmple(self.upper).all()) {
            return None;
        }
        let start = *self.grid.start.get(self.grid.cell(p - self.lower))?;
        self.region_from(start as usize, p)
    }

    /// The factors of the region holding `p`, found by descending from node `start`.
    #[inline]
    fn region_from(&self, start: usize, p: Vec3) -> Option<&RegionFactors> {
        let p = p.to_array();
        let mut node = *self.nodes.get(start)?;
        while node.bits & LEAF != LEAF {
            let axis = (node.bits >> 30) as usize;
            let below = (node.bits & !LEAF) as usize;
            node = *self.nodes.get(below + (p[axis] >= node.at) as usize)?;
        }
        self.factors.get((node.bits & !LEAF) as usize)
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

    /// Regions learned from, of all regions.
    pub fn learned(&self) -> (usize, usize) {
        let leaves = self.nodes.iter().filter(|n| n.bits & LEAF == LEAF).count();
        (self.factors.len(), leaves)
    }
}

/// The regions' k-d tree as it is built over the sample places.
struct Regions<'a, P> {
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
        let halves = members.len() > REGION_SAMPLES
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
    /// halves it, to an uneven depth (up to 16 levels), each leaf its own factors.
    fn uneven_guide(lower: Vec3, upper: Vec3) -> LightGuide {
        fn split(guide: &mut LightGuide, slot: usize, bounds: [Vec3; 2], depth: u32) {
            let stop = depth >= 16 || hash32(slot as u32 ^ 0x5bd1).is_multiple_of(5) && depth > 3;
            if stop {
                guide.nodes[slot] = RegionNode::leaf(guide.factors.len() as u32);
                let factor = guide.factors.len() as f32;
                guide.factors.push(RegionFactors {
                    sky: factor,
                    ..RegionFactors::default()
                });
                return;
            }
            let (axis, at) = middle_of_longest_side(bounds);
            let (first, [low, high]) = split_node(&mut guide.nodes, slot, bounds, axis, at);
            split(guide, first, low, depth + 1);
            split(guide, first + 1, high, depth + 1);
        }
        let mut guide = LightGuide {
            lower,
            upper,
            nodes: vec![RegionNode::leaf(NOTHING_LEARNED)],
            ..LightGuide::default()
        };
        split(&mut guide, 0, [lower, upper], 0);
        guide.with_grid()
    }

    #[test]
    fn a_lookup_through_the_grid_finds_the_region_a_descent_from_the_root_finds() {
        let (lower, upper) = (Vec3::new(-3.0, 0.0, -7.5), Vec3::new(4.0, 2.9, 3.0));
        let guide = uneven_guide(lower, upper);
        assert!(
            guide.factors.len() > 1000,
            "{} regions",
            guide.factors.len()
        );
        let from_root = |p: Vec3| guide.region_from(0, p);
        let mut skipped = 0;
        for i in 0..20_000u32 {
            let u = Vec3::new(
                hash32(3 * i) as f32,
                hash32(3 * i + 1) as f32,
                hash32(3 * i + 2) as f32,
            ) / u32::MAX as f32;
            let p = lower + (upper - lower) * u;
            assert_eq!(guide.at(p), from_root(p), "{p}");
            // The grid skipped levels: the cell's start is below the root.
            skipped += (guide.grid.start[guide.grid.cell(p - lower)] != 0) as u32;
        }
        assert!(
            skipped > 19_000,
            "{skipped} of 20000 lookups skipped levels"
        );
        // The box's far corner and points just outside it.
        assert_eq!(guide.at(upper), from_root(upper));
        assert_eq!(guide.at(upper + 1e-3), None);
    }

    #[test]
    fn points_outside_the_regions_or_in_regions_without_samples_are_not_guided() {
        let factors = RegionFactors {
            lanes: PerLane::splat(2.0),
            sky: 0.5,
        };
        let guide = LightGuide {
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
            factors: vec![factors],
            grid: Grid::default(),
        }
        .with_grid();
        assert_eq!(guide.at(Vec3::new(0.5, 0.2, 0.5)), Some(&factors));
        assert_eq!(guide.at(Vec3::new(0.5, 0.7, 0.5)), None);
        assert_eq!(guide.at(Vec3::new(1.5, 0.2, 0.5)), None);
        assert_eq!(guide.at(Vec3::splat(f32::NAN)), None);
        assert_eq!(guide.learned(), (1, 2));
    }
}
