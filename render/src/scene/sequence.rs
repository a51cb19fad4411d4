//! Mesh sequences: `mesh = "walker.####.obj"` (or `.ply`) names one file per frame, as an
//! animation package writes a character's cache. The run of `#` is the frame number, padded;
//! files whose number has a fraction (`walker.0012.5.ply`) are sub-frame samples. Only the
//! samples around the times rays can reach are read (the shutter, widened by openings' time
//! offsets, at each copy's own time); before the sequence's first sample the mesh holds its
//! first shape and after the last its last, as a cache's time samples do elsewhere.
//!
//! Every sample must have the topology of the first: the same parts with the same triangles;
//! a PLY's velocities (`vx vy vz`, units per second) shape the motion between samples when
//! every sample has them. A frame missing between two that are present is an error, not a
//! longer interpolation.

use super::mesh::{self, MeshPart};
use super::ply;
use crate::error::RenderError;
use crate::geometry::{Deformation, Samples};
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A sequence's samples as the scene uses them: the first sample's parts (names, materials,
/// UVs, the shape stored as the object's own) and the deformation over all of them.
pub struct Sequence {
    pub parts: Vec<MeshPart>,
    pub mesh: Arc<Deformation>,
}

/// Bytes a sample of `triangles` triangles takes with its tree's share: corners (and
/// velocities and packed normals, when given) and about one node's slice per two triangles.
fn sample_bytes(triangles: usize, (velocities, normals): (bool, bool)) -> u64 {
    let corners = size_of::<[Vec3; 3]>() as u64 * if velocities { 2 } else { 1 };
    let normals = if normals { 12 } else { 0 };
    triangles as u64 * (corners + normals + 64 + 8)
}

/// True when a mesh path names a sequence (holds a run of `#`).
pub fn is_sequence(mesh: &str) -> bool {
    mesh.contains('#')
}

/// One file of a sequence: its frame number (with any fraction) and path.
#[derive(Clone, Debug)]
pub(crate) struct Sample {
    pub frame: f64,
    pub path: PathBuf,
}

/// Reads the samples of the sequence `pattern` (a path whose file name holds a run of `#`)
/// that rays at `times` (seconds, at `fps` frames a second) need, within `budget` bytes.
pub fn load(
    pattern: &Path,
    times: [f64; 2],
    fps: f64,
    budget: Option<u64>,
) -> Result<Sequence, RenderError> {
    let bad = |file: &Path, message: String| RenderError::Mesh {
        file: file.to_owned(),
        message,
    };
    let all = list(pattern).map_err(|m| bad(pattern, m))?;
    let needed = needed(&all, times.map(|t| t * fps));
    check_no_gap(pattern, &all, needed).map_err(|m| bad(pattern, m))?;
    let chosen = &all[needed.0..=needed.1];
    let first = super::load_mesh(&chosen[0].path)?;
    let triangles: usize = first.iter().map(|p| p.triangles.len()).sum();
    let given = (has_velocities(&first), has_normals(&first));
    let bytes = sample_bytes(triangles, given) * chosen.len() as u64;
    if let Some(budget) = budget.filter(|&b| bytes > b) {
        return Err(bad(
            pattern,
            format!(
                "{} samples of {triangles} triangles need about {} MiB, more than the {} MiB \
                 available",
                chosen.len(),
                bytes >> 20,
                budget >> 20
            ),
        ));
    }
    let rest = chosen[1..]
        .iter()
        .map(|s| Ok((s, super::load_mesh(&s.path)?)));
    assemble((&chosen[0], first), rest, fps)
}

/// The sequence of the `first` sample's parts and the `rest` (read as they are asked for),
/// each checked against the first's topology; sample times in seconds at `fps`.
pub(crate) fn assemble<'a>(
    (first, first_parts): (&Sample, Vec<MeshPart>),
    rest: impl Iterator<Item = Result<(&'a Sample, Vec<MeshPart>), RenderError>>,
    fps: f64,
) -> Result<Sequence, RenderError> {
    let velocities = has_velocities(&first_parts);
    let normals = has_normals(&first_parts);
    let mut samples = Samples {
        times: Vec::new(),
        corners: Vec::new(),
        velocities: Vec::new(),
        normals: Vec::new(),
    };
    push(&mut samples, first, &first_parts, (velocities, normals));
    for next in rest {
        let (sample, parts) = next?;
        same_topology(first, &first_parts, sample, &parts, (velocities, normals)).map_err(
            |message| RenderError::Mesh {
                file: sample.path.clone(),
                message,
            },
        )?;
        push(&mut samples, sample, &parts, (velocities, normals));
    }
    for t in &mut samples.times {
        *t /= fps;
    }
    Ok(Sequence {
        parts: first_parts,
        mesh: Arc::new(Deformation::new(samples)),
    })
}
/// True when every part of a sample gives velocities.
fn has_velocities(parts: &[MeshPart]) -> bool {
    parts.iter().all(|p| !p.velocities.is_empty())
}

/// True when every part of a sample gives its corners' normals.
fn has_normals(parts: &[MeshPart]) -> bool {
    parts.iter().all(|p| !p.normals.is_empty())
}

/// Appends `sample`'s corners (and velocities and normals, when the sequence has them) in part
/// order: the order the object's triangles take in the scene.
fn push(
    samples: &mut Samples,
    sample: &Sample,
    parts: &[MeshPart],
    (velocities, normals): (bool, bool),
) {
    samples.times.push(sample.frame);
    samples.corners.push(
        parts
            .iter()
            .flat_map(|p| p.triangles.iter().copied())
            .collect(),
    );
    if velocities {
        samples.velocities.push(
            parts
                .iter()
                .flat_map(|p| p.velocities.iter().copied())
                .collect(),
        );
    }
    if normals {
        let each = parts.iter().flat_map(|p| p.normals.iter().copied());
        samples.normals.push(each.collect());
    }
}

/// Refuses a sample whose parts or triangle counts differ from the first's, or whose
/// velocities are missing where the first has them (or the other way round).
fn same_topology(
    first: &Sample,
    first_parts: &[MeshPart],
    sample: &Sample,
    parts: &[MeshPart],
    (velocities, normals): (bool, bool),
) -> Result<(), String> {
    let name = |s: &Sample| {
        s.path
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into_owned())
    };
    let (here, there) = (
        format!("frame {}", sample.frame),
        format!("{} (frame {})", name(first), first.frame),
    );
    if parts.len() != first_parts.len() {
        return Err(format!(
            "{here} has {} parts where {there} has {}: every sample of a sequence must have \
             the same topology",
            parts.len(),
            first_parts.len()
        ));
    }
    for (p, q) in parts.iter().zip(first_parts) {
        if p.triangles.len() != q.triangles.len() {
            return Err(format!(
                "{here}: part {:?} has {} triangles where {there} has {}: every sample of a \
                 sequence must have the same topology",
                p.name,
                p.triangles.len(),
                q.triangles.len()
            ));
        }
        let per_corner = [
            (
                "velocities",
                "velocities (vx vy vz)",
                velocities,
                [&p.velocities, &q.velocities].map(Vec::len),
            ),
            (
                "normals",
                "normals",
                normals,
                [&p.normals, &q.normals].map(Vec::len),
            ),
        ];
        for (what, give, wanted, [here_count, there_count]) in per_corner {
            if (here_count == 0) == wanted {
                return Err(format!(
                    "{here}: part {:?} has {what} for {here_count} of its {} triangles' corners \
                     where {there} has them for {there_count}: give {give} in every sample or in \
                     none",
                    p.name,
                    p.triangles.len(),
                ));
            }
        }
    }
    Ok(())
}

