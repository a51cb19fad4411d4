//! OpenVDB files (format 222 and later: OpenVDB 3 onwards, as Houdini, Blender and EmberGen
//! write them): one scalar grid, by name, read into [`Voxels`] with its index-to-world map.
//!
//! The file is a header, then per grid a descriptor (name, type, offsets) followed by the
//! grid: compression flags, metadata, the transform, the tree's topology (root tiles and
//! children, internal nodes' masks and tile values, leaves' masks) and then the leaves' values
//! in tree order. Every count, length and offset comes from the file and is checked before it
//! is used; nothing is allocated beyond `max_bytes` of voxels.

mod blosc;
mod tree;

use crate::media::voxels::Voxels;
use glam::{DAffine3, DMat3, DVec3};

/// The oldest file format read: node-mask compression, per-grid compression flags.
const MIN_FORMAT: u32 = 222;
const MAGIC: u64 = 0x5644_4220;

/// Per-grid compression flags.
pub(crate) const COMPRESS_ZIP: u32 = 0x1;
pub(crate) const COMPRESS_ACTIVE_MASK: u32 = 0x2;
pub(crate) const COMPRESS_BLOSC: u32 = 0x4;

/// A scalar grid read from a VDB file.
pub struct Grid {
    pub voxels: Voxels,
    /// From index space (voxel centres at integer coordinates) to the file's world space.
    pub world_from_index: DAffine3,
}

/// Reads the scalar grid called `name` from the bytes of a VDB file, refusing one whose voxels
/// would need more than `max_bytes`.
pub fn read_grid(bytes: &[u8], name: &str, max_bytes: u64) -> Result<Grid, String> {
    let mut c = Cursor { bytes, at: 0 };
    header(&mut c)?;
    let count = c.u32("the grid count")?;
    let mut names = Vec::new();
    for _ in 0..count {
        let descriptor = Descriptor::read(&mut c)?;
        if descriptor.name == name {
            return descriptor.grid(bytes, max_bytes);
        }
        names.push(descriptor.name);
        c.seek(descriptor.end, "the next grid")?;
    }
    Err(format!(
        "no grid is called {name:?}; the file holds {}",
        if names.is_empty() {
            "no grids".to_owned()
        } else {
            names
                .iter()
                .map(|n| format!("{n:?}"))
                .collect::<Vec<_>>()
                .join(", ")
        }
    ))
}

/// Reads the file header up to the grid count.
fn header(c: &mut Cursor) -> Result<(), String> {
    if c.u64("the magic number").ok() != Some(MAGIC) {
        return Err("not an OpenVDB file (its first bytes are not the VDB magic number)".into());
    }
    let format = c.u32("the format version")?;
    if format < MIN_FORMAT {
        return Err(format!(
            "OpenVDB file format {format} is older than rift reads ({MIN_FORMAT}, OpenVDB 3); \
             save it again with a newer OpenVDB"
        ));
    }
    c.u32("the library version")?;
    c.u32("the library version")?;
    if c.u8("the grid-offsets flag")? == 0 {
        return Err("the file has no grid offsets (written by OpenVDB before 2.0?)".into());
    }
    c.take(36, "the file's UUID")?;
    skip_metadata(c)
}

/// Skips a metadata table (name, type and sized value per entry).
fn skip_metadata(c: &mut Cursor) -> Result<(), String> {
    let entries = c.u32("a metadata count")?;
    for _ in 0..entries {
        c.string("a metadata name")?;
        c.string("a metadata type")?;
        let size = c.u32("a metadata size")? as usize;
        c.take(size, "a metadata value")?;
    }
    Ok(())
}

/// The value type of a grid's tree.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum ValueType {
    F32,
    F64,
    /// Floats saved as half precision.
    Half,
}

/// A grid descriptor: where the grid lies in the file and what it holds.
struct Descriptor {
    name: String,
    value: Result<ValueType, String>,
    start: usize,
    blocks: usize,
    end: usize,
}

