//! The `[environment]` section: a constant radiance or a lat-long EXR map, with its intensity,
//! rotation and light group.

use super::light_groups::LightGroups;
use super::materials::color;
use super::schema::EnvironmentSection;
use super::{Entry, optional, parse};
use crate::error::{RenderError, key_error};
use crate::lights::environment::{Environment, LatLong};
use glam::Vec3;
use rift_fx::Invalid;
use rift_fx::shot::check;
use std::path::Path;

/// The `[environment]` section's light, when the shot has one, and its light group.
/// `entry` is the shot's `[environment]` or one a USD dome light made; `base` is the folder
/// the shot's paths are relative to.
pub(super) fn environment_section(
    entry: Option<&Entry>,
    base: &Path,
    groups: &mut LightGroups,
) -> Result<(Option<Environment>, u8), RenderError> {
    let Some(entry) = entry else {
        return Ok((None, 0));
    };
    let (file, key) = (entry.file.as_path(), entry.key.as_str());
    let section = parse::<EnvironmentSection>(file, key, &entry.table)?;
    let group = groups.index(
        file,
        &format!("{key}.light_group"),
        section.light_group.as_deref(),
    )?;
    Ok((Some(environment((file, key), base, &section)?), group))
}

/// The environment light of `[environment]`: a constant or a lat-long map.
fn environment(
    (file, key): (&Path, &str),
    base: &Path,
    e: &EnvironmentSection,
) -> Result<Environment, RenderError> {
    let invalid = |e: Invalid| RenderError::Shot(e.in_file(file));
    let k = |name: &str| format!("{key}.{name}");
    match (&e.radiance, &e.map) {
        (Some(_), Some(_)) => Err(key_error(
            file,
            k("map"),
            "give either `radiance` or `map`, not both",
        )),
        (None, None) => Err(key_error(
            file,
            key,
            "expected `radiance = [r, g, b]` or `map = \"file.exr\"`",
        )),
        (Some(radiance), None) => {
            if e.intensity.is_some() || e.rotation_degrees.is_some() {
                return Err(key_error(
                    file,
                    key,
                    "`intensity` and `rotation_degrees` apply to a `map` only",
                ));
            }
            Ok(Environment::Constant(
                color(&k("radiance"), Some(*radiance), Vec3::ZERO).map_err(invalid)?,
            ))
        }
        (None, Some(map)) => {
            let intensity = optional(e.intensity, 1.0, |v| {
                check::non_negative(&k("intensity"), v)
            })
            .map_err(invalid)?;
            let degrees = optional(e.rotation_degrees, 0.0, |v| {
                check::finite(&k("rotation_degrees"), v)
            })
            .map_err(invalid)?;
            let path = base.join(map);
            let (w, h, texels) = crate::texture::read_exr_rgb(&path)
                .map_err(|cause| key_error(file, k("map"), format!("{map:?}: {cause}")))?;
            if let Some(bad) = texels
                .iter()
                .position(|c| !c.is_finite() || c.min_element() < 0.0)
            {
                return Err(key_error(
                    file,
                    k("map"),
                    format!(
                        "{map:?}: texel ({}, {}) is negative or not finite",
                        bad % w,
                        bad / w
                    ),
                ));
            }
            Ok(Environment::LatLong(LatLong::new(
                w,
                h,
                texels,
                intensity as f32,
                degrees as f32,
            )))
        }
    }
}
