//! Light selection learned per region: the light tree's first two choices reweighed, region by
//! region of the scene, by what each branch was seen to bring there.
//!
//! The tree's importance is an unoccluded bound. It cannot see that a ring lying in the plane of
//! the wall it lights sends that wall little, that the lamps of a room are behind a wall from the
//! room next door, or that one side of a ring hides behind the other. So, before rendering, a few
//! camera paths are traced at a low resolution (`TRAINING_WIDTH` pixels across,
//! `TRAINING_SPP` paths each), and every light sample they take is recorded with what it
//! brought, shadow ray included. The places those samples were taken at are cut into regions,
//! the leaves of a k-d tree halved at the middle of their longest side until each holds about
//! `REGION_SAMPLES` of them, so regions are small where shading is dense.
//!
//! In each region, for each lane of the tree's root and of the root's children, the samples
//! give the second moment of the estimate that lane alone would make. One-sample selection has
//! the least variance when lanes are chosen in proportion to the root of that moment. Each
//! lane's factor turns the tree's mean share in the region into that proportion, blended with
//! the tree's own share (`TREE_SHARE`) so that no lane the tree would pick is ever starved.
//! The descent and the replay of its pmf apply the same factors, so the estimate stays unbiased
//! whatever was learned: a poor guide costs noise, never bias.
//!
//! Where the scene has an environment beside its emitters, each region also learns the split
//! between them the same way: the estimate behind the split counts the sky in full inside a
//! closed room, and the emitters in full behind a wall.
//!
//! What is recorded is each sample's MIS-weighted value: what light sampling itself must bring,
//! leaving out what BSDF sampling finds well (a wide sky, a big lamp close by).
//!
//! The tree's root holds the kinds of emitters apart when there are at most four (the lamps,
//! and each ring's strands; see [`crate::lights::emitters`]), so the root's factors are what a region
//! learns about each ring and the lamps, and the next level's about each quarter of a ring.
//!
//! Training depends only on the scene (its resolution, camera and seed), never on the crop, the
//! sample range or the thread count, so every part of a split render learns the same guide.

use crate::geometry::ray::Ray;
use crate::integrator::trace;
use crate::lights::emitters::{Picked, Receiver};
use crate::lights::tree::{PerLane, WIDTH};
use crate::sampling::{SampleStream, hash32};
use crate::scene::Scene;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::cell::RefCell;
use std::ops::Range;

/// Training paths: the camera's frame at about this many pixels across (at most its own);
/// fewer in fuzz builds, as for [`crate::through::light_visibility`]'s grid.
const TRAINING_WIDTH: u32 = if cfg!(fuzzing) { 16 } else { 160 };
/// Paths per training pixel.
const TRAINING_SPP: u32 = 4;
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
/// Light samples a region must have seen before its factors are trusted.
const LEAST_SAMPLES: usize = 32;
/// The tree's own share kept in every choice: what the guide cannot starve. On the showcase
/// and `lit_through`, 0.1 to 0.35 all measured within half a percent of noise of 0.2.
const TREE_SHARE: f64 = 0.2;

/// The largest factor a lane gets: a lane the tree all but ignores where it brought most of the
/// light is raised this far, which keeps the descent's weights far from overflow.
const MAX_FACTOR: f64 = 1e4;

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

/// One light sample a training path took.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Record {
    /// Where it was taken, as light selection saw it (beyond openings for a chain's strategy).
    pub receiver: Receiver,
    /// What it took (`None`: a point on an opening's aperture, or no light at all).
    pub took: Option<Picked>,
    /// Luminance of what it brought over the density it was drawn with, shadow ray included.
    pub value: f32,
}

thread_local! {
    /// Where the integrator leaves its records while a training path is traced.
    static SINK: RefCell<Option<Vec<Record>>> = const { RefCell::new(None) };
}

/// Keeps `record` when the calling thread is tracing training paths.
pub(crate) fn record(record: Record) {
    SINK.with(|sink| {
        if let Some(records) = sink.borrow_mut().as_mut() {
            records.push(record);
        }
    });
}

