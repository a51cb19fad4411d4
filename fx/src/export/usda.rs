//! USD export as `.usda` text: one file per frame, one Xform per opening carrying its here frame
//! (sampled at shutter open, the frame and shutter close, so consumers blur a moving opening), and
//! under it one BasisCurves prim holding every strand as a linear, periodic (closed) curve.
//!
//! Authored per curve vertex: `points`, `widths`, `velocities`, `accelerations`,
//! `primvars:displayColor` (linear Rec.709) and `primvars:intensity`; per curve:
//! `primvars:direction` (+1 or −1, the way the strand turns). Every value is a time sample at the
//! frame (topology included), so the files serve as value clips of the shot's stage. Stage metadata: `defaultPrim`,
//! `timeCodesPerSecond` and `framesPerSecond` (the shot's fps, so velocities are per second),
//! `upAxis = "Y"`, `metersPerUnit = 1`.

use crate::ring::{RingCurves, RingFrame};
use glam::Vec3;
use std::io::{self, Write};

/// Writes one frame.
pub fn write(w: &mut dyn Write, shot: &str, frame: &RingFrame) -> io::Result<()> {
    let code = frame.frame;
    let doc = format!("rift fx portal rings: shot {shot}, frame {code}");
    write_header(w, shot, &doc, [code, code], frame.fps)?;
    writeln!(w, "def Xform \"{shot}\"")?;
    writeln!(w, "{{")?;
    for (i, ring) in frame.rings.iter().enumerate() {
        if i > 0 {
            writeln!(w)?;
        }
        write_ring(w, frame, ring)?;
    }
    writeln!(w, "}}")
}

/// The layer's metadata: `shot` as the default prim, time codes `range` at `fps`, metres, Y up.
pub(crate) fn write_header(
    w: &mut dyn Write,
    shot: &str,
    doc: &str,
    range: [i64; 2],
    fps: f64,
) -> io::Result<()> {
    write_header_over(w, shot, doc, (range, fps), &[])
}

/// [`write_header`], with `sublayers` (asset paths, and the frames each is offset by) beneath.
pub(crate) fn write_header_over(
    w: &mut dyn Write,
    shot: &str,
    doc: &str,
    (range, fps): ([i64; 2], f64),
    sublayers: &[(String, f64)],
) -> io::Result<()> {
    writeln!(w, "#usda 1.0")?;
    writeln!(w, "(")?;
    writeln!(w, "    defaultPrim = \"{shot}\"")?;
    writeln!(w, "    doc = \"{doc}\"")?;
    if !sublayers.is_empty() {
        writeln!(w, "    subLayers = [")?;
        for (path, offset) in sublayers {
            writeln!(w, "        @{path}@ (offset = {offset})")?;
        }
        writeln!(w, "    ]")?;
    }
    writeln!(w, "    startTimeCode = {}", range[0])?;
    writeln!(w, "    endTimeCode = {}", range[1])?;
    writeln!(w, "    framesPerSecond = {fps}")?;
    writeln!(w, "    timeCodesPerSecond = {fps}")?;
    writeln!(w, "    metersPerUnit = 1")?;
    writeln!(w, "    upAxis = \"Y\"")?;
    writeln!(w, ")")?;
    writeln!(w)
}

