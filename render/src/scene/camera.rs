//! The renderer's camera sections: `[camera.clip]` and `[camera.stereo]`. Syntax:
//! [`super::schema`].

use super::schema::{ClipSection, StereoSection};
use super::{optional, parse};
use crate::camera::{Clip, Stereo};
use crate::error::RenderError;
use glam::Vec4;
use rift_fx::Invalid;
use rift_fx::shot::check;
use std::path::Path;

/// `[camera.stereo]`, if any.
pub fn stereo(file: &Path, table: Option<&toml::Table>) -> Result<Option<Stereo>, RenderError> {
    let invalid = |e: Invalid| RenderError::Shot(e.in_file(file));
    let Some(table) = table else {
        return Ok(None);
    };
    let s: StereoSection = parse(file, "camera.stereo", table)?;
    Ok(Some(Stereo {
        interaxial: check::positive("camera.stereo.interaxial", s.interaxial).map_err(invalid)?
            as f32,
        convergence: check::positive("camera.stereo.convergence", s.convergence).map_err(invalid)?
            as f32,
    }))
}

/// `[camera.clip]`, or no clipping.
pub fn clip(file: &Path, table: Option<&toml::Table>) -> Result<Clip, RenderError> {
    let invalid = |e: Invalid| RenderError::Shot(e.in_file(file));
    let Some(table) = table else {
        return Ok(Clip::default());
    };
    let c: ClipSection = parse(file, "camera.clip", table)?;
    let near = optional(c.near, 0.0, |v| check::non_negative("camera.clip.near", v))
        .map_err(invalid)? as f32;
    let far = optional(c.far, f64::INFINITY, |v| {
        check::positive("camera.clip.far", v)
    })
    .map_err(invalid)? as f32;
    if far <= near {
        return Err(invalid(Invalid::new(
            "camera.clip.far",
            "the far plane must lie beyond the near plane",
        )));
    }
    let planes = clip_planes(file, "camera.clip.planes", c.planes.as_deref())?;
    let world_planes = clip_planes(file, "camera.clip.world_planes", c.world_planes.as_deref())?;
    Ok(Clip {
        near,
        far,
        planes,
        world_planes,
    })
}

/// Planes [a, b, c, d] with their normal made unit length.
fn clip_planes(
    file: &Path,
    key: &str,
    planes: Option<&[[f64; 4]]>,
) -> Result<Vec<Vec4>, RenderError> {
    let invalid = |e: Invalid| RenderError::Shot(e.in_file(file));
    let mut out = Vec::new();
    for (i, p) in planes.unwrap_or_default().iter().enumerate() {
        let key = format!("{key}[{i}]");
        if p.iter().any(|v| !v.is_finite()) {
            return Err(invalid(Invalid::new(key, "expected four finite numbers")));
        }
        let normal = glam::DVec3::new(p[0], p[1], p[2]);
        let length = normal.length();
        if length < 1e-12 {
            return Err(invalid(Invalid::new(
                key,
                "the plane's normal [a, b, c] is zero",
            )));
        }
        out.push(Vec4::new(p[0] as f32, p[1] as f32, p[2] as f32, p[3] as f32) / length as f32);
    }
    Ok(out)
}