impl Descriptor {
    fn read(c: &mut Cursor) -> Result<Self, String> {
        let unique = c.string("a grid name")?;
        // Duplicate names get a suffix after an ASCII record separator.
        let name = unique.split('\u{1e}').next().unwrap_or_default().to_owned();
        let kind = c.string("a grid type")?;
        let parent = c.string("a grid's instance parent")?;
        let value = match kind.as_str() {
            "Tree_float_5_4_3" => Ok(ValueType::F32),
            "Tree_float_5_4_3_HalfFloat" => Ok(ValueType::Half),
            "Tree_double_5_4_3" => Ok(ValueType::F64),
            _ => Err(format!(
                "grid {name:?} is a {kind}; rift reads scalar float grids"
            )),
        };
        let value = if parent.is_empty() {
            value
        } else {
            Err(format!(
                "grid {name:?} is an instance of {parent:?}; save the file without instancing"
            ))
        };
        let start = c.offset("a grid's offset")?;
        let blocks = c.offset("a grid's block offset")?;
        let end = c.offset("a grid's end offset")?;
        if !(start <= blocks && blocks <= end && end <= c.bytes.len()) {
            return Err(format!(
                "grid {name:?} lies at bytes {start}..{end} (values from {blocks}) of a \
                 {}-byte file",
                c.bytes.len()
            ));
        }
        Ok(Self {
            name,
            value,
            start,
            blocks,
            end,
        })
    }

    /// Reads the grid itself.
    fn grid(self, bytes: &[u8], max_bytes: u64) -> Result<Grid, String> {
        let value = self.value?;
        let in_grid = |e: String| format!("grid {:?}: {e}", self.name);
        let mut c = Cursor {
            bytes: &bytes[..self.end],
            at: self.start,
        };
        let compression = c.u32("the compression flags").map_err(in_grid)?;
        if compression & !(COMPRESS_ZIP | COMPRESS_ACTIVE_MASK | COMPRESS_BLOSC) != 0 {
            return Err(in_grid(format!(
                "unknown compression flags {compression:#x}"
            )));
        }
        skip_metadata(&mut c).map_err(in_grid)?;
        let world_from_index = transform(&mut c).map_err(in_grid)?;
        let stream = tree::Stream {
            compression,
            value,
            max_bytes,
        };
        let mut topology = stream.topology(&mut c).map_err(in_grid)?;
        c.seek(self.blocks, "the grid's values").map_err(in_grid)?;
        stream.values(&mut c, &mut topology).map_err(in_grid)?;
        Ok(Grid {
            voxels: topology.into_voxels(),
            world_from_index,
        })
    }
}

/// Reads a grid's transform: the map from index to world space. Linear maps only (scale,
/// translation, affine); frustum maps are refused.
fn transform(c: &mut Cursor) -> Result<DAffine3, String> {
    let kind = c.string("the transform's type")?;
    let vec3 = |c: &mut Cursor, what| -> Result<DVec3, String> {
        Ok(DVec3::new(c.f64(what)?, c.f64(what)?, c.f64(what)?))
    };
    let map = match kind.as_str() {
        "UniformScaleMap" | "ScaleMap" => {
            let scale = vec3(c, "the transform's scale")?;
            for _ in 0..4 {
                vec3(c, "the transform's derived values")?;
            }
            DAffine3::from_scale(scale)
        }
        "UniformScaleTranslateMap" | "ScaleTranslateMap" => {
            let translation = vec3(c, "the transform's translation")?;
            let scale = vec3(c, "the transform's scale")?;
            for _ in 0..4 {
                vec3(c, "the transform's derived values")?;
            }
            DAffine3::from_scale_rotation_translation(scale, glam::DQuat::IDENTITY, translation)
        }
        "TranslationMap" => DAffine3::from_translation(vec3(c, "the transform's translation")?),
        "AffineMap" | "UnitaryMap" => {
            // A 4x4 matrix applied to row vectors: rows 0-2 are the images of the axes, row 3
            // the translation.
            let rows: Vec<DVec3> = (0..4)
                .map(|_| {
                    let r = vec3(c, "the transform's matrix")?;
                    c.f64("the transform's matrix")?;
                    Ok(r)
                })
                .collect::<Result<_, String>>()?;
            DAffine3::from_mat3_translation(DMat3::from_cols(rows[0], rows[1], rows[2]), rows[3])
        }
        other => {
            return Err(format!(
                "its transform is a {other}; rift reads linear transforms (scale, translation, \
                 affine)"
            ));
        }
    };
    let det = map.matrix3.determinant();
    if !map.is_finite() || !det.is_normal() {
        return Err(format!(
            "its transform is singular or not finite (determinant {det:e})"
        ));
    }
    Ok(map)
}

