//! A VDB tree (root → 32³ → 16³ internal nodes → 8³ leaves): its topology, tile values and
//! leaf values, read into a [`VoxelsBuilder`].

use super::{COMPRESS_ACTIVE_MASK, COMPRESS_BLOSC, COMPRESS_ZIP, Cursor, ValueType};
use crate::media::voxels::{BRICK, Voxels, VoxelsBuilder};
use glam::IVec3;
use std::io::Read;

/// log2 of the side of each internal level's node table, top first.
const INTERNAL_LOG2: [u32; 2] = [5, 4];
/// Voxels per side of a root child (32 × 16 × 8).
const ROOT_CHILD: i32 = 4096;
/// Values of a leaf.
const LEAF_VALUES: usize = 512;
/// Bytes of voxel storage a leaf costs (its values and its table entry, roughly).
const LEAF_BYTES: u64 = 2048 + 8;

/// How the grid's values are stored.
pub(crate) struct Stream {
    pub compression: u32,
    pub value: ValueType,
    pub max_bytes: u64,
}

/// What the topology pass found: tiles (already in the builder) and the leaves' origins in
/// the order their values follow.
pub(crate) struct Topology {
    builder: VoxelsBuilder,
    leaves: Vec<IVec3>,
}

impl Topology {
    pub fn into_voxels(self) -> Voxels {
        self.builder.build()
    }
}

/// How a node's value table was saved (OpenVDB's mask-compression metadata).
/// (0 and 1, no mask with the background or its negative as the inactive value, need no
/// reading: the background is zero.)
mod meta {
    pub const NO_MASK_AND_ONE_INACTIVE_VAL: u8 = 2;
    pub const MASK_AND_NO_INACTIVE_VALS: u8 = 3;
    pub const MASK_AND_ONE_INACTIVE_VAL: u8 = 4;
    pub const MASK_AND_TWO_INACTIVE_VALS: u8 = 5;
    pub const NO_MASK_AND_ALL_VALS: u8 = 6;
}

impl Stream {
    /// Reads the tree's topology: the root's tiles and children, down to the leaves' masks.
    pub fn topology(&self, c: &mut Cursor) -> Result<Topology, String> {
        let buffers = c.i32("the tree's buffer count")?;
        if buffers != 1 {
            return Err(format!("its tree has {buffers} buffers; rift reads one"));
        }
        let background = c.value(self.value, "the background value")?;
        if background != 0.0 {
            return Err(format!(
                "its background value is {background}; a density grid must be 0 outside its \
                 voxels"
            ));
        }
        let tiles = c.u32("the root's tile count")?;
        let children = c.u32("the root's child count")?;
        let mut topology = Topology {
            builder: VoxelsBuilder::default(),
            leaves: Vec::new(),
        };
        for _ in 0..tiles {
            let origin = coord(c)?;
            let value = c.value(self.value, "a root tile")?;
            c.u8("a root tile's active flag")?;
            aligned(origin, ROOT_CHILD)?;
            topology.builder.tile(origin, ROOT_CHILD, finite(value)?);
        }
        let mut children_leaves = Vec::new();
        for _ in 0..children {
            let origin = coord(c)?;
            aligned(origin, ROOT_CHILD)?;
            let mut leaves = Vec::new();
            self.internal(c, origin, 0, &mut topology.builder, &mut leaves)?;
            children_leaves.push((origin, leaves));
        }
        // Values follow in the root's order: its children sorted by origin.
        children_leaves.sort_by_key(|(o, _)| (o.x, o.y, o.z));
        topology.leaves = children_leaves.into_iter().flat_map(|(_, l)| l).collect();
        // The table spans the leaves too, whose values are read later: a leaf far from the
        // tiles stretches it as much as a tile would.
        let cells = topology.builder.table_len(&topology.leaves);
        // Nodes that overlap (two root children at one origin, say) would make filling the
        // table cost far more than its size.
        if topology.builder.covered_bricks(topology.leaves.len()) > cells {
            return Err("its tree has nodes that overlap; the file is damaged".into());
        }
        // Each tile value takes a brick of its own, as a leaf does: a damaged tree of many
        // tiles with different values would otherwise take far more memory (and time) than
        // the table's size shows.
        let bricks = topology.leaves.len() as u64 + topology.builder.tile_bricks();
        // Saturating, as the table's size is: past what a u64 counts is past any limit.
        let bytes = bricks
            .saturating_mul(LEAF_BYTES)
            .saturating_add(cells.saturating_mul(8));
        if bytes > self.max_bytes {
            return Err(format!(
                "its {bricks} bricks of values (leaves and tile values) over a table of {cells} \
                 bricks need about {} MiB, more than the {} MiB allowed",
                bytes >> 20,
                self.max_bytes >> 20
            ));
        }
        Ok(topology)
    }

