//! A sparse grid of scalar voxels, as OpenVDB stores density: 8³ bricks (one per VDB leaf, or
//! one shared brick per constant tile value) looked up through a dense table over the grid's
//! bounds, with a coarse majorant per brick for null-collision tracking.
//!
//! Positions are in index space: voxel (i, j, k) is the sample at (i, j, k), and a density at
//! any position interpolates its eight neighbours trilinearly (as OpenVDB's box sampler does).
//! The table is padded by one empty brick on every side, so the density is exactly zero on
//! and outside the box [`Voxels::bounds`] and the tracker can clip rays to it.

use glam::{IVec3, Vec3};

/// Voxels per brick side (a VDB leaf).
pub const BRICK: i32 = 8;
const BRICK_VOXELS: usize = 512;

/// A sparse scalar grid in index space.
#[derive(Clone, Debug)]
pub struct Voxels {
    /// The first voxel of brick (0, 0, 0) (a multiple of [`BRICK`]).
    origin: IVec3,
    /// Bricks per axis, padding included.
    bricks: IVec3,
    /// Per brick (x slowest): its index in `values`; 0 is the empty brick.
    table: Vec<u32>,
    /// [`BRICK_VOXELS`] values per brick, z fastest.
    values: Vec<f32>,
    /// Per brick: the largest density a position inside it can interpolate.
    majorant: Vec<f32>,
}

/// Majorants are raised by this factor: eight weights that should sum to one can sum to a few
/// units in the last place more, and a density above its majorant would bias the tracking.
const MAJORANT_MARGIN: f32 = 1.0 + 1e-5;

/// Gathers bricks and constant regions, then builds [`Voxels`].
#[derive(Default)]
pub struct VoxelsBuilder {
    leaves: Vec<(IVec3, Box<[f32; BRICK_VOXELS]>)>,
    /// Constant regions: first voxel, side in voxels (a multiple of [`BRICK`]), value.
    tiles: Vec<(IVec3, i32, f32)>,
}

/// Bricks of the table per axis for the voxel bounds [lo, hi): a brick of padding each side.
/// The memory check and [`VoxelsBuilder::build`] share it, so they agree on the size.
fn table_shape(lo: IVec3, hi: IVec3) -> IVec3 {
    (hi - lo) / BRICK + 2
}

/// A value as the grid stores it: negative densities (smoke solvers leave small ones behind)
/// raised to zero. Tiles of one stored value share a brick.
fn stored(value: f32) -> f32 {
    value.max(0.0)
}

impl VoxelsBuilder {
    /// A brick of voxels at `origin` (a multiple of [`BRICK`]), z fastest.
    pub fn leaf(&mut self, origin: IVec3, values: Box<[f32; BRICK_VOXELS]>) {
        if values.iter().any(|&v| v != 0.0) {
            self.leaves.push((origin, values));
        }
    }

    /// A cube of `side` voxels from `origin` all holding `value`.
    pub fn tile(&mut self, origin: IVec3, side: i32, value: f32) {
        if value != 0.0 {
            self.tiles.push((origin, side, value));
        }
    }

    /// The bricks the table would hold (padding included) once the leaves at `coming`
    /// (origins whose values are still to be read) join what is gathered, for a memory check
    /// before [`Self::build`].
    pub fn table_len(&self, coming: &[IVec3]) -> u64 {
        let coming = coming.iter().map(|&o| (o, o + BRICK));
        match self.extent(coming) {
            Some((lo, hi)) => {
                // Saturating: a damaged file's nodes far apart on every axis ask for more
                // entries than a u64 counts, which the memory check then refuses.
                let n = table_shape(lo, hi);
                (n.x as u64)
                    .saturating_mul(n.y as u64)
                    .saturating_mul(n.z as u64)
            }
            None => 0,
        }
    }

    /// The bricks of values [`Self::build`] stores for the tiles: one for each value they
    /// hold (tiles of one value share theirs), for a memory check before it.
    pub fn tile_bricks(&self) -> u64 {
        let values: std::collections::HashSet<u32> = self
            .tiles
            .iter()
            .map(|&(_, _, v)| stored(v).to_bits())
            .collect();
        values.len() as u64
    }

    /// Table entries the leaves and tiles fill, `coming` more leaves included: no more than
    /// [`Self::table_len`] unless some overlap (which a well-formed VDB tree never has).
    pub fn covered_bricks(&self, coming: usize) -> u64 {
        let tiles: u64 = self
            .tiles
            .iter()
            .map(|&(_, side, _)| ((side / BRICK) as u64).pow(3))
            .sum();
        (self.leaves.len() + coming) as u64 + tiles
    }