/// Learns the guide of `scene` from training paths over its camera's frame; `None` when its
/// light selection does not descend a tree, or no training path took a light sample. The
/// scene's lights must be in training (see [`crate::lights::emitters::Lights::set_training`]) for the
/// paths to leave records.
pub fn train(scene: &Scene) -> Option<LightGuide> {
    if !scene.lights.descends_tree() {
        return None;
    }
    let records = training_records(scene);
    let mut kept: Vec<u32> = (0..records.len() as u32)
        .filter(|&i| records[i as usize].receiver.p.is_finite())
        .collect();
    let (lower, upper) = kept.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), &i| {
            let p = records[i as usize].receiver.p;
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
        records: &records,
        kept: &mut kept,
        leaves: Vec::new(),
    };
    regions.split(0, 0..regions.kept.len(), [lower, upper], 0);
    let leaves = regions.leaves;
    let learned: Vec<Option<RegionFactors>> = leaves
        .par_iter()
        .map(|(_, members)| learn(scene, &records, &kept[members.clone()]))
        .collect();
    for ((node, _), factors) in leaves.iter().zip(learned) {
        if let Some(factors) = factors {
            guide.nodes[*node] = RegionNode::leaf(guide.factors.len() as u32);
            guide.factors.push(factors);
        }
    }
    Some(guide.with_grid())
}

/// The regions' k-d tree as it is built over the training records.
struct Regions<'a> {
    nodes: &'a mut Vec<RegionNode>,
    records: &'a [Record],
    /// Indices of the records used, partitioned in place so each region's are a range.
    kept: &'a mut [u32],
    /// Each leaf's node and its range of `kept`.
    leaves: Vec<(usize, Range<usize>)>,
}