/// Every file of the sequence, by frame. The `#` run must be in the file name; any number of
/// digits (at least one) with an optional fraction fills it.
fn list(pattern: &Path) -> Result<Vec<Sample>, String> {
    let name = pattern
        .file_name()
        .and_then(|n| n.to_str())
        .ok_or("the sequence's file name is not valid UTF-8")?;
    let start = name
        .find('#')
        .ok_or("the run of # (the frame number) must be in the file name")?;
    let run = name[start..].chars().take_while(|&c| c == '#').count();
    let (prefix, suffix) = (&name[..start], &name[start + run..]);
    if suffix.contains('#') {
        return Err("only one run of # (the frame number) may be in the file name".into());
    }
    let folder = match pattern.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let entries = std::fs::read_dir(folder)
        .map_err(|e| format!("cannot list its folder {}: {e}", folder.display()))?;
    let mut all = Vec::new();
    for entry in entries.flatten() {
        let file = entry.file_name();
        let Some(file) = file.to_str() else { continue };
        let Some(middle) = file
            .strip_prefix(prefix)
            .and_then(|rest| rest.strip_suffix(suffix))
        else {
            continue;
        };
        if let Some(frame) = frame_number(middle) {
            all.push(Sample {
                frame,
                path: folder.join(file),
            });
        }
    }
    all.sort_by(|a, b| a.frame.total_cmp(&b.frame));
    if all.is_empty() {
        return Err(format!("no file in {} matches {name}", folder.display()));
    }
    if let Some(w) = all.windows(2).find(|w| w[0].frame == w[1].frame) {
        return Err(format!(
            "{} and {} are both frame {}",
            w[0].path.display(),
            w[1].path.display(),
            w[0].frame
        ));
    }
    Ok(all)
}

