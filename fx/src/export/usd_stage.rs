//! One USD stage for a shot's frame range, `<shot>.usda`, beside the per-frame files: the
//! camera as a `Camera` and every opening's here frame as an `Xform`, both sampled at every frame
//! and at its shutter open and close (so the whole rig travels to Blender, usdview, Maya or
//! Houdini), each ring's `BasisCurves` taken frame by frame from the per-frame files as
//! value clips, and each deforming object (a character and its copies) as a `Mesh` whose
//! points (and normals, where it has them) are sampled at the same times. The stage stays small however long the shot, the per-frame files stay the only
//! copy of the curves, and a stage opens as one animation.
//!
//! Clips carry time samples only, so the stage declares what they cannot: the curves' `type` and
//! `wrap`, and each primvar with its interpolation.

use super::usda::{fmt_time, matrix, write_header_over};
use crate::FrameRange;
use crate::rig::{Projection, Similarity};
use crate::shot::Shot;
use std::io::{self, Write};

/// Vertical film size the camera's focal length is given against, in tenths of a scene unit
/// (USD's convention; 0.24 = 24 mm with metres).
const VERTICAL_APERTURE: f64 = 0.24;

/// A deforming object in world space, sampled at the stage's [`sample_frames`]: triangles of
/// three consecutive points.
pub struct StageMesh {
    pub name: String,
    /// Per sample, three corners per triangle.
    pub points: Vec<Vec<[f32; 3]>>,
    /// Per sample, each corner's unit shading normal (empty where the mesh gives none).
    pub normals: Vec<Vec<[f32; 3]>>,
}

/// The (fractional) frames the stage samples what moves at: each frame and its shutter's open
/// and close.
pub fn sample_frames(shot: &Shot, frames: FrameRange) -> Vec<f64> {
    let mut codes: Vec<f64> = frames
        .iter()
        .flat_map(|f| [shot.shutter[0], 0.0, shot.shutter[1]].map(|s| f as f64 + s))
        .collect();
    codes.sort_by(f64::total_cmp);
    codes.dedup();
    codes
}

/// Writes the stage for `frames` of `shot` with its deforming `meshes`; `frame_file(f)` is the
/// per-frame file of frame `f` (a path relative to the stage). The shot's `[[usd]]` layers,
/// `sets` (asset paths as the stage finds them, and their time offsets in frames), lie beneath
/// it as sublayers: one stage holds set, characters, camera and rings.
pub fn write(
    w: &mut dyn Write,
    shot: &Shot,
    frames: FrameRange,
    (meshes, sets): (&[StageMesh], &[(String, f64)]),
    frame_file: impl Fn(i64) -> String,
) -> io::Result<()> {
    let name = &shot.name;
    let doc = format!(
        "rift fx: shot {name}, frames {}-{}: camera, openings and rings",
        frames.first, frames.last
    );
    let range = [frames.first, frames.last];
    write_header_over(w, name, &doc, (range, shot.fps), sets)?;
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
    for mesh in meshes {
        writeln!(w)?;
        write_mesh(w, &sample_frames(shot, frames), mesh)?;
    }
    writeln!(w, "}}")
}

/// A deforming object's normals, where it has them: `primvars:normals`, one per triangle
/// corner (face-varying, in the order of the faces' indices), sampled with the points.
fn write_normals(w: &mut dyn Write, codes: &[f64], normals: &[Vec<[f32; 3]>]) -> io::Result<()> {
    if normals.is_empty() {
        return Ok(());
    }
    writeln!(w, "        normal3f[] primvars:normals (")?;
    writeln!(w, "            interpolation = \"faceVarying\"")?;
    writeln!(w, "        )")?;
    writeln!(w, "        normal3f[] primvars:normals.timeSamples = {{")?;
    for (code, corners) in codes.iter().zip(normals) {
        let list: Vec<String> = (corners.iter())
            .map(|n| format!("({}, {}, {})", n[0], n[1], n[2]))
            .collect();
        writeln!(w, "            {}: [{}],", fmt_time(*code), list.join(", "))?;
    }
    writeln!(w, "        }}")
}

/// A deforming object's `Mesh`: its triangles' topology once, its points at each sample.
fn write_mesh(w: &mut dyn Write, codes: &[f64], mesh: &StageMesh) -> io::Result<()> {
    let (indices, first_corner) = shared_corners(&mesh.points);
    writeln!(w, "    def Mesh \"{}\"", prim_name(&mesh.name))?;
    writeln!(w, "    {{")?;
    let counts = vec!["3"; indices.len() / 3].join(", ");
    writeln!(w, "        int[] faceVertexCounts = [{counts}]")?;
    let list: Vec<String> = indices.iter().map(|i| i.to_string()).collect();
    writeln!(w, "        int[] faceVertexIndices = [{}]", list.join(", "))?;
    writeln!(w, "        point3f[] points.timeSamples = {{")?;
    for (code, points) in codes.iter().zip(&mesh.points) {
        let list: Vec<String> = first_corner
            .iter()
            .map(|&c| points[c])
            .map(|p| format!("({}, {}, {})", p[0], p[1], p[2]))
            .collect();
        writeln!(w, "            {}: [{}],", fmt_time(*code), list.join(", "))?;
    }
    writeln!(w, "        }}")?;
    write_normals(w, codes, &mesh.normals)?;
    writeln!(w, "        float3[] extent.timeSamples = {{")?;
    for (code, points) in codes.iter().zip(&mesh.points) {
        let (lo, hi) = points.iter().fold(
            ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]),
            |(lo, hi), p| {
                (
                    std::array::from_fn(|a| lo[a].min(p[a])),
                    std::array::from_fn(|a| hi[a].max(p[a])),
                )
            },
        );
        let (lo, hi) = (lo.map(f64::from), hi.map(f64::from));
        writeln!(
            w,
            "            {}: [({}, {}, {}), ({}, {}, {})],",
            fmt_time(*code),
            lo[0],
            lo[1],
            lo[2],
            hi[0],
            hi[1],
            hi[2]
        )?;
    }
    writeln!(w, "        }}")?;
    writeln!(w, "        uniform token subdivisionScheme = \"none\"")?;
    writeln!(w, "    }}")
}