impl Regions<'_> {
    /// Makes node `slot` the region over `kept[members]` (records inside `bounds`, `depth`
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
            if self.records[part[k] as usize].receiver.p[axis] < at {
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

/// The factors one region's samples (`members`, indices of `records`) teach; `None` when they
/// are too few.
fn learn(scene: &Scene, records: &[Record], members: &[u32]) -> Option<RegionFactors> {
    if members.len() < LEAST_SAMPLES {
        return None;
    }
    let lights = &scene.lights;
    let mut moments = Moments::default();
    for &i in members {
        let r = &records[i as usize];
        let Some(shares) = lights.lane_shares(&r.receiver) else {
            continue;
        };
        let sky_share = lights.estimated_environment_share(&r.receiver) as f64;
        // The lanes an emitter's path took, and which side of the split the sample fell on
        // (`Some(true)`: the environment).
        let (lanes, side) = match r.took {
            Some(Picked::Emitter(e)) => {
                let lanes = lights.top_lanes(e);
                (lanes, lanes.map(|_| false))
            }
            Some(Picked::Environment) => (None, Some(true)),
            None => (None, None),
        };
        // Within the emitters' side, a sample's own estimate leaves out the split's share.
        moments.add(&shares, lanes, r.value as f64 * (1.0 - sky_share));
        moments.add_split(sky_share, side, r.value as f64);
    }
    Some(RegionFactors {
        lanes: moments.factors(lights.lane_costs()),
        sky: if lights.splits_by_estimate() {
            moments.sky_factor()
        } else {
            1.0
        },
    })
}

/// The records of [`TRAINING_SPP`] paths a pixel over the camera's frame at about
/// [`TRAINING_WIDTH`] pixels across, row after row (the same whatever the thread count).
fn training_records(scene: &Scene) -> Vec<Record> {
    let [w, h] = scene.camera.projection.resolution;
    let width = TRAINING_WIDTH.min(w).max(1);
    let height = ((h as u64 * width as u64 / w.max(1) as u64) as u32).max(1);
    let seed = hash32(scene.settings.seed ^ 0x4c16_47e5);
    let rows: Vec<Vec<Record>> = (0..height)
        .into_par_iter()
        .map(|y| {
            SINK.with(|sink| *sink.borrow_mut() = Some(Vec::new()));
            for x in 0..width {
                let pixel_seed = hash32(hash32(y * width + x) ^ seed);
                for i in 0..TRAINING_SPP {
                    let pixel = (
                        Vec2::new(x as f32, y as f32),
                        Vec2::new(width as f32, height as f32),
                    );
                    training_path(scene, pixel, &mut SampleStream::new(i, pixel_seed));
                }
            }
            SINK.with(|sink| sink.borrow_mut().take())
                .unwrap_or_default()
        })
        .collect();
    // Row after row into one list, each row freed as it is moved (a flattening collect would
    // hold every record twice at its peak: 20 MB on the showcase).
    let mut records = Vec::with_capacity(rows.iter().map(Vec::len).sum());
    for row in rows {
        records.extend(row);
    }
    records
}

/// Traces one training path through `pixel` (its corner and the training frame's size), with
/// the shot camera at a time in the shutter.
fn training_path(scene: &Scene, (corner, size): (Vec2, Vec2), s: &mut SampleStream) {
    let [open, close] = scene.shutter;
    let [jx, jy, lx, ly] = s.next_4d();
    let time = open + (close - open) * s.time() as f64;
    let lens = crate::camera::Lens::at(&scene.camera, time);
    let (o, d) = lens.ray((corner + Vec2::new(jx, jy)) / size, Vec2::new(lx, ly));
    let range = if scene.clip.is_none() {
        Some((0.0, f32::INFINITY))
    } else {
        scene.clip.interval(&lens, o, d)
    };
    if let Some((t_min, t_max)) = range {
        trace(scene, Ray::new(o, d, t_max, time).between(t_min, t_max), s);
    }
}

/// What one region's light samples showed.
#[derive(Clone, Copy, Debug, Default)]
struct Moments {
    /// Per root lane, the sum over the samples that took it of value² × its share: the second
    /// moment of the estimate that lane alone would make, times the sample count.
    root: [f64; WIDTH],
    /// The same for each root lane's child lanes.
    second: [[f64; WIDTH]; WIDTH],
    /// Sums of the tree's shares at every sample's point.
    root_share: [f64; WIDTH],
    second_share: [[f64; WIDTH]; WIDTH],
    /// The same for the split between the environment and the emitters: the second moments
    /// of each side's own estimate, and the sum of the environment's estimated share.
    sky: f64,
    emitters: f64,
    sky_share: f64,
    samples: f64,
}

impl Moments {
    /// Adds a sample whose point the tree gives `shares`, which took the lanes `lanes` (none
    /// for the environment or no light) and brought `value`.
    fn add(&mut self, shares: &PerLane, lanes: Option<(usize, Option<usize>)>, value: f64) {
        for j in 0..WIDTH {
            self.root_share[j] += shares.root[j] as f64;
            for k in 0..WIDTH {
                self.second_share[j][k] += shares.second[j][k] as f64;
            }
        }
        let Some((j, second)) = lanes else {
            return;
        };
        // The lane's own estimate is the sample's over its share; weighing the square by the
        // probability of taking the lane gives its second moment.
        let root_share = shares.root[j] as f64;
        self.root[j] += value * value * root_share;
        if let Some(k) = second {
            self.second[j][k] += value * value * root_share * shares.second[j][k] as f64;
        }
    }

    /// Adds a sample to the split: the environment's estimated share at its point, whether it
    /// took the environment (`Some(true)`) or an emitter (`Some(false)`), and what it brought.
    fn add_split(&mut self, sky_share: f64, took_sky: Option<bool>, value: f64) {
        self.samples += 1.0;
        self.sky_share += sky_share;
        match took_sky {
            Some(true) => self.sky += value * value * sky_share,
            Some(false) => self.emitters += value * value * (1.0 - sky_share),
            None => {}
        }
    }

    /// The factor of the environment's weight that takes its mean estimated share to the
    /// root of its second moment's share, blended like the lanes'.
    fn sky_factor(&self) -> f32 {
        let mean = self.sky_share / self.samples.max(1.0);
        let [sky, emitters] = [self.sky, self.emitters].map(|m| m.max(0.0).sqrt());
        if !(sky + emitters > 0.0 && (sky + emitters).is_finite() && mean > 0.0 && mean < 1.0) {
            return 1.0;
        }
        let learned = sky / (sky + emitters);
        let blended = (1.0 - TREE_SHARE) * learned + TREE_SHARE * mean;
        // The weight ratio that turns the mean share into the blended one.
        let factor = blended * (1.0 - mean) / ((1.0 - blended) * mean);
        factor.clamp(1.0 / MAX_FACTOR, MAX_FACTOR) as f32
    }

    /// The factors that take the tree's shares to the learned ones, for lanes whose samples
    /// cost `costs`.
    fn factors(&self, costs: &PerLane) -> PerLane {
        PerLane {
            root: lane_factors(&self.root, &self.root_share, &costs.root),
            second: std::array::from_fn(|j| {
                lane_factors(&self.second[j], &self.second_share[j], &costs.second[j])
            }),
        }
    }
}

/// Factors that turn lanes' mean shares (`share_sums`, summed over the samples) into shares in
/// proportion to the root of their second moments (`moment_sums`) over their samples' `costs`
/// (the most efficient one-sample choice), blended with the tree's own by [`TREE_SHARE`]; all
/// 1 when the lanes brought nothing.
fn lane_factors(
    moment_sums: &[f64; WIDTH],
    share_sums: &[f64; WIDTH],
    costs: &[f32; WIDTH],
) -> [f32; WIDTH] {
    let roots: [f64; WIDTH] =
        std::array::from_fn(|k| (moment_sums[k].max(0.0) / costs[k].max(1e-6) as f64).sqrt());
    let (root_total, share_total) = (roots.iter().sum::<f64>(), share_sums.iter().sum::<f64>());
    if !(root_total > 0.0 && share_total > 0.0 && root_total.is_finite()) {
        return [1.0; WIDTH];
    }
    std::array::from_fn(|k| {
        let tree = share_sums[k] / share_total;
        if tree <= 0.0 {
            return 1.0;
        }
        let learned = roots[k] / root_total;
        let factor = ((1.0 - TREE_SHARE) * learned + TREE_SHARE * tree) / tree;
        factor.min(MAX_FACTOR) as f32
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn factors_move_shares_towards_the_root_of_second_moments_over_costs() {
        let even = [0.25f64; WIDTH];
        let ones = [1.0f32; WIDTH];
        // What the tree gives is what was seen: nothing moves.
        let f = lane_factors(&[1.0, 1.0, 1.0, 1.0], &even, &ones);
        assert!(f.iter().all(|&f| (f - 1.0).abs() < 1e-6), "{f:?}");
        // A lane that never brought light keeps only the tree's share of it.
        let f = lane_factors(&[1.0, 1.0, 1.0, 0.0], &even, &ones);
        assert!((f[3] - TREE_SHARE as f32).abs() < 1e-6, "{f:?}");
        // Second moments 16:4:1:1 want shares 4:2:1:1; a lane costing four times as much
        // wants half the share.
        let f = lane_factors(&[16.0, 4.0, 1.0, 1.0], &even, &ones);
        let g = lane_factors(&[16.0, 4.0, 1.0, 1.0], &even, &[4.0, 1.0, 1.0, 1.0]);
        let shares = |f: [f32; WIDTH]| {
            let total: f32 = f.iter().sum();
            f.map(|f| f / total)
        };
        let blend = |learned: f32| (1.0 - TREE_SHARE as f32) * learned + TREE_SHARE as f32 * 0.25;
        let (s, t) = (shares(f), shares(g));
        assert!(
            (s[0] - blend(0.5)).abs() < 1e-5 && (s[1] - blend(0.25)).abs() < 1e-5,
            "{s:?}"
        );
        assert!((t[0] - blend(2.0 / 6.0)).abs() < 1e-5, "{t:?}");
        // Nothing seen at all: no change.
        assert_eq!(lane_factors(&[0.0; WIDTH], &even, &ones), [1.0; WIDTH]);
    }

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
