//! The ring boundary as a binary little-endian PLY point cloud, one file per opening and frame.
//!
//! Points are in the opening's local frame (the opening lies in XY, front along +Z), which is what
//! the renderer's teleport mask works in; the here frame is given in a comment for consumers that
//! want world space. Properties, all `float` but `strand` (`int`):
//!
//! `x y z` position at the frame, `vx vy vz` velocity (per second), `ax ay az` acceleration
//! (per second²), `time` (seconds), `angle` (polar angle in the opening plane, radians in
//! [0, 2π)), `radius` (distance from the opening's axis), `strand` (index within the ring),
//! `r g b` (linear Rec.709), `intensity`, `width`.
//!
//! [`read`] takes such a file back into a one-ring [`RingFrame`], so the renderer can take its
//! rings (and teleport mask) from point clouds as well as from the native cache. Each strand's
//! points must be contiguous, in strand order; what the file does not record is rebuilt: the
//! way each strand turns (from its points' velocities) and the here frame over the shutter (the
//! frame's own, at both ends).

use super::ply_table::{self, Element};
use crate::error::FxError;
use crate::rig::Similarity;
use crate::ring::{RingCurves, RingFrame};
use glam::{DAffine3, DMat4, Vec3};
use std::f32::consts::TAU;
use std::io::{self, Write};
use std::path::Path;

/// Property names in file order (every one `float` except `strand`).
pub const PROPERTIES: [&str; 18] = [
    "x",
    "y",
    "z",
    "vx",
    "vy",
    "vz",
    "ax",
    "ay",
    "az",
    "time",
    "angle",
    "radius",
    "strand",
    "r",
    "g",
    "b",
    "intensity",
    "width",
];

/// Writes one opening's ring at one frame.
pub fn write(w: &mut dyn Write, frame: &RingFrame, ring: &RingCurves) -> io::Result<()> {
    let m = ring.here.to_mat4().transpose().to_cols_array();
    writeln!(w, "ply")?;
    writeln!(w, "format binary_little_endian 1.0")?;
    writeln!(
        w,
        "comment rift fx ring boundary: opening {} frame {}",
        ring.opening, frame.frame
    )?;
    writeln!(
        w,
        "comment fps {} shutter {} {} (seconds)",
        frame.fps, frame.shutter[0], frame.shutter[1]
    )?;
    write!(
        w,
        "comment space opening-local; here frame (row-major 4x4):"
    )?;
    for v in m {
        write!(w, " {v}")?;
    }
    writeln!(w)?;
    writeln!(w, "element vertex {}", ring.len())?;
    for name in PROPERTIES {
        let ty = if name == "strand" { "int" } else { "float" };
        writeln!(w, "property {ty} {name}")?;
    }
    writeln!(w, "end_header")?;

    let time = frame.time as f32;
    let mut record = Vec::with_capacity(PROPERTIES.len() * 4);
    for (strand, range) in ring.strand_ranges().enumerate() {
        for i in range {
            let p = ring.points[i];
            let angle = p.y.atan2(p.x).rem_euclid(TAU);
            let radius = p.x.hypot(p.y);
            record.clear();
            for v in [p.x, p.y, p.z] {
                record.extend_from_slice(&v.to_le_bytes());
            }
            for v in ring.velocities[i].to_array() {
                record.extend_from_slice(&v.to_le_bytes());
            }
            for v in ring.accelerations[i].to_array() {
                record.extend_from_slice(&v.to_le_bytes());
            }
            for v in [time, angle, radius] {
                record.extend_from_slice(&v.to_le_bytes());
            }
            record.extend_from_slice(&(strand as i32).to_le_bytes());
            for v in ring.colors[i].to_array() {
                record.extend_from_slice(&v.to_le_bytes());
            }
            for v in [ring.intensities[i], ring.widths[i]] {
                record.extend_from_slice(&v.to_le_bytes());
            }
            w.write_all(&record)?;
        }
    }
    Ok(())
}

/// What the first comment line starts with, before the opening's name.
const TITLE: &str = "rift fx ring boundary: opening ";

/// Reads one opening's ring at one frame, as [`write()`] wrote it.
pub fn read(path: &Path) -> Result<RingFrame, FxError> {
    let bytes = crate::io::read(path).map_err(|cause| FxError::Read {
        file: path.to_owned(),
        cause,
    })?;
    decode(&bytes).map_err(|message| FxError::PointCloud {
        file: path.to_owned(),
        message,
    })
}