/// Reads little-endian values from bytes, every read bounds-checked.
pub(crate) struct Cursor<'a> {
    pub bytes: &'a [u8],
    pub at: usize,
}

impl<'a> Cursor<'a> {
    pub fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], String> {
        let slice = self
            .at
            .checked_add(n)
            .and_then(|end| self.bytes.get(self.at..end))
            .ok_or_else(|| {
                format!(
                    "the file ends (or the grid's bytes end) at byte {} in {what}",
                    self.bytes.len()
                )
            })?;
        self.at += n;
        Ok(slice)
    }

    fn array<const N: usize>(&mut self, what: &str) -> Result<[u8; N], String> {
        Ok(self.take(N, what)?.try_into().unwrap_or([0; N]))
    }

    pub fn u8(&mut self, what: &str) -> Result<u8, String> {
        Ok(self.array::<1>(what)?[0])
    }

    pub fn u32(&mut self, what: &str) -> Result<u32, String> {
        self.array(what).map(u32::from_le_bytes)
    }

    pub fn i32(&mut self, what: &str) -> Result<i32, String> {
        self.array(what).map(i32::from_le_bytes)
    }

    pub fn i64(&mut self, what: &str) -> Result<i64, String> {
        self.array(what).map(i64::from_le_bytes)
    }

    pub fn u64(&mut self, what: &str) -> Result<u64, String> {
        self.array(what).map(u64::from_le_bytes)
    }

    pub fn f64(&mut self, what: &str) -> Result<f64, String> {
        self.array(what).map(f64::from_le_bytes)
    }

    /// A value of `value`'s full precision, as f32.
    pub fn value(&mut self, value: ValueType, what: &str) -> Result<f32, String> {
        Ok(match value {
            ValueType::F64 => self.f64(what)? as f32,
            _ => f32::from_le_bytes(self.array(what)?),
        })
    }

    /// A length-prefixed string.
    fn string(&mut self, what: &str) -> Result<String, String> {
        let n = self.u32(what)? as usize;
        let bytes = self.take(n, what)?;
        String::from_utf8(bytes.to_vec()).map_err(|_| format!("{what} is not UTF-8"))
    }

    /// A file offset (u64) that fits the file.
    fn offset(&mut self, what: &str) -> Result<usize, String> {
        let at = self.u64(what)?;
        usize::try_from(at)
            .ok()
            .filter(|&a| a <= self.bytes.len())
            .ok_or_else(|| format!("{what} {at} lies past the end of the file"))
    }

    fn seek(&mut self, to: usize, what: &str) -> Result<(), String> {
        if to > self.bytes.len() {
            return Err(format!("{what} would start past the end of the file"));
        }
        self.at = to;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    //! Against files written by OpenVDB itself (tools/make_vdb_fixtures.py), whose values
    //! follow closed forms evaluated again here.
    use super::*;
    use glam::{IVec3, Vec3};

    fn fixture(name: &str) -> Vec<u8> {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../tests/data/vdb")
            .join(name);
        std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
    }

    fn puff(v: IVec3) -> f32 {
        let r = (v - IVec3::new(3, -2, 5)).as_vec3().length();
        (1.0 - r / 8.0).max(0.0) * (0.75 + 0.25 * (0.4 * v.x as f32).sin())
    }

    /// Every voxel of the puff's box (and a margin of zeros) against the closed form.
    fn check_puff(grid: &Grid, tolerance: f32) {
        let mut worst = 0.0f32;
        for x in -12..20 {
            for y in -14..10 {
                for z in -8..18 {
                    let v = IVec3::new(x, y, z);
                    worst = worst.max((grid.voxels.voxel(v) - puff(v)).abs());
                }
            }
        }
        assert!(worst <= tolerance, "worst voxel off by {worst}");
    }

    #[test]
    fn a_blosc_grid_reads_back_every_voxel_and_its_transform() {
        let grid = read_grid(&fixture("puff.vdb"), "density", 1 << 30).unwrap();
        check_puff(&grid, 1e-6);
        let world = grid
            .world_from_index
            .transform_point3(glam::DVec3::new(2.0, -4.0, 6.0));
        assert!(
            (world - glam::DVec3::new(1.1, 1.8, 3.3))
                .abs()
                .max_element()
                < 1e-12,
            "{world}"
        );
    }

    #[test]
    fn half_precision_affine_maps_and_grids_by_name() {
        let bytes = fixture("puff_half.vdb");
        let grid = read_grid(&bytes, "density", 1 << 30).unwrap();
        check_puff(&grid, 1e-3);
        let m = grid.world_from_index;
        let (c, s) = (0.5f64.cos(), 0.5f64.sin());
        let x = m.transform_point3(glam::DVec3::X) - m.translation;
        assert!(
            (x - glam::DVec3::new(0.1 * c, 0.1 * s, 0.0)).length() < 1e-12,
            "{x}"
        );
        assert!((m.translation - glam::DVec3::new(0.5, 0.0, -1.0)).length() < 1e-12);
        // The full-precision grid beside it, and what is refused.
        check_puff(&read_grid(&bytes, "temperature", 1 << 30).unwrap(), 1e-6);
        let e = read_grid(&bytes, "vel", 1 << 30).err().unwrap();
        assert!(e.contains("vec3s") || e.contains("Vec3"), "{e}");
        let e = read_grid(&bytes, "smoke", 1 << 30).err().unwrap();
        assert!(e.contains("\"temperature\", \"density\", \"vel\""), "{e}");
    }

    #[test]
    fn constant_tiles_fill_their_regions() {
        let grid = read_grid(&fixture("slab.vdb"), "density", 1 << 30).unwrap();
        let inside = |v: IVec3| {
            v.cmpge(IVec3::new(-8, -8, 0)).all() && v.cmplt(IVec3::new(40, 24, 16)).all()
        };
        for x in -20..50 {
            for y in -20..30 {
                for z in -10..25 {
                    let v = IVec3::new(x, y, z);
                    assert_eq!(grid.voxels.voxel(v), inside(v) as u8 as f32, "{v}");
                }
            }
        }
        assert_eq!(grid.voxels.density(Vec3::new(3.3, 0.7, 7.5)), 1.0);
    }

    #[test]
    fn memory_limits_and_damaged_files_are_refused() {
        let bytes = fixture("puff.vdb");
        let e = read_grid(&bytes, "density", 4096).err().unwrap();
        assert!(e.contains("MiB"), "{e}");
        assert!(
            read_grid(b"not a vdb file at all", "density", 1 << 30)
                .err()
                .unwrap()
                .contains("not an OpenVDB file")
        );
        // Every truncation, and a byte flipped at many places, must fail or read, never panic.
        for cut in (0..bytes.len()).step_by(97) {
            assert!(
                read_grid(&bytes[..cut], "density", 1 << 30).is_err(),
                "cut at {cut}"
            );
        }
        for at in (0..bytes.len()).step_by(61) {
            let mut b = bytes.clone();
            b[at] ^= 0x5a;
            let _ = read_grid(&b, "density", 1 << 26);
        }
    }

    #[test]
    fn a_table_past_what_a_u64_counts_is_refused() {
        // A damaged file (found by the fuzzer) whose nodes lie so far apart on every axis
        // that the table's entries, times their bytes, passed 2^64: the count wrapped (or,
        // with overflow checks, panicked) before the memory check.
        let e = refusal_of_regression("table-past-u64.vdb", 1 << 30);
        // The bytes stop at the most a u64 counts (they wrapped to 6.6e12 MiB before).
        assert!(e.contains(&format!("{} MiB", u64::MAX >> 20)), "{e}");
    }

    #[test]
    fn a_leaf_far_from_the_tiles_counts_in_the_table_it_stretches() {
        // A damaged smoke file (found by the fuzzer) whose tiles lie in one corner and one
        // leaf far away: the table between them passed the memory check when only the tiles
        // were counted, then took seconds to fill.
        let e = refusal_of_regression("leaf-far-from-tiles.vdb", 8 << 20);
        assert!(e.contains("MiB"), "{e}");
    }

    /// The error reading the density grid of `fuzz/regressions/vdb/<name>` within
    /// `max_bytes` gives (a panic if it reads).
    fn refusal_of_regression(name: &str, max_bytes: u64) -> String {
        let path = format!(
            "{}/../fuzz/regressions/vdb/{name}",
            env!("CARGO_MANIFEST_DIR")
        );
        let bytes = std::fs::read(path).unwrap();
        read_grid(&bytes, "density", max_bytes).err().unwrap()
    }
}
