//! The renderer's side of a shot's openings: `[portal.surface]` (mask radius, tint, opacity,
//! ior, distortion), the portal depth limit, and the camera's `[camera.clip]`. Syntax:
//! [`super::schema`].

use super::schema::{ClipSection, PortalSurfaceSection};
use super::{moves_during, parse};
use crate::camera::Clip;
use crate::error::RenderError;
use crate::portal::{Distortion, Mask, OpeningLook, Portals};
use glam::Vec4;
use rift_fx::rig::ThereFrame;
use rift_fx::shot::check;
use rift_fx::{Invalid, Shot};
use std::path::Path;

/// Teleports in a row allowed when the shot does not say.
pub const DEFAULT_MAX_PORTAL_DEPTH: u32 = 8;

/// The openings of `shot` over the shutter `[open, close]` (seconds).
pub fn portals(shot: &Shot, shutter: [f64; 2]) -> Result<Portals, RenderError> {
    let file = &shot.source;
    let invalid = |e: Invalid| RenderError::Shot(e.in_file(file));
    let mut masks = Vec::new();
    let mut looks = Vec::new();
    for (i, surface) in shot.render.portal_surfaces.iter().enumerate() {
        let key = format!("portal[{i}].surface");
        let s: PortalSurfaceSection = match surface {
            Some(t) => parse(file, &key, t)?,
            None => PortalSurfaceSection::default(),
        };
        let ring_radius = shot.rings.get(i).and_then(|r| r.as_ref()).map(|r| r.radius);
        let (mask, look) = surface_look(&key, &s, ring_radius).map_err(invalid)?;
        masks.push(mask);
        looks.push(look);
    }
    let moving = shot.rig.openings.iter().any(|o| {
        moves_during(&o.here, shutter)
            || matches!(&o.there, ThereFrame::Explicit(t) if moves_during(t, shutter))
    });
    Ok(Portals::new(
        shot.rig.clone(),
        masks,
        looks,
        moving,
        shutter[0],
    ))
}

fn surface_look(
    key: &str,
    s: &PortalSurfaceSection,
    ring_radius: Option<f64>,
) -> Result<(Mask, OpeningLook), Invalid> {
    let k = |name: &str| format!("{key}.{name}");
    let radius = match s.radius {
        Some(r) => check::positive(&k("radius"), r)?,
        None => ring_radius.unwrap_or(1.0),
    };
    // Unset keys keep the defaults of [`OpeningLook`].
    let mut look = OpeningLook::default();
    if let Some(c) = s.tint {
        look.tint = check::color(&k("tint"), c)?.as_vec3();
    }
    if let Some(v) = s.opacity {
        look.opacity = check::within(&k("opacity"), v, 0.0, 1.0, false)? as f32;
    }
    if let Some(v) = s.ior {
        look.ior = check::within(&k("ior"), v, 1e-3, 1e3, false)?;
    }
    if let Some(d) = &s.distortion {
        let dk = |name: &str| format!("{key}.distortion.{name}");
        look.distortion = Some(Distortion::new(
            check::non_negative(&dk("amplitude"), d.amplitude)?,
            match d.frequency {
                Some(f) => check::positive(&dk("frequency"), f)?,
                None => 3.0,
            },
            match d.evolution {
                Some(e) => check::non_negative(&dk("evolution"), e)?,
                None => 0.5,
            },
            match d.seed {
                Some(v) => check::integer(&dk("seed"), v, 0, u32::MAX as i64, "an integer ≥ 0")?,
                None => 0,
            },
        ));
    }
    Ok((Mask::Disk { radius }, look))
}

/// `[camera.clip]`, or no clipping.
pub fn clip(file: &Path, table: Option<&toml::Table>) -> Result<Clip, RenderError> {
    let invalid = |e: Invalid| RenderError::Shot(e.in_file(file));
    let Some(table) = table else {
        return Ok(Clip::default());
    };
    let c: ClipSection = parse(file, "camera.clip", table)?;
    let near = match c.near {
        Some(v) => check::non_negative("camera.clip.near", v).map_err(invalid)? as f32,
        None => 0.0,
    };
    let far = match c.far {
        Some(v) => check::positive("camera.clip.far", v).map_err(invalid)? as f32,
        None => f32::INFINITY,
    };
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