/// Decodes a ring point cloud.
pub fn decode(bytes: &[u8]) -> Result<RingFrame, String> {
    let table = ply_table::parse(bytes)?;
    let comment = |prefix: &str| {
        table
            .comments
            .iter()
            .find_map(|c| c.strip_prefix(prefix))
            .ok_or_else(|| format!("no `comment {prefix}…` line: not a rift ring point cloud"))
    };
    let (opening, frame) = comment(TITLE)?
        .rsplit_once(" frame ")
        .ok_or("the title comment names no frame")?;
    let frame: i64 = frame
        .trim()
        .parse()
        .map_err(|_| format!("frame {frame:?} is not a whole number"))?;
    let numbers = |text: &str, what: &str, count: usize| -> Result<Vec<f64>, String> {
        let values: Vec<f64> = text
            .split_whitespace()
            .map(str::parse)
            .collect::<Result<_, _>>()
            .map_err(|_| format!("the {what} comment holds something other than numbers"))?;
        if values.len() != count || values.iter().any(|v| !v.is_finite()) {
            return Err(format!("the {what} comment needs {count} finite numbers"));
        }
        Ok(values)
    };
    let timing = comment("fps ")?
        .replace("shutter", " ")
        .replace("(seconds)", " ");
    let [fps, open, close] = numbers(&timing, "fps and shutter", 3)?[..] else {
        unreachable!("three numbers were checked for")
    };
    if fps <= 0.0 || open > close {
        return Err(format!("fps {fps} with shutter [{open}, {close}]"));
    }
    let rows = numbers(
        comment("space opening-local; here frame (row-major 4x4):")?,
        "here frame",
        16,
    )?;
    let matrix = DMat4::from_cols_array(&rows.try_into().expect("16 numbers")).transpose();
    let here = Similarity::from_affine(&DAffine3::from_mat4(matrix))
        .map_err(|e| format!("the here frame is not a similarity: {e}"))?;
    let vertex = table.element("vertex").ok_or("no vertex element")?;
    let mut ring = curves(vertex)?;
    ring.opening = opening.to_owned();
    ring.here = here;
    ring.here_shutter = [here; 2];
    let time = frame as f64 / fps;
    if let Some(stamp) = vertex.scalar("time") {
        // Stored in f32: agreement to its precision.
        let tolerance = 1e-6 * time.abs().max(1.0);
        if let Some(t) = stamp.iter().find(|&&t| (t - time).abs() > tolerance) {
            return Err(format!(
                "a point has time {t} s, but frame {frame} at {fps} fps is at {time} s"
            ));
        }
    }
    let decoded = RingFrame {
        frame,
        time,
        fps,
        shutter: [open, close],
        rings: vec![ring],
    };
    decoded.check()?;
    Ok(decoded)
}