    /// Reads an internal node at `origin` of level `level` (0: 32³ under the root).
    fn internal(
        &self,
        c: &mut Cursor,
        origin: IVec3,
        level: usize,
        builder: &mut VoxelsBuilder,
        leaves: &mut Vec<IVec3>,
    ) -> Result<(), String> {
        let log2 = INTERNAL_LOG2[level];
        let entries = 1usize << (3 * log2);
        let child_side = ROOT_CHILD >> INTERNAL_LOG2[..=level].iter().sum::<u32>();
        let children = mask(c, entries, "an internal node's child mask")?;
        let active = mask(c, entries, "an internal node's value mask")?;
        let values = self.compressed_values(c, entries, &active)?;
        for (i, &value) in values.iter().enumerate() {
            let at = origin + offset(i, log2) * child_side;
            if !bit(&children, i) {
                builder.tile(at, child_side, finite(value)?);
            } else if level + 1 < INTERNAL_LOG2.len() {
                self.internal(c, at, level + 1, builder, leaves)?;
            } else {
                mask(c, LEAF_VALUES, "a leaf's value mask")?;
                leaves.push(at);
                if leaves.len() as u64 * LEAF_BYTES > self.max_bytes {
                    return Err(format!(
                        "it has more leaves than fit in the {} MiB allowed",
                        self.max_bytes >> 20
                    ));
                }
            }
        }
        Ok(())
    }

    /// Reads every leaf's values, in the order of `topology`.
    pub fn values(&self, c: &mut Cursor, topology: &mut Topology) -> Result<(), String> {
        for &origin in &topology.leaves {
            let active = mask(c, LEAF_VALUES, "a leaf's value mask")?;
            let values = self.compressed_values(c, LEAF_VALUES, &active)?;
            let mut brick = Box::new([0.0f32; LEAF_VALUES]);
            for (out, v) in brick.iter_mut().zip(values) {
                *out = finite(v)?;
            }
            topology.builder.leaf(origin, brick);
        }
        Ok(())
    }

    /// Reads a node's table of `count` values, of which those inactive in `active` may have
    /// been left out (mask compression) and are rebuilt from the one or two inactive values
    /// saved with it (the background is zero).
    fn compressed_values(
        &self,
        c: &mut Cursor,
        count: usize,
        active: &[u64],
    ) -> Result<Vec<f32>, String> {
        use meta::*;
        let flag = c.u8("a node's compression metadata")?;
        if flag > NO_MASK_AND_ALL_VALS {
            return Err(format!(
                "a node's compression metadata is {flag} (0 to 6 expected)"
            ));
        }
        let mut inactive = [0.0f32; 2];
        if matches!(
            flag,
            NO_MASK_AND_ONE_INACTIVE_VAL | MASK_AND_ONE_INACTIVE_VAL | MASK_AND_TWO_INACTIVE_VALS
        ) {
            inactive[0] = c.value(self.value, "an inactive value")?;
            if flag == MASK_AND_TWO_INACTIVE_VALS {
                inactive[1] = c.value(self.value, "an inactive value")?;
            }
        }
        let selection = if matches!(
            flag,
            MASK_AND_NO_INACTIVE_VALS | MASK_AND_ONE_INACTIVE_VAL | MASK_AND_TWO_INACTIVE_VALS
        ) {
            mask(c, count, "a node's selection mask")?
        } else {
            vec![0; count / 64]
        };
        let stored = if self.compression & COMPRESS_ACTIVE_MASK != 0 && flag != NO_MASK_AND_ALL_VALS
        {
            active.iter().map(|w| w.count_ones() as usize).sum()
        } else {
            count
        };
        let data = self.read_data(c, stored)?;
        if stored == count {
            return Ok(data);
        }
        let mut next = data.into_iter();
        Ok((0..count)
            .map(|i| {
                if bit(active, i) {
                    next.next().unwrap_or(0.0)
                } else {
                    inactive[bit(&selection, i) as usize]
                }
            })
            .collect())
    }