fn write_ring(w: &mut dyn Write, frame: &RingFrame, ring: &RingCurves) -> io::Result<()> {
    let code = frame.frame as f64;
    let samples = [
        (code + frame.shutter[0] * frame.fps, ring.here_shutter[0]),
        (code, ring.here),
        (code + frame.shutter[1] * frame.fps, ring.here_shutter[1]),
    ];
    writeln!(w, "    def Xform \"{}\"", ring.opening)?;
    writeln!(w, "    {{")?;
    writeln!(w, "        matrix4d xformOp:transform.timeSamples = {{")?;
    let mut last = f64::NAN;
    for (tc, here) in samples {
        // A closed shutter gives three equal time codes: author each once.
        if tc == last {
            continue;
        }
        last = tc;
        writeln!(w, "            {}: {},", fmt_time(tc), matrix(&here))?;
    }
    writeln!(w, "        }}")?;
    writeln!(
        w,
        "        uniform token[] xformOpOrder = [\"xformOp:transform\"]"
    )?;
    writeln!(w)?;
    writeln!(w, "        def BasisCurves \"ring\"")?;
    writeln!(w, "        {{")?;
    writeln!(w, "            uniform token type = \"linear\"")?;
    writeln!(w, "            uniform token wrap = \"periodic\"")?;
    let tc = fmt_time(code);
    // Topology as time samples too, so a stage taking this file as one value clip of many
    // (`usd_stage`) gets it frame by frame.
    write!(
        w,
        "            int[] curveVertexCounts.timeSamples = {{ {tc}: ["
    )?;
    write_list(w, &ring.vertex_counts, |w, n| write!(w, "{n}"))?;
    writeln!(w, "] }}")?;
    writeln!(w, "            int[] primvars:direction (")?;
    writeln!(w, "                interpolation = \"uniform\"")?;
    writeln!(w, "            )")?;
    write!(
        w,
        "            int[] primvars:direction.timeSamples = {{ {tc}: ["
    )?;
    write_list(w, &ring.directions, |w, d| write!(w, "{d}"))?;
    writeln!(w, "] }}")?;
    let (lo, hi) = ring.extent();
    writeln!(
        w,
        "            float3[] extent.timeSamples = {{ {tc}: [({}, {}, {}), ({}, {}, {})] }}",
        lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
    )?;
    vec3_samples(w, "point3f[] points", &tc, &ring.points)?;
    vec3_samples(w, "vector3f[] velocities", &tc, &ring.velocities)?;
    vec3_samples(w, "vector3f[] accelerations", &tc, &ring.accelerations)?;
    vertex_interpolation(w, "float[] widths")?;
    float_samples(w, "float[] widths", &tc, &ring.widths)?;
    vertex_interpolation(w, "color3f[] primvars:displayColor")?;
    vec3_samples(w, "color3f[] primvars:displayColor", &tc, &ring.colors)?;
    vertex_interpolation(w, "float[] primvars:intensity")?;
    float_samples(w, "float[] primvars:intensity", &tc, &ring.intensities)?;
    writeln!(w, "        }}")?;
    writeln!(w, "    }}")
}

/// Time codes print without a trailing `.0` when whole.
pub(crate) fn fmt_time(tc: f64) -> String {
    if tc.fract() == 0.0 {
        format!("{}", tc as i64)
    } else {
        format!("{tc}")
    }
}

/// A similarity as a USD `matrix4d`: rows are the matrix's columns (USD multiplies row vectors
/// from the left).
pub(crate) fn matrix(m: &crate::rig::Similarity) -> String {
    let m = m.to_mat4();
    let rows: Vec<String> = (0..4)
        .map(|c| {
            let col = m.col(c);
            format!("({}, {}, {}, {})", col.x, col.y, col.z, col.w)
        })
        .collect();
    format!("({})", rows.join(", "))
}

fn vertex_interpolation(w: &mut dyn Write, decl: &str) -> io::Result<()> {
    writeln!(w, "            {decl} (")?;
    writeln!(w, "                interpolation = \"vertex\"")?;
    writeln!(w, "            )")
}

fn vec3_samples(w: &mut dyn Write, decl: &str, tc: &str, values: &[Vec3]) -> io::Result<()> {
    write!(w, "            {decl}.timeSamples = {{ {tc}: [")?;
    write_list(w, values, |w, v| write!(w, "({}, {}, {})", v.x, v.y, v.z))?;
    writeln!(w, "] }}")
}

fn float_samples(w: &mut dyn Write, decl: &str, tc: &str, values: &[f32]) -> io::Result<()> {
    write!(w, "            {decl}.timeSamples = {{ {tc}: [")?;
    write_list(w, values, |w, v| write!(w, "{v}"))?;
    writeln!(w, "] }}")
}

fn write_list<T>(
    w: &mut dyn Write,
    items: &[T],
    mut each: impl FnMut(&mut dyn Write, &T) -> io::Result<()>,
) -> io::Result<()> {
    for (i, item) in items.iter().enumerate() {
        if i > 0 {
            w.write_all(b", ")?;
        }
        each(w, item)?;
    }
    Ok(())
}
