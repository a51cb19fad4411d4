//! The native ring cache: every opening's baked strands for one frame, in one little-endian file
//! that loads with a single read and no parsing beyond slicing.
//!
//! ```text
//! "RIFTRING" u32 version(1) u32 ring_count
//! i64 frame  f64 time  f64 fps  f64 shutter_open  f64 shutter_close      (seconds)
//! per ring:
//!   u32 name_len, name (UTF-8)
//!   3 × here frame (open, frame, close): f64 quat x y z w, f64 translation x y z, f64 scale
//!   u32 strand_count  u32 vertex_count
//!   u32 vertex_counts[strand_count]  i32 directions[strand_count]
//!   f32 points[3n] velocities[3n] accelerations[3n] widths[n] colors[3n] intensities[n]
//! u64 FNV-1a hash of everything above
//! ```

use crate::error::FxError;
use crate::rig::Similarity;
use crate::ring::{RingCurves, RingFrame};
use glam::{DQuat, DVec3, Vec3};
use std::io::{self, Write};
use std::path::Path;

const MAGIC: &[u8; 8] = b"RIFTRING";
const VERSION: u32 = 1;

/// Writes one frame.
pub fn write(w: &mut dyn Write, frame: &RingFrame) -> io::Result<()> {
    let mut b = Vec::with_capacity(64 + frame.vertex_count() * 56);
    b.extend_from_slice(MAGIC);
    b.extend_from_slice(&VERSION.to_le_bytes());
    b.extend_from_slice(&(frame.rings.len() as u32).to_le_bytes());
    b.extend_from_slice(&frame.frame.to_le_bytes());
    for v in [frame.time, frame.fps, frame.shutter[0], frame.shutter[1]] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    for ring in &frame.rings {
        b.extend_from_slice(&(ring.opening.len() as u32).to_le_bytes());
        b.extend_from_slice(ring.opening.as_bytes());
        for s in [ring.here_shutter[0], ring.here, ring.here_shutter[1]] {
            let values = s
                .rotation
                .to_array()
                .into_iter()
                .chain(s.translation.to_array())
                .chain([s.scale]);
            for v in values {
                b.extend_from_slice(&v.to_le_bytes());
            }
        }
        b.extend_from_slice(&(ring.vertex_counts.len() as u32).to_le_bytes());
        b.extend_from_slice(&(ring.len() as u32).to_le_bytes());
        for n in &ring.vertex_counts {
            b.extend_from_slice(&n.to_le_bytes());
        }
        for d in &ring.directions {
            b.extend_from_slice(&(*d as i32).to_le_bytes());
        }
        for array in [&ring.points, &ring.velocities, &ring.accelerations] {
            for v in array.iter() {
                for c in v.to_array() {
                    b.extend_from_slice(&c.to_le_bytes());
                }
            }
        }
        for v in &ring.widths {
            b.extend_from_slice(&v.to_le_bytes());
        }
        for v in &ring.colors {
            for c in v.to_array() {
                b.extend_from_slice(&c.to_le_bytes());
            }
        }
        for v in &ring.intensities {
            b.extend_from_slice(&v.to_le_bytes());
        }
    }
    let hash = fnv1a(&b);
    b.extend_from_slice(&hash.to_le_bytes());
    w.write_all(&b)
}

/// Reads a cache file.
pub fn read(path: &Path) -> Result<RingFrame, FxError> {
    let bytes = crate::io::read(path).map_err(|cause| FxError::Read {
        file: path.to_owned(),
        cause,
    })?;
    decode(&bytes).map_err(|message| FxError::Cache {
        file: path.to_owned(),
        message,
    })
}

