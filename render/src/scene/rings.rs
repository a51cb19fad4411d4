//! Where a render's rings come from: a native ring cache written by `rift fx` (`[render] rings`
//! or `--rings`, with `#` frame tokens), or generated in memory from the shot's ring looks when
//! no cache is named. Either way every opening with a ring look gets exactly one ring, at the
//! frame being rendered.

use crate::error::{RenderError, key_error};
use rift_fx::ring::{RingFrame, RingGenerator};
use rift_fx::{FrameRange, Shot};
use std::path::{Path, PathBuf};

/// Where to read a frame's rings from.
#[derive(Clone, Debug)]
pub enum RingSource {
    /// Bake them from the shot.
    Generate,
    /// A cache path pattern (`#`s become the frame number), and where it was named: the shot
    /// key `render.rings`, or `None` for the command line.
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
/// opening with a ring look, and none for an unknown opening), else those generated from the
/// ring looks (`None` when no opening has one).
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
            return Ok(Some(generator.frame(frame)));
        }
        RingSource::Cache { pattern, key } => (pattern, key),
    };
    let path = PathBuf::from(frame_path(&pattern.to_string_lossy(), frame));
    let rings = rift_fx::export::cache::read(&path)?;
    let bad = |message: String| -> RenderError {
        match key {
            Some(k) => key_error(
                &shot.source,
                k.clone(),
                format!("{}: {message}", path.display()),
            ),
            None => RenderError::Settings(format!("--rings {}: {message}", path.display())),
        }
    };
    if rings.frame != frame {
        return Err(bad(format!(
            "holds frame {}, not frame {frame}",
            rings.frame
        )));
    }
    for ring in &rings.rings {
        if shot.rig.find(&ring.opening).is_none() {
            return Err(bad(format!(
                "has a ring for {:?}, which is not an opening of this shot",
                ring.opening
            )));
        }
    }
    for &i in &wanted {
        let name = &shot.rig.openings[i].name;
        if !rings.rings.iter().any(|r| &r.opening == name) {
            return Err(bad(format!("has no ring for opening {name:?}")));
        }
    }
    Ok(Some(rings))
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
