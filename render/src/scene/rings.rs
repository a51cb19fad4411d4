//! Where a render's rings come from: the native ring caches written by `rift fx` (`[render]
//! rings` or `--rings`, with `#` frame tokens), its PLY point clouds (a pattern ending in `.ply`,
//! with `%o` where the opening's name goes, one file per opening), or generated in memory from
//! the shot's ring looks when no file is named. Either way every opening with a ring look gets
//! exactly one ring, at the frame being rendered.

use super::moves_during;
use super::portals::StrandLook;
use crate::error::{RenderError, key_error};
use crate::geometry::{self, Strands};
use rift_fx::rig::Rig;
use rift_fx::ring::{RingFrame, RingGenerator};
use rift_fx::{FrameRange, Shot};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Where to read a frame's rings from.
#[derive(Clone, Debug)]
pub enum RingSource {
    /// Bake them from the shot.
    Generate,
    /// A cache or point-cloud path pattern (`#`s become the frame number, `%o` the opening's
    /// name), and where it was named: the shot key `render.rings`, or `None` for the command
    /// line.
    Cache {
        pattern: PathBuf,
        key: Option<String>,
    },
}

/// Replaces the run of `#` in `pattern` with `frame`, zero-padded to the run's length.
pub fn frame_path(pattern: &str, frame: i64) -> String {
    match pattern.find('#') {
        None => pattern.to_owned(),
        Some(start) => {
            let len = pattern[start..].chars().take_while(|&c| c == '#').count();
            format!(
                "{}{:0len$}{}",
                &pattern[..start],
                frame,
                &pattern[start + len..]
            )
        }
    }
}

/// The rings of `shot` at `frame`: those of a named cache (which must hold one for every
/// opening with a ring look, and none for an unknown opening) or of named point clouds (one per
/// opening with a ring look), else those generated from the ring looks (`None` when no opening
/// has one).
pub fn load(
    shot: &Shot,
    frame: i64,
    source: &RingSource,
) -> Result<Option<RingFrame>, RenderError> {
    let wanted: Vec<usize> = (0..shot.rig.openings.len())
        .filter(|&i| shot.rings.get(i).is_some_and(|r| r.is_some()))
        .collect();
    let (pattern, key) = match source {
        RingSource::Generate if wanted.is_empty() => return Ok(None),
        RingSource::Generate => {
            let generator = RingGenerator::new(
                shot,
                FrameRange {
                    first: frame,
                    last: frame,
                },
            );
            return Ok(Some(generator.checked_frame(frame)?));
        }
        RingSource::Cache { pattern, key } => (pattern, key),
    };
    let pattern = frame_path(&pattern.to_string_lossy(), frame);
    let bad = |path: &Path, message: String| -> RenderError {
        match key {
            Some(k) => key_error(
                &shot.source,
                k.clone(),
                format!("{}: {message}", path.display()),
            ),
            None => RenderError::Settings(format!("--rings {}: {message}", path.display())),
        }
    };
    let names = wanted.iter().map(|&i| shot.rig.openings[i].name.as_str());
    if pattern.ends_with(".ply") {
        return point_clouds(&pattern, names, frame, &bad);
    }
    let path = PathBuf::from(&pattern);
    let rings = rift_fx::export::cache::read(&path)?;
    if rings.frame != frame {
        return Err(bad(
            &path,
            format!("holds frame {}, not frame {frame}", rings.frame),
        ));
    }
    for ring in &rings.rings {
        if shot.rig.find(&ring.opening).is_none() {
            return Err(bad(
                &path,
                format!(
                    "has a ring for {:?}, which is not an opening of this shot",
                    ring.opening
                ),
            ));
        }
    }
    for name in names {
        if !rings.rings.iter().any(|r| r.opening == name) {
            return Err(bad(&path, format!("has no ring for opening {name:?}")));
        }
    }
    Ok(Some(rings))
}

/// The rings of openings `names` at `frame` from one point cloud each: `pattern` with `%o`
/// replaced by the opening's name (`None` without openings). The files must agree on the
/// frame's timing.
fn point_clouds<'a>(
    pattern: &str,
    names: impl Iterator<Item = &'a str>,
    frame: i64,
    bad: &impl Fn(&Path, String) -> RenderError,
) -> Result<Option<RingFrame>, RenderError> {
    if !pattern.contains("%o") {
        return Err(bad(
            Path::new(pattern),
            "a PLY ring pattern names one file per opening: put %o where the opening's name goes"
                .into(),
        ));
    }
    let mut all: Option<RingFrame> = None;
    for name in names {
        let path = PathBuf::from(pattern.replace("%o", name));
        let mut read = rift_fx::export::ply::read(&path)?;
        let ring = read.rings.pop().expect("a point cloud holds one ring");
        if ring.opening != name {
            return Err(bad(
                &path,
                format!("holds the ring of {:?}, not of {name:?}", ring.opening),
            ));
        }
        if read.frame != frame {
            return Err(bad(
                &path,
                format!("holds frame {}, not frame {frame}", read.frame),
            ));
        }
        match &mut all {
            None => {
                all = Some(RingFrame {
                    rings: vec![ring],
                    ..read
                })
            }
            Some(first) if (first.fps, first.shutter) == (read.fps, read.shutter) => {
                first.rings.push(ring)
            }
            Some(first) => {
                return Err(bad(
                    &path,
                    format!(
                        "is at {} fps with shutter {:?} s, where the first ring's file is at {} \
                         fps with shutter {:?} s",
                        read.fps, read.shutter, first.fps, first.shutter
                    ),
                ));
            }
        }
    }
    Ok(all)
}

/// The cache pattern named by `[render] rings`, relative to the shot file.
pub fn shot_source(shot: &Shot, rings: Option<&str>) -> RingSource {
    match rings {
        Some(p) => RingSource::Cache {
            pattern: shot.source.parent().unwrap_or(Path::new(".")).join(p),
            key: Some("render.rings".into()),
        },
        None => RingSource::Generate,
    }
}

/// The frame's rings as render geometry, each in its opening's frame (followed over time when
/// the opening moves within `times`), with each ring's look (visibility flags, light group).
pub(super) fn strands(
    shot: &Shot,
    rings: Option<&RingFrame>,
    looks: &[StrandLook],
    times: [f64; 2],
    rig: &Arc<Rig>,
) -> (Strands, Vec<StrandLook>) {
    let mut strands = Strands::default();
    let mut ring_looks = Vec::new();
    for curves in rings.iter().flat_map(|f| &f.rings) {
        let opening = shot
            .rig
            .find(&curves.opening)
            .expect("rings::load checks every ring names an opening");
        let frame = if moves_during(&shot.rig.openings[opening].here, times) {
            let rig = rig.clone();
            geometry::RingFrame::Moving(Box::new(move |t| rig.here_at(opening, t)))
        } else {
            let to_world = shot.rig.here_at(opening, times[0]);
            geometry::RingFrame::fixed(to_world)
        };
        let look = looks[opening];
        strands.add_ring(
            curves,
            frame,
            rings.map_or(0.0, |f| f.time),
            times,
            look.intensity,
        );
        ring_looks.push(look);
    }
    (strands, ring_looks)
}