    /// The voxel bounds [lo, hi) of everything gathered and the boxes `more`, in whole
    /// bricks.
    fn extent(&self, more: impl Iterator<Item = (IVec3, IVec3)>) -> Option<(IVec3, IVec3)> {
        let boxes = self.leaves.iter().map(|(o, _)| (*o, *o + BRICK));
        let tiles = self.tiles.iter().map(|&(o, side, _)| (o, o + side));
        boxes
            .chain(tiles)
            .chain(more)
            .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)))
    }

    /// The grid, with negative values raised to zero (a density cannot be negative; smoke
    /// solvers leave small negative values behind).
    pub fn build(self) -> Voxels {
        let Some((lo, hi)) = self.extent(std::iter::empty()) else {
            return Voxels::empty();
        };
        let origin = lo - BRICK;
        let bricks = table_shape(lo, hi);
        let cells = (bricks.x * bricks.y * bricks.z) as usize;
        let mut voxels = Voxels {
            origin,
            bricks,
            table: vec![0; cells],
            values: vec![0.0; BRICK_VOXELS],
            majorant: Vec::new(),
        };
        let mut constant: std::collections::HashMap<u32, u32> = Default::default();
        for (at, side, value) in self.tiles {
            let value = stored(value);
            let next = voxels.brick_count();
            let brick = *constant.entry(value.to_bits()).or_insert(next);
            if brick == next {
                voxels.values.extend([value; BRICK_VOXELS]);
            }
            let first = (at - origin) / BRICK;
            let n = side / BRICK;
            for x in 0..n {
                for y in 0..n {
                    for z in 0..n {
                        let cell = voxels.cell(first + IVec3::new(x, y, z));
                        voxels.table[cell] = brick;
                    }
                }
            }
        }
        for (at, values) in self.leaves {
            let brick = voxels.brick_count();
            voxels.values.extend(values.iter().map(|&v| stored(v)));
            let cell = voxels.cell((at - origin) / BRICK);
            voxels.table[cell] = brick;
        }
        voxels.majorant = voxels.majorants();
        voxels
    }
}

impl Voxels {
    /// A grid with no density anywhere.
    pub fn empty() -> Self {
        Self {
            origin: IVec3::ZERO,
            bricks: IVec3::ZERO,
            table: Vec::new(),
            values: vec![0.0; BRICK_VOXELS],
            majorant: Vec::new(),
        }
    }

    fn brick_count(&self) -> u32 {
        (self.values.len() / BRICK_VOXELS) as u32
    }

    /// Bytes held (for memory estimates).
    pub fn bytes(&self) -> usize {
        4 * (self.table.len() + self.values.len() + self.majorant.len())
    }