/// The frame number a file name's `#` run holds: digits (optionally signed) with an optional
/// fraction; `None` for anything else.
fn frame_number(text: &str) -> Option<f64> {
    let digits = text.strip_prefix('-').unwrap_or(text);
    let (whole, fraction) = digits.split_once('.').unwrap_or((digits, "0"));
    let all_digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    (all_digits(whole) && all_digits(fraction) && whole.len() <= 9)
        .then(|| text.parse().ok())
        .flatten()
}

/// Fractional frames within which two samples count as one time.
const SAME_FRAME: f64 = 1e-6;

/// The first and last index of the samples rays in `frames` need: the last at or before the
/// earliest frame and the first at or after the latest (held at the sequence's ends).
fn needed(all: &[Sample], frames: [f64; 2]) -> (usize, usize) {
    let at_or_before = all
        .iter()
        .rposition(|s| s.frame <= frames[0] + SAME_FRAME)
        .unwrap_or(0);
    let at_or_after = all
        .iter()
        .position(|s| s.frame >= frames[1] - SAME_FRAME)
        .unwrap_or(all.len() - 1);
    (at_or_before, at_or_after.max(at_or_before))
}

/// Refuses a whole frame missing between the samples rays need: its neighbours would be
/// interpolated across two frames where the cache meant one.
fn check_no_gap(pattern: &Path, all: &[Sample], (a, b): (usize, usize)) -> Result<(), String> {
    for w in all[a..=b].windows(2) {
        let next_whole = w[0].frame.floor() + 1.0;
        if next_whole < w[1].frame - SAME_FRAME {
            let name = pattern
                .file_name()
                .map(|n| n.to_string_lossy())
                .unwrap_or_default();
            let missing = super::rings::frame_path(&name, next_whole as i64);
            return Err(format!(
                "frame {next_whole} ({missing}) is missing between {} and {}, which the \
                 shutter spans",
                w[0].path.display(),
                w[1].path.display()
            ));
        }
    }
    Ok(())
}