/// Corners that are one point at every sample, as one vertex: each corner's vertex index, and
/// each vertex's first corner. Corners that only meet at some samples stay apart.
fn shared_corners(samples: &[Vec<[f32; 3]>]) -> (Vec<usize>, Vec<usize>) {
    let corners = samples.first().map_or(0, Vec::len);
    let mut vertex_of = std::collections::HashMap::new();
    let mut first_corner = Vec::new();
    let indices = (0..corners)
        .map(|c| {
            let key: Vec<u32> = samples
                .iter()
                .flat_map(|s| s[c].map(f32::to_bits))
                .collect();
            *vertex_of.entry(key).or_insert_with(|| {
                first_corner.push(c);
                first_corner.len() - 1
            })
        })
        .collect();
    (indices, first_corner)
}

/// `name` as a USD prim name: letters, digits and `_`, not starting with a digit.
fn prim_name(name: &str) -> String {
    let mut out: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if !out.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_') {
        out.insert(0, '_');
    }
    out
}

/// The shot camera: its transform over the frames and its lens (sampled like the transform
/// where it changes over the shot).
fn write_camera(w: &mut dyn Write, shot: &Shot, frames: FrameRange) -> io::Result<()> {
    let p = &shot.camera.projection;
    writeln!(w, "    def Camera \"camera\"")?;
    writeln!(w, "    {{")?;
    write_transform(w, shot, frames, |t| shot.camera.transform.at(t))?;
    writeln!(w, "        float verticalAperture = {VERTICAL_APERTURE}")?;
    writeln!(
        w,
        "        float horizontalAperture = {}",
        VERTICAL_APERTURE * p.aspect()
    )?;
    writeln!(w, "        float2 clippingRange = (0.01, 100000)")?;
    let codes = match shot.camera.lens.is_empty() {
        true => Vec::new(),
        false => sample_frames(shot, frames),
    };
    let lens = |code: f64| shot.camera.projection_at(shot.time_of(code));
    write_lens_attribute(w, "focalLength", p, &codes, &lens, |p| {
        Some(focal_tenths(p))
    })?;
    // The lens opening, 2·radius across, is focal / N (focal in metres: tenths / 10); a
    // pinhole has no f-stop.
    let f_stop = |p: &Projection| {
        (p.aperture_radius > 0.0).then(|| focal_tenths(p) * 0.1 / (2.0 * p.aperture_radius))
    };
    write_lens_attribute(w, "fStop", p, &codes, &lens, f_stop)?;
    let focus = |p: &Projection| (p.aperture_radius > 0.0).then_some(p.focus_distance);
    write_lens_attribute(w, "focusDistance", p, &codes, &lens, focus)?;
    writeln!(w, "    }}")
}

/// The focal length in USD's tenths of a unit that gives `p`'s field of view on the
/// vertical aperture written.
fn focal_tenths(p: &Projection) -> f64 {
    VERTICAL_APERTURE / 2.0 / p.tan_half_fov_y()
}

/// A float attribute of the lens: one value, or where `codes` are given one at each (a pinhole
/// at every code leaves an f-stop or focus distance out; a pinhole at some is f-stop 0, USD's).
fn write_lens_attribute(
    w: &mut dyn Write,
    name: &str,
    fixed: &Projection,
    codes: &[f64],
    lens: &dyn Fn(f64) -> Projection,
    value: impl Fn(&Projection) -> Option<f64>,
) -> io::Result<()> {
    if codes.is_empty() {
        return match value(fixed) {
            Some(v) => writeln!(w, "        float {name} = {v}"),
            None => Ok(()),
        };
    }
    let values: Vec<Option<f64>> = codes.iter().map(|&c| value(&lens(c))).collect();
    if values.iter().all(Option::is_none) {
        return Ok(());
    }
    writeln!(w, "        float {name}.timeSamples = {{")?;
    for (code, v) in codes.iter().zip(values) {
        writeln!(w, "            {}: {},", fmt_time(*code), v.unwrap_or(0.0))?;
    }
    writeln!(w, "        }}")
}

/// `xformOp:transform` sampled at each frame and at its shutter open and close.
fn write_transform(
    w: &mut dyn Write,
    shot: &Shot,
    frames: FrameRange,
    at: impl Fn(f64) -> Similarity,
) -> io::Result<()> {
    writeln!(w, "        matrix4d xformOp:transform.timeSamples = {{")?;
    for code in sample_frames(shot, frames) {
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