/// Decodes cache bytes.
pub fn decode(bytes: &[u8]) -> Result<RingFrame, String> {
    if bytes.len() < MAGIC.len() + 16 || &bytes[..8] != MAGIC {
        return Err("missing RIFTRING header".into());
    }
    let (body, tail) = bytes.split_at(bytes.len() - 8);
    if fnv1a(body) != u64::from_le_bytes(tail.try_into().unwrap()) {
        return Err("checksum mismatch (truncated or corrupt file)".into());
    }
    let mut r = Reader { bytes: body, at: 8 };
    let version = r.u32()?;
    if version != VERSION {
        return Err(format!(
            "version {version}; this rift reads version {VERSION}"
        ));
    }
    let ring_count = r.u32()? as usize;
    let frame = r.i64()?;
    let [time, fps, open, close] = [r.f64()?, r.f64()?, r.f64()?, r.f64()?];
    let mut rings = Vec::with_capacity(ring_count.min(1 << 16));
    for _ in 0..ring_count {
        let name_len = r.u32()? as usize;
        let opening = String::from_utf8(r.take(name_len)?.to_vec())
            .map_err(|_| "an opening name is not UTF-8".to_string())?;
        let mut frames = [Similarity::IDENTITY; 3];
        for f in &mut frames {
            let q = DQuat::from_xyzw(r.f64()?, r.f64()?, r.f64()?, r.f64()?);
            let t = DVec3::new(r.f64()?, r.f64()?, r.f64()?);
            *f = Similarity::new(q, t, r.f64()?);
        }
        let strands = r.u32()? as usize;
        let n = r.u32()? as usize;
        let vertex_counts = (0..strands)
            .map(|_| r.u32())
            .collect::<Result<Vec<_>, _>>()?;
        if vertex_counts.iter().map(|&c| c as usize).sum::<usize>() != n {
            return Err(format!(
                "ring {opening:?}: strand vertex counts do not add up to {n}"
            ));
        }
        // Read whole before narrowing to i8, so 257 is refused rather than read as 1.
        let directions = (0..strands)
            .map(|i| match r.u32()? as i32 {
                1 => Ok(1),
                -1 => Ok(-1),
                other => Err(format!(
                    "ring {opening:?}: strand {i} turns {other}, not +1 or -1"
                )),
            })
            .collect::<Result<Vec<i8>, _>>()?;
        let points = r.vec3s(n)?;
        let velocities = r.vec3s(n)?;
        let accelerations = r.vec3s(n)?;
        let widths = r.f32s(n)?;
        let colors = r.vec3s(n)?;
        let intensities = r.f32s(n)?;
        rings.push(RingCurves {
            opening,
            here: frames[1],
            here_shutter: [frames[0], frames[2]],
            vertex_counts,
            directions,
            points,
            velocities,
            accelerations,
            widths,
            colors,
            intensities,
        });
    }
    if r.at != body.len() {
        return Err("unexpected bytes after the last ring".into());
    }
    let decoded = RingFrame {
        frame,
        time,
        fps,
        shutter: [open, close],
        rings,
    };
    decoded.check()?;
    Ok(decoded)
}

/// 64-bit FNV-1a: the checksum that ends a cache, over everything before it.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let end = end.ok_or_else(|| "the file ends early".to_string())?;
        let out = &self.bytes[self.at..end];
        self.at = end;
        Ok(out)
    }
    fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().unwrap()))
    }
    fn i64(&mut self) -> Result<i64, String> {
        Ok(i64::from_le_bytes(self.take(8)?.try_into().unwrap()))
    }
    fn f64(&mut self) -> Result<f64, String> {
        Ok(f64::from_le_bytes(self.take(8)?.try_into().unwrap()))
    }
    fn f32s(&mut self, n: usize) -> Result<Vec<f32>, String> {
        let raw = self.take(n.checked_mul(4).ok_or("size overflow")?)?;
        Ok(raw
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect())
    }
    fn vec3s(&mut self, n: usize) -> Result<Vec<Vec3>, String> {
        let flat = self.f32s(n.checked_mul(3).ok_or("size overflow")?)?;
        Ok(flat.chunks_exact(3).map(Vec3::from_slice).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One ring of one strand (two vertices turning +1), written as a cache.
    fn one_strand() -> RingFrame {
        let ring = RingCurves {
            opening: "door".into(),
            here: Similarity::IDENTITY,
            here_shutter: [Similarity::IDENTITY; 2],
            vertex_counts: vec![2],
            directions: vec![1],
            points: vec![Vec3::X, Vec3::Y],
            velocities: vec![Vec3::ZERO; 2],
            accelerations: vec![Vec3::ZERO; 2],
            widths: vec![0.01; 2],
            colors: vec![Vec3::ONE; 2],
            intensities: vec![1.0; 2],
        };
        RingFrame {
            frame: 1,
            time: 1.0 / 24.0,
            fps: 24.0,
            shutter: [0.0, 0.0],
            rings: vec![ring],
        }
    }

    /// `frame`'s cache with its first strand's direction stored as `direction`, and the
    /// checksum made again so that only the direction is wrong.
    fn with_direction(frame: &RingFrame, direction: i32) -> Vec<u8> {
        let mut bytes = Vec::new();
        write(&mut bytes, frame).unwrap();
        // Header (56 bytes), the name's length and the name, three frames of eight f64, the
        // strand and vertex counts, one strand's vertex count: then the direction.
        let at = 56 + 4 + frame.rings[0].opening.len() + 3 * 64 + 8 + 4;
        bytes[at..at + 4].copy_from_slice(&direction.to_le_bytes());
        let body = bytes.len() - 8;
        let sum = fnv1a(&bytes[..body]);
        bytes[body..].copy_from_slice(&sum.to_le_bytes());
        bytes
    }

    #[test]
    fn reads_back_both_directions() {
        let frame = one_strand();
        for d in [1, -1] {
            let back = decode(&with_direction(&frame, d)).unwrap();
            assert_eq!(back.rings[0].directions, vec![d as i8]);
        }
    }

    /// −128 once overflowed the check's absolute value (a panic in builds with overflow
    /// checks, found by fuzzing), and 257 or −255 narrowed to ±1 and were read as such.
    #[test]
    fn a_direction_other_than_plus_or_minus_one_is_refused() {
        let frame = one_strand();
        for d in [i8::MIN as i32, 0, 2, 257, -255, i32::MIN] {
            let err = decode(&with_direction(&frame, d)).unwrap_err();
            assert!(
                err.contains(&format!("strand 0 turns {d}, not +1 or -1")),
                "{d}: {err}"
            );
        }
    }
}
