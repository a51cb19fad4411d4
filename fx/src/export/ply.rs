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

use crate::ring::{RingCurves, RingFrame};
use std::f32::consts::TAU;
use std::io::{self, Write};

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
