//! One USD stage for a shot's frame range, `<shot>.usda`, beside the per-frame files: the
//! camera as a `Camera` and every opening's here frame as an `Xform`, both sampled at every frame
//! and at its shutter open and close (so the whole rig travels to Blender, usdview, Maya or
//! Houdini), and each ring's `BasisCurves` taken frame by frame from the per-frame files as
//! value clips. The stage stays small however long the shot, the per-frame files stay the only
//! copy of the curves, and a stage opens as one animation.
//!
//! Clips carry time samples only, so the stage declares what they cannot: the curves' `type` and
//! `wrap`, and each primvar with its interpolation.

use super::usda::{fmt_time, matrix, write_header};
use crate::FrameRange;
use crate::rig::Similarity;
use crate::shot::Shot;
use std::io::{self, Write};

/// Vertical film size the camera's focal length is given against, in tenths of a scene unit
/// (USD's convention; 0.24 = 24 mm with metres).
const VERTICAL_APERTURE: f64 = 0.24;

/// Writes the stage for `frames` of `shot`; `frame_file(f)` is the per-frame file of frame `f`
/// (a path relative to the stage).
pub fn write(
    w: &mut dyn Write,
    shot: &Shot,
    frames: FrameRange,
    frame_file: impl Fn(i64) -> String,
) -> io::Result<()> {
    let name = &shot.name;
    let doc = format!(
        "rift fx: shot {name}, frames {}-{}: camera, openings and rings",
        frames.first, frames.last
    );
    write_header(w, name, &doc, [frames.first, frames.last], shot.fps)?;
    writeln!(w, "def Xform \"{name}\"")?;
    writeln!(w, "{{")?;
    write_camera(w, shot, frames)?;
    for (i, opening) in shot.rig.openings.iter().enumerate() {
        writeln!(w)?;
        let has_ring = shot.rings.get(i).is_some_and(Option::is_some);
        let clips = has_ring.then(|| (format!("/{name}/{}", opening.name), &frame_file));
        match clips {
            Some((prim, files)) => {
                writeln!(w, "    def Xform \"{}\" (", opening.name)?;
                write_clips(w, frames, &prim, files)?;
                writeln!(w, "    )")?;
            }
            None => writeln!(w, "    def Xform \"{}\"", opening.name)?,
        }
        writeln!(w, "    {{")?;
        write_transform(w, shot, frames, |t| shot.rig.here_at(i, t))?;
        if has_ring {
            writeln!(w)?;
            write_ring_declaration(w)?;
        }
        writeln!(w, "    }}")?;
    }
    writeln!(w, "}}")
}

/// The shot camera: its transform over the frames and its lens.
fn write_camera(w: &mut dyn Write, shot: &Shot, frames: FrameRange) -> io::Result<()> {
    let p = &shot.camera.projection;
    let focal = VERTICAL_APERTURE / 2.0 / p.tan_half_fov_y();
    writeln!(w, "    def Camera \"camera\"")?;
    writeln!(w, "    {{")?;
    write_transform(w, shot, frames, |t| shot.camera.transform.at(t))?;
    writeln!(w, "        float focalLength = {focal}")?;
    writeln!(w, "        float verticalAperture = {VERTICAL_APERTURE}")?;
    writeln!(
        w,
        "        float horizontalAperture = {}",
        VERTICAL_APERTURE * p.aspect()
    )?;
    writeln!(w, "        float2 clippingRange = (0.01, 100000)")?;
    if p.aperture_radius > 0.0 {
        // The lens opening, 2·radius across, is focal / N (focal in metres: tenths / 10).
        let f_stop = focal * 0.1 / (2.0 * p.aperture_radius);
        writeln!(w, "        float fStop = {f_stop}")?;
        writeln!(w, "        float focusDistance = {}", p.focus_distance)?;
    }
    writeln!(w, "    }}")
}

/// `xformOp:transform` sampled at each frame and at its shutter open and close.
fn write_transform(
    w: &mut dyn Write,
    shot: &Shot,
    frames: FrameRange,
    at: impl Fn(f64) -> Similarity,
) -> io::Result<()> {
    writeln!(w, "        matrix4d xformOp:transform.timeSamples = {{")?;
    let mut codes: Vec<f64> = frames
        .iter()
        .flat_map(|f| [shot.shutter[0], 0.0, shot.shutter[1]].map(|s| f as f64 + s))
        .collect();
    codes.sort_by(f64::total_cmp);
    codes.dedup();
    for code in codes {
        let m = matrix(&at(shot.time_of(code)));
        writeln!(w, "            {}: {m},", fmt_time(code))?;
    }
    writeln!(w, "        }}")?;
    writeln!(
        w,
        "        uniform token[] xformOpOrder = [\"xformOp:transform\"]"
    )
}

/// Value clips: frame f's values come from its own file, between f and the next frame.
fn write_clips(
    w: &mut dyn Write,
    frames: FrameRange,
    prim: &str,
    frame_file: &dyn Fn(i64) -> String,
) -> io::Result<()> {
    let list = |item: &dyn Fn(usize, i64) -> String| {
        frames
            .iter()
            .enumerate()
            .map(|(k, f)| item(k, f))
            .collect::<Vec<_>>()
            .join(", ")
    };
    writeln!(w, "        clips = {{")?;
    writeln!(w, "            dictionary default = {{")?;
    writeln!(
        w,
        "                double2[] active = [{}]",
        list(&|k, f| format!("({f}, {k})"))
    )?;
    writeln!(
        w,
        "                asset[] assetPaths = [{}]",
        list(&|_, f| format!("@{}@", frame_file(f)))
    )?;
    writeln!(w, "                string primPath = \"{prim}\"")?;
    writeln!(
        w,
        "                double2[] times = [{}]",
        list(&|_, f| format!("({f}, {f})"))
    )?;
    writeln!(w, "            }}")?;
    writeln!(w, "        }}")
}

/// The ring's curves as the clips fill them in: what clips cannot carry.
fn write_ring_declaration(w: &mut dyn Write) -> io::Result<()> {
    writeln!(w, "        def BasisCurves \"ring\"")?;
    writeln!(w, "        {{")?;
    writeln!(w, "            uniform token type = \"linear\"")?;
    writeln!(w, "            uniform token wrap = \"periodic\"")?;
    for decl in [
        "int[] curveVertexCounts",
        "float3[] extent",
        "point3f[] points",
        "vector3f[] velocities",
        "vector3f[] accelerations",
    ] {
        writeln!(w, "            {decl}")?;
    }
    for (decl, interpolation) in [
        ("int[] primvars:direction", "uniform"),
        ("float[] widths", "vertex"),
        ("color3f[] primvars:displayColor", "vertex"),
        ("float[] primvars:intensity", "vertex"),
    ] {
        writeln!(w, "            {decl} (")?;
        writeln!(w, "                interpolation = \"{interpolation}\"")?;
        writeln!(w, "            )")?;
    }
    writeln!(w, "        }}")
}