    /// Reads `count` values of the grid's stored type, compressed as the grid says.
    fn read_data(&self, c: &mut Cursor, count: usize) -> Result<Vec<f32>, String> {
        let size = match self.value {
            ValueType::Half => 2,
            ValueType::F32 => 4,
            ValueType::F64 => 8,
        };
        let expected = count * size;
        if count == 0 && self.value == ValueType::Half {
            // OpenVDB writes nothing at all for an empty block of halves.
            return Ok(Vec::new());
        }
        let raw: Vec<u8> = if self.compression & (COMPRESS_BLOSC | COMPRESS_ZIP) != 0 {
            let length = c.i64("a compressed block's length")?;
            if length <= 0 {
                let n = length.unsigned_abs() as usize;
                if n != expected {
                    return Err(format!(
                        "a stored block holds {n} bytes where {expected} were expected"
                    ));
                }
                c.take(n, "a stored block")?.to_vec()
            } else {
                let n =
                    usize::try_from(length).map_err(|_| "a block length overflows".to_owned())?;
                let packed = c.take(n, "a compressed block")?;
                if self.compression & COMPRESS_BLOSC != 0 {
                    super::blosc::decompress(packed, expected)?
                } else {
                    let mut out = vec![0u8; expected];
                    flate2::read::ZlibDecoder::new(packed)
                        .read_exact(&mut out)
                        .map_err(|e| format!("a zip-compressed block: {e}"))?;
                    out
                }
            }
        } else {
            c.take(expected, "a block of values")?.to_vec()
        };
        Ok(raw
            .chunks_exact(size)
            .map(|b| match self.value {
                ValueType::Half => half::f16::from_le_bytes([b[0], b[1]]).to_f32(),
                ValueType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                ValueType::F64 => f64::from_le_bytes(b.try_into().unwrap_or([0; 8])) as f32,
            })
            .collect())
    }
}

fn coord(c: &mut Cursor) -> Result<IVec3, String> {
    Ok(IVec3::new(
        c.i32("a coordinate")?,
        c.i32("a coordinate")?,
        c.i32("a coordinate")?,
    ))
}

/// A node's origin must be a multiple of its size (and far enough from the integer limits
/// that its voxels' coordinates do not overflow).
fn aligned(origin: IVec3, side: i32) -> Result<(), String> {
    // Compared as a range: `abs` of i32::MIN overflows.
    let limit = IVec3::splat(i32::MAX / 2);
    let outside = origin.cmpgt(limit) | origin.cmplt(-limit);
    if outside.any() || (origin % side) != IVec3::ZERO {
        return Err(format!(
            "a node at {origin} is not on the {side}-voxel lattice"
        ));
    }
    Ok(())
}

fn finite(v: f32) -> Result<f32, String> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("it holds a value of {v}; densities must be finite"))
    }
}

/// A mask of `bits` bits.
fn mask(c: &mut Cursor, bits: usize, what: &str) -> Result<Vec<u64>, String> {
    (0..bits / 64).map(|_| c.u64(what)).collect()
}

fn bit(mask: &[u64], i: usize) -> bool {
    mask[i / 64] >> (i % 64) & 1 == 1
}

/// The position of entry `i` in a node table of side 2^`log2` (x slowest, z fastest).
fn offset(i: usize, log2: u32) -> IVec3 {
    let side = (1usize << log2) - 1;
    IVec3::new(
        (i >> (2 * log2)) as i32,
        ((i >> log2) & side) as i32,
        (i & side) as i32,
    )
}

const _: () = assert!(ROOT_CHILD == BRICK << 9);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn node_origins_near_the_integer_limits_are_refused() {
        let side = ROOT_CHILD;
        assert!(aligned(IVec3::new(-side, 0, 2 * side), side).is_ok());
        assert!(aligned(IVec3::new(side, 1, 0), side).is_err());
        // i32::MIN is on every power-of-two lattice, and its `abs` overflows.
        for origin in [
            IVec3::new(i32::MIN, 0, 0),
            IVec3::new(0, 0, i32::MIN),
            IVec3::new(0, i32::MAX / 2 + side, 0),
            IVec3::new(-(i32::MAX / 2) - side, 0, 0),
        ] {
            assert!(aligned(origin, side).is_err(), "{origin}");
        }
    }
}