    /// The index-space box outside which the density is zero (empty when it is zero
    /// everywhere).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let lo = self.origin.as_vec3();
        (lo, lo + (self.bricks * BRICK).as_vec3())
    }

    /// True when the density is zero everywhere.
    pub fn is_empty(&self) -> bool {
        self.table.is_empty()
    }

    /// The table index of brick `b` (inside the table).
    fn cell(&self, b: IVec3) -> usize {
        ((b.x * self.bricks.y + b.y) * self.bricks.z + b.z) as usize
    }

    /// The value of voxel `v` (zero outside the table).
    #[inline]
    pub fn voxel(&self, v: IVec3) -> f32 {
        let rel = v - self.origin;
        let b = rel >> IVec3::splat(3);
        if b.cmplt(IVec3::ZERO).any() || b.cmpge(self.bricks).any() {
            return 0.0;
        }
        let brick = self.table[self.cell(b)] as usize;
        let l = rel & IVec3::splat(7);
        self.values[brick * BRICK_VOXELS + ((l.x << 6) | (l.y << 3) | l.z) as usize]
    }

    /// The density at index-space position `p`, interpolated trilinearly.
    pub fn density(&self, p: Vec3) -> f32 {
        if self.table.is_empty() {
            return 0.0;
        }
        let (lo, hi) = self.bounds();
        if !(p.cmpge(lo).all() && p.cmplt(hi).all()) {
            return 0.0;
        }
        let base = p.floor();
        let f = p - base;
        let i = base.as_ivec3();
        let mut sum = 0.0;
        for corner in 0..8 {
            let d = IVec3::new(corner >> 2, (corner >> 1) & 1, corner & 1);
            let w = Vec3::select(d.cmpeq(IVec3::ONE), f, Vec3::ONE - f);
            let weight = w.x * w.y * w.z;
            if weight > 0.0 {
                sum += weight * self.voxel(i + d);
            }
        }
        sum
    }

    /// The majorant of the brick holding index-space position `p` (zero outside).
    pub fn majorant_at(&self, p: Vec3) -> f32 {
        let b = ((p - self.origin.as_vec3()) / BRICK as f32)
            .floor()
            .as_ivec3();
        if b.cmplt(IVec3::ZERO).any() || b.cmpge(self.bricks).any() {
            return 0.0;
        }
        self.majorant[self.cell(b)]
    }

    /// Per brick, the largest value trilinear interpolation can reach inside it: the maximum
    /// over it and its neighbours on the positive side (whose first voxels it reads), taken
    /// one axis at a time.
    fn majorants(&self) -> Vec<f32> {
        // Per stored brick (many table entries share a tile's brick), then per table entry.
        let stored_max: Vec<f32> = self
            .values
            .chunks_exact(BRICK_VOXELS)
            .map(|brick| brick.iter().fold(0.0f32, |m, &v| m.max(v)))
            .collect();
        let mut out: Vec<f32> = self.table.iter().map(|&b| stored_max[b as usize]).collect();
        let n = self.bricks;
        let strides = [(n.y * n.z) as usize, n.z as usize, 1];
        for axis in 0..3 {
            for x in 0..n.x {
                for y in 0..n.y {
                    for z in 0..n.z {
                        let b = IVec3::new(x, y, z);
                        if b[axis] + 1 < n[axis] {
                            let c = self.cell(b);
                            out[c] = out[c].max(out[c + strides[axis]]);
                        }
                    }
                }
            }
        }
        for m in &mut out {
            *m *= MAJORANT_MARGIN;
        }
        out
    }

    /// The stretches of the line `origin + t·dir` (index space) with `t` in [`from`, `to`]
    /// that cross the grid, brick by brick, each with its majorant.
    pub fn segments(&self, origin: Vec3, dir: Vec3, from: f32, to: f32) -> Segments<'_> {
        Segments::new(self, origin, dir, from, to)
    }
}

/// Walks the bricks a line crosses (a 3D DDA), giving each stretch's end and majorant.
pub struct Segments<'a> {
    voxels: &'a Voxels,
    /// Current brick.
    cell: IVec3,
    step: IVec3,
    /// Line parameter at which the line leaves the current brick along each axis.
    next: Vec3,
    /// Line parameter to cross one brick along each axis.
    delta: Vec3,
    t: f32,
    end: f32,
    done: bool,
}

impl<'a> Segments<'a> {
    fn new(voxels: &'a Voxels, origin: Vec3, dir: Vec3, from: f32, to: f32) -> Self {
        let (lo, hi) = voxels.bounds();
        let mut this = Self {
            voxels,
            cell: IVec3::ZERO,
            step: IVec3::ZERO,
            next: Vec3::INFINITY,
            delta: Vec3::INFINITY,
            t: from,
            end: to,
            done: true,
        };
        if voxels.is_empty() {
            return this;
        }
        // Clip to the box.
        let inv = dir.recip();
        let (a, b) = ((lo - origin) * inv, (hi - origin) * inv);
        let near = a.min(b);
        let far = a.max(b);
        // NaN (a zero component with the origin on a face) counts as no limit.
        let enter = [near.x, near.y, near.z, from]
            .into_iter()
            .fold(f32::NEG_INFINITY, |m, v| if v > m { v } else { m });
        let leave = [far.x, far.y, far.z, to]
            .into_iter()
            .fold(f32::INFINITY, |m, v| if v < m { v } else { m });
        if enter >= leave || enter.is_nan() || leave.is_nan() {
            return this;
        }
        let size = BRICK as f32;
        let p = origin + dir * enter;
        let cell = ((p - lo) / size)
            .floor()
            .as_ivec3()
            .clamp(IVec3::ZERO, voxels.bricks - 1);
        for axis in 0..3 {
            let d = dir[axis];
            if d > 0.0 {
                this.step[axis] = 1;
                let boundary = lo[axis] + (cell[axis] + 1) as f32 * size;
                this.next[axis] = (boundary - origin[axis]) / d;
                this.delta[axis] = size / d;
            } else if d < 0.0 {
                this.step[axis] = -1;
                let boundary = lo[axis] + cell[axis] as f32 * size;
                this.next[axis] = (boundary - origin[axis]) / d;
                this.delta[axis] = -size / d;
            }
        }
        this.cell = cell;
        this.t = enter;
        this.end = leave;
        this.done = false;
        this
    }

    /// Where the line enters the grid's box (`None`: it misses it within its range).
    pub fn start(&self) -> Option<f32> {
        (!self.done).then_some(self.t)
    }
}

