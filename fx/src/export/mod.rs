//! Writing baked rings: USD (`.usda` BasisCurves per frame, and one stage over the frame range
//! that plays them as an animation with the camera and openings), a binary PLY point cloud of the boundary, and a
//! compact native cache that the renderer loads. Every file is written to a temporary name beside
//! its destination and renamed into place, so a failed or interrupted job leaves no partial file.

pub mod atomic;
pub mod cache;
pub mod ply;
pub mod ply_table;
pub mod usd_stage;
pub mod usda;

use crate::error::FxError;
use crate::ring::RingFrame;
use std::path::{Path, PathBuf};

/// The formats `rift fx` can write.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Format {
    Usd,
    Ply,
    Cache,
}

impl Format {
    /// Every format.
    pub const ALL: [Format; 3] = [Format::Usd, Format::Ply, Format::Cache];

    /// Parses a comma-separated list such as `usd,ply,cache`.
    pub fn parse_list(text: &str) -> Result<Vec<Format>, String> {
        let mut out = Vec::new();
        for word in text.split(',').map(str::trim).filter(|w| !w.is_empty()) {
            let f = match word {
                "usd" | "usda" => Format::Usd,
                "ply" => Format::Ply,
                "cache" => Format::Cache,
                other => {
                    return Err(format!(
                        "unknown format {other:?}: expected usd, ply or cache"
                    ));
                }
            };
            if !out.contains(&f) {
                out.push(f);
            }
        }
        if out.is_empty() {
            return Err("expected at least one of usd, ply, cache".into());
        }
        Ok(out)
    }
}

/// Output file names for a shot called `shot`.
pub fn usda_path(dir: &Path, shot: &str, frame: i64) -> PathBuf {
    dir.join(format!("{shot}.{frame:04}.usda"))
}

/// The shot's stage over a frame range, beside its per-frame files.
pub fn stage_path(dir: &Path, shot: &str) -> PathBuf {
    dir.join(format!("{shot}.usda"))
}

/// Writes the stage of `frames` of `shot` into `dir`, where the frames' `.usda` files are (or
/// will be); returns its path.
pub fn write_stage(
    dir: &Path,
    shot: &crate::Shot,
    frames: crate::FrameRange,
    meshes: &[usd_stage::StageMesh],
) -> Result<PathBuf, FxError> {
    let path = stage_path(dir, &shot.name);
    let frame_file = |f: i64| {
        let file = usda_path(Path::new("."), &shot.name, f);
        file.to_string_lossy().into_owned()
    };
    let sets = set_layers(shot, dir);
    atomic::write(&path, |w| {
        usd_stage::write(w, shot, frames, (meshes, &sets), frame_file)
    })?;
    Ok(path)
}

/// The shot's `[[usd]]` layers as the stage in `dir` finds them (relative paths where both are
/// under one root, else absolute), with their time offsets in frames. A section the renderer
/// would refuse is left out here; rendering says why.
fn set_layers(shot: &crate::Shot, dir: &Path) -> Vec<(String, f64)> {
    let base = shot.source.parent().unwrap_or(Path::new("."));
    let absolute = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_owned());
    let stage_dir = absolute(dir);
    shot.render
        .usd
        .iter()
        .filter_map(|table| {
            let file = table.get("file")?.as_str()?;
            let offset = table.get("time_offset").map_or(Some(0.0), |v| {
                v.as_float().or_else(|| v.as_integer().map(|i| i as f64))
            })?;
            let layer = absolute(&base.join(file));
            let shown = relative(&layer, &stage_dir).unwrap_or(layer);
            let text = shown.to_string_lossy().replace('\\', "/");
            // An asset path cannot hold `@`; such a layer is left out of the stage.
            (!text.contains('@')).then_some((text, offset))
        })
        .collect()
}

/// `path` relative to the folder `from` (both absolute), through `..` where needed.
fn relative(path: &Path, from: &Path) -> Option<PathBuf> {
    let (p, f): (Vec<_>, Vec<_>) = (path.components().collect(), from.components().collect());
    let common = p.iter().zip(&f).take_while(|(a, b)| a == b).count();
    if common == 0 {
        return None;
    }
    let mut out: PathBuf = f[common..].iter().map(|_| "..").collect();
    out.extend(&p[common..]);
    Some(out)
}

/// One PLY per opening and frame.
pub fn ply_path(dir: &Path, shot: &str, opening: &str, frame: i64) -> PathBuf {
    dir.join(format!("{shot}.{opening}.{frame:04}.ply"))
}

/// One cache per frame holding every opening.
pub fn cache_path(dir: &Path, shot: &str, frame: i64) -> PathBuf {
    dir.join(format!("{shot}.{frame:04}.ringcache"))
}

/// Writes `frame` in the given formats; returns the paths written.
pub fn write_frame(
    dir: &Path,
    shot: &str,
    frame: &RingFrame,
    formats: &[Format],
) -> Result<Vec<PathBuf>, FxError> {
    let mut written = Vec::new();
    for format in formats {
        match format {
            Format::Usd => {
                let path = usda_path(dir, shot, frame.frame);
                atomic::write(&path, |w| usda::write(w, shot, frame))?;
                written.push(path);
            }
            Format::Ply => {
                for ring in &frame.rings {
                    let path = ply_path(dir, shot, &ring.opening, frame.frame);
                    atomic::write(&path, |w| ply::write(w, frame, ring))?;
                    written.push(path);
                }
            }
            Format::Cache => {
                let path = cache_path(dir, shot, frame.frame);
                atomic::write(&path, |w| cache::write(w, frame))?;
                written.push(path);
            }
        }
    }
    Ok(written)
}