/// `bytes` cut at each line `end_frame`.
fn split_frames(bytes: &[u8]) -> Vec<&[u8]> {
    const SEPARATOR: &[u8] = b"end_frame\n";
    let mut out = Vec::new();
    let mut rest = bytes;
    while let Some(at) = rest.windows(SEPARATOR.len()).position(|w| w == SEPARATOR) {
        out.push(&rest[..at]);
        rest = &rest[at + SEPARATOR.len()..];
    }
    out.push(rest);
    out
}

/// The fuzz target's reading of a sequence from bytes (see [`crate::untrusted`]).
pub(crate) fn fuzz_frames(bytes: &[u8]) {
    let parse = |frame: &[u8]| match frame.starts_with(b"ply") {
        true => ply::parse(frame),
        false => mesh::parse_obj(frame, |_| None),
    };
    let mut frames = Vec::new();
    for (i, frame) in split_frames(bytes).into_iter().take(4).enumerate() {
        let Ok(parts) = parse(frame) else { return };
        let sample = Sample {
            frame: i as f64,
            path: PathBuf::from(format!("fuzz.{i}")),
        };
        frames.push((sample, parts));
    }
    let mut frames = frames.into_iter();
    let Some((first, parts)) = frames.next() else {
        return;
    };
    let rest: Vec<_> = frames.collect();
    let Ok(sequence) = assemble(
        (&first, parts),
        rest.iter().map(|(s, p)| Ok((s, p.clone()))),
        1.0,
    ) else {
        return;
    };
    let b = sequence.mesh.bounds;
    let (lo, hi) = (Vec3::from(b.min), Vec3::from(b.max));
    for time in [-1.0, 0.0, 0.5, 1.7, 9.0] {
        for k in 0..4 {
            let target = lo.lerp(hi, 0.25 * k as f32 + 0.1);
            let origin = target + Vec3::new(1.0, 2.0, 3.0) * (hi - lo).max_element().max(1.0);
            let ray = (origin, target - origin);
            let _ = sequence
                .mesh
                .intersect(ray, f32::MAX, time, 0, &|_, _| true);
            let _ = sequence.mesh.occluded(ray, 1.0, time, 0, &|_, _| true);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_numbers_are_digits_with_an_optional_fraction() {
        assert_eq!(frame_number("0012"), Some(12.0));
        assert_eq!(frame_number("0012.5"), Some(12.5));
        assert_eq!(frame_number("-3"), Some(-3.0));
        for bad in ["", "12a", "1.2.3", ".5", "1.", "+4", "1e3"] {
            assert_eq!(frame_number(bad), None, "{bad:?}");
        }
    }

    fn samples(frames: &[f64]) -> Vec<Sample> {
        frames
            .iter()
            .map(|&frame| Sample {
                frame,
                path: PathBuf::from(format!("m.{frame}.obj")),
            })
            .collect()
    }

    #[test]
    fn the_samples_around_the_shutter_are_read_and_the_ends_hold() {
        let all = samples(&[1.0, 2.0, 3.0, 3.5, 4.0, 5.0]);
        assert_eq!(needed(&all, [2.0, 2.5]), (1, 2));
        assert_eq!(needed(&all, [3.2, 3.7]), (2, 4));
        assert_eq!(needed(&all, [3.0, 3.0]), (2, 2));
        // Beyond the ends: the nearest end alone.
        assert_eq!(needed(&all, [-4.0, -3.5]), (0, 0));
        assert_eq!(needed(&all, [7.0, 7.5]), (5, 5));
        assert_eq!(needed(&all, [4.5, 7.0]), (4, 5));
    }

    #[test]
    fn a_missing_whole_frame_inside_the_shutter_is_refused() {
        let all = samples(&[1.0, 2.0, 4.0, 5.0]);
        let pattern = Path::new("walk.####.obj");
        assert!(check_no_gap(pattern, &all, needed(&all, [1.0, 2.0])).is_ok());
        let e = check_no_gap(pattern, &all, needed(&all, [2.0, 2.5])).unwrap_err();
        assert!(e.contains("frame 3 (walk.0003.obj) is missing"), "{e}");
    }
}