impl Iterator for Segments<'_> {
    /// (start, end, majorant) of one stretch inside one brick.
    type Item = (f32, f32, f32);

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let axis = self.next.min_position();
        let exit = self.next[axis].min(self.end);
        let majorant = self.voxels.majorant[self.voxels.cell(self.cell)];
        let stretch = (self.t, exit.max(self.t), majorant);
        self.t = stretch.1;
        if self.next[axis] >= self.end {
            self.done = true;
        } else {
            self.cell[axis] += self.step[axis];
            self.next[axis] += self.delta[axis];
            if self.cell[axis] < 0 || self.cell[axis] >= self.voxels.bricks[axis] {
                self.done = true;
            }
        }
        Some(stretch)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid of hashed values over a few bricks, some left out, with a constant tile.
    fn sample_grid() -> Voxels {
        let mut b = VoxelsBuilder::default();
        for (n, origin) in [
            IVec3::new(0, 0, 0),
            IVec3::new(8, 0, -8),
            IVec3::new(-16, 8, 0),
        ]
        .into_iter()
        .enumerate()
        {
            let values = Box::new(std::array::from_fn(|i| {
                crate::sampling::hash32((n * 512 + i) as u32) as f32 / u32::MAX as f32
            }));
            b.leaf(origin, values);
        }
        b.tile(IVec3::new(16, 16, 16), 16, 0.75);
        b.build()
    }

    #[test]
    fn voxels_and_interpolation() {
        let g = sample_grid();
        // A voxel reads back its brick's value; the tile is constant; elsewhere zero.
        let expect = crate::sampling::hash32(512 + (3 << 6 | 2 << 3 | 5)) as f32 / u32::MAX as f32;
        assert_eq!(g.voxel(IVec3::new(11, 2, -3)), expect);
        assert_eq!(g.voxel(IVec3::new(31, 20, 16)), 0.75);
        assert_eq!(g.voxel(IVec3::new(100, 0, 0)), 0.0);
        assert_eq!(g.density(Vec3::new(20.5, 20.25, 20.0)), 0.75);
        // Interpolation at a voxel equals it; halfway is the mean.
        let (a, b) = (g.voxel(IVec3::new(3, 4, 5)), g.voxel(IVec3::new(4, 4, 5)));
        assert!((g.density(Vec3::new(3.0, 4.0, 5.0)) - a).abs() < 1e-6);
        assert!((g.density(Vec3::new(3.5, 4.0, 5.0)) - 0.5 * (a + b)).abs() < 1e-6);
    }

    #[test]
    fn majorants_bound_every_interpolated_density() {
        let g = sample_grid();
        let (lo, hi) = g.bounds();
        for k in 0..200_000u32 {
            let u = Vec3::new(
                crate::sampling::hash32(3 * k) as f32,
                crate::sampling::hash32(3 * k + 1) as f32,
                crate::sampling::hash32(3 * k + 2) as f32,
            ) / u32::MAX as f32;
            let p = lo - 2.0 + u * (hi - lo + 4.0);
            assert!(
                g.density(p) <= g.majorant_at(p),
                "{p} {} {}",
                g.density(p),
                g.majorant_at(p)
            );
        }
    }

    #[test]
    fn segments_tile_the_clipped_line_with_the_majorants_along_it() {
        let g = sample_grid();
        let origin = Vec3::new(-30.0, 3.3, -7.1);
        let dir = Vec3::new(1.0, 0.31, 0.52).normalize();
        let stretches: Vec<_> = g.segments(origin, dir, 0.0, 200.0).collect();
        assert!(stretches.len() > 3);
        for w in stretches.windows(2) {
            assert_eq!(w[0].1, w[1].0, "stretches must join");
        }
        for &(a, b, m) in &stretches {
            for i in 0..20 {
                let t = a + (b - a) * (i as f32 + 0.5) / 20.0;
                assert!(g.density(origin + dir * t) <= m + 1e-6);
            }
        }
        // Outside the stretches the density is zero.
        let (first, last) = (stretches[0].0, stretches.last().unwrap().1);
        for t in [first - 0.5, last + 0.5, 0.0, 199.0] {
            if t < first || t > last {
                assert_eq!(g.density(origin + dir * t), 0.0);
            }
        }
        // Along an axis, and a line that misses.
        assert!(
            g.segments(Vec3::new(-30.0, 4.0, 4.0), Vec3::X, 0.0, 100.0)
                .count()
                > 0
        );
        assert_eq!(
            g.segments(Vec3::new(-30.0, 400.0, 4.0), Vec3::X, 0.0, 100.0)
                .count(),
            0
        );
    }
}
