//! The `[[medium]]` section: a homogeneous medium filling the scene (see [`crate::medium`]).

use super::parse;
use super::schema::MediumSection;
use crate::error::{RenderError, key_error};
use crate::medium::Medium;
use glam::Vec3;
use rift_fx::Invalid;
use rift_fx::shot::check;
use std::path::Path;

/// Coefficients above this (per metre: a mean free path under a nanometre) are refused.
const MAX_COEFFICIENT: f64 = 1e9;

/// The medium the `[[medium]]` tables of `file` describe, if any (at most one: it fills the
/// scene).
pub(crate) fn medium(file: &Path, tables: &[toml::Table]) -> Result<Option<Medium>, RenderError> {
    if tables.len() > 1 {
        return Err(key_error(
            file,
            "medium[1]",
            "only one medium can fill the scene".to_string(),
        ));
    }
    let Some(table) = tables.first() else {
        return Ok(None);
    };
    let section: MediumSection = parse(file, "medium[0]", table)?;
    let medium = checked(&section).map_err(|e| RenderError::Shot(e.in_file(file)))?;
    Ok(medium.matters().then_some(medium))
}

fn checked(m: &MediumSection) -> Result<Medium, Invalid> {
    let coefficients = |field: &str, v: Option<[f64; 3]>| -> Result<Vec3, Invalid> {
        let key = format!("medium[0].{field}");
        let Some(v) = v else {
            return Ok(Vec3::ZERO);
        };
        let c = check::color(&key, v)?;
        if c.max_element() > MAX_COEFFICIENT {
            return Err(Invalid::new(
                key,
                format!("expected at most {MAX_COEFFICIENT:e} per metre, got {v:?}"),
            ));
        }
        Ok(c.as_vec3())
    };
    let absorption = coefficients("absorption", m.absorption)?;
    let scattering = coefficients("scattering", m.scattering)?;
    let emission = coefficients("emission", m.emission)?;
    let anisotropy = match m.anisotropy {
        Some(g) if !(g.is_finite() && g.abs() < 1.0) => {
            return Err(Invalid::new(
                "medium[0].anisotropy",
                format!("expected a number in (-1, 1), got {g}"),
            ));
        }
        Some(g) => g as f32,
        None => 0.0,
    };
    Ok(Medium {
        name: m.name.clone(),
        extinction: absorption + scattering,
        scattering,
        anisotropy,
        emission,
    })
}