/// The strands of a `vertex` element: contiguous runs of one strand index, counting up from 0.
fn curves(vertex: &Element) -> Result<RingCurves, String> {
    let column = |name: &str| {
        vertex
            .scalar(name)
            .ok_or_else(|| format!("the vertex element has no {name} property"))
    };
    let vec3s = |names: [&str; 3]| -> Result<Vec<Vec3>, String> {
        let [x, y, z] = [column(names[0])?, column(names[1])?, column(names[2])?];
        let v: Vec<Vec3> = (0..vertex.count)
            .map(|i| Vec3::new(x[i] as f32, y[i] as f32, z[i] as f32))
            .collect();
        match v.iter().position(|p| !p.is_finite()) {
            Some(i) => Err(format!("point {i}: {} is not finite", names.join(" "))),
            None => Ok(v),
        }
    };
    let floats = |name: &str| -> Result<Vec<f32>, String> {
        let v: Vec<f32> = column(name)?.iter().map(|&v| v as f32).collect();
        match v.iter().position(|p| !p.is_finite() || *p < 0.0) {
            Some(i) => Err(format!("point {i}: {name} is {}", v[i])),
            None => Ok(v),
        }
    };
    let mut ring = RingCurves {
        points: vec3s(["x", "y", "z"])?,
        velocities: vec3s(["vx", "vy", "vz"])?,
        accelerations: vec3s(["ax", "ay", "az"])?,
        colors: vec3s(["r", "g", "b"])?,
        intensities: floats("intensity")?,
        widths: floats("width")?,
        ..Default::default()
    };
    for (i, &strand) in column("strand")?.iter().enumerate() {
        let next = ring.vertex_counts.len() as f64;
        if strand == next {
            ring.vertex_counts.push(1);
        } else if let Some(count) = ring
            .vertex_counts
            .last_mut()
            .filter(|_| strand == next - 1.0)
        {
            *count += 1;
        } else {
            return Err(format!(
                "point {i} belongs to strand {strand} after strand {}: each strand's points must \
                 be contiguous and strands numbered from 0 in order",
                next - 1.0
            ));
        }
    }
    // The way each strand turns about +Z: the sign of its points' angular momentum.
    ring.directions = ring
        .strand_ranges()
        .map(|range| {
            let spin: f32 = range
                .map(|i| {
                    ring.points[i]
                        .truncate()
                        .perp_dot(ring.velocities[i].truncate())
                })
                .sum();
            if spin < 0.0 { -1 } else { 1 }
        })
        .collect();
    Ok(ring)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rig::Similarity;
    use glam::{DQuat, DVec3};

    /// Two strands of a small ring turning opposite ways, the opening placed off the origin.
    fn frame() -> RingFrame {
        let mut ring = RingCurves {
            opening: "gate west".into(),
            here: Similarity::new(
                DQuat::from_rotation_y(0.7),
                DVec3::new(1.5, -2.0, 30.25),
                1.25,
            ),
            ..Default::default()
        };
        for (strand, direction) in [(0, 1i8), (1, -1)] {
            let n = 5 + strand;
            ring.vertex_counts.push(n as u32);
            ring.directions.push(direction);
            for k in 0..n {
                let a = TAU * k as f32 / n as f32;
                let p = Vec3::new(a.cos(), a.sin(), 0.01 * k as f32) * (1.0 + 0.1 * strand as f32);
                let omega = 3.0 * direction as f32;
                ring.points.push(p);
                ring.velocities.push(Vec3::new(-p.y, p.x, 0.0) * omega);
                ring.accelerations
                    .push(-p.truncate().extend(0.0) * omega * omega);
                ring.widths.push(0.02 + 0.001 * k as f32);
                ring.colors.push(Vec3::new(1.0, 0.5, 0.1 * k as f32));
                ring.intensities.push(4.0 + k as f32);
            }
        }
        ring.here_shutter = [ring.here; 2];
        RingFrame {
            frame: 1001,
            time: 1001.0 / 24.0,
            fps: 24.0,
            shutter: [-0.25 / 24.0, 0.25 / 24.0],
            rings: vec![ring],
        }
    }

    fn written(frame: &RingFrame) -> Vec<u8> {
        let mut bytes = Vec::new();
        write(&mut bytes, frame, &frame.rings[0]).unwrap();
        bytes
    }

    #[test]
    fn reads_back_what_it_writes() {
        let original = frame();
        let back = decode(&written(&original)).unwrap();
        assert_eq!(
            (back.frame, back.fps, back.shutter),
            (1001, 24.0, original.shutter)
        );
        assert_eq!(back.time, original.time);
        let (a, b) = (&original.rings[0], &back.rings[0]);
        assert_eq!(b.opening, a.opening);
        assert_eq!(b.vertex_counts, a.vertex_counts);
        assert_eq!(b.directions, a.directions);
        for (name, x, y) in [
            ("points", &a.points, &b.points),
            ("velocities", &a.velocities, &b.velocities),
            ("accelerations", &a.accelerations, &b.accelerations),
            ("colours", &a.colors, &b.colors),
        ] {
            assert_eq!(x, y, "{name}");
        }
        assert_eq!((&b.widths, &b.intensities), (&a.widths, &a.intensities));
        let here = |s: &Similarity| s.to_mat4().to_cols_array();
        for (x, y) in here(&a.here).iter().zip(here(&b.here)) {
            assert!((x - y).abs() < 1e-12, "here frame {x} against {y}");
        }
        assert_eq!(b.here_shutter, [b.here; 2]);
    }

    #[test]
    fn rejects_what_is_not_a_ring_point_cloud() {
        let good = String::from_utf8_lossy(&written(&frame())).into_owned();
        let header_end = good.find("end_header").unwrap();
        let header = &good[..header_end];
        let body = &written(&frame())[header_end..];
        let with_header = |h: String| [h.as_bytes(), body].concat();
        for (bytes, expect) in [
            (
                with_header(header.replace(TITLE, "some other tool: ")),
                "not a rift ring point cloud",
            ),
            (
                with_header(header.replace("frame 1001", "frame soon")),
                "is not a whole number",
            ),
            (with_header(header.replace("fps 24", "fps -24")), "fps -24"),
            (
                with_header(header.replace("(row-major 4x4): ", "(row-major 4x4): 0 0 0 0 ")),
                "needs 16 finite numbers",
            ),
            (
                with_header(header.replace("property float width", "property float girth")),
                "no width property",
            ),
            (
                with_header(header.replace("frame 1001", "frame 1002")),
                "but frame 1002 at 24 fps",
            ),
        ] {
            let err = decode(&bytes).unwrap_err();
            assert!(err.contains(expect), "{err:?} lacks {expect:?}");
        }
        // Strand 1's last point claims strand 0 again.
        let mut bytes = written(&frame());
        // The strand index of the last point: an i32 after twelve floats of its 18-value record.
        let at = bytes.len() - 4 * PROPERTIES.len() + 4 * 12;
        bytes[at..at + 4].copy_from_slice(&0i32.to_le_bytes());
        let err = decode(&bytes).unwrap_err();
        assert!(
            err.contains("point 10 belongs to strand 0 after strand 1"),
            "{err}"
        );
        // A first point numbered before strand 0.
        let mut bytes = written(&frame());
        let header_end = bytes
            .windows(11)
            .position(|w| w == b"end_header\n")
            .unwrap()
            + 11;
        let at = header_end + 4 * 12;
        bytes[at..at + 4].copy_from_slice(&(-1i32).to_le_bytes());
        let err = decode(&bytes).unwrap_err();
        assert!(err.contains("point 0 belongs to strand -1"), "{err}");
    }
}
