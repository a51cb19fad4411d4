//! The `[[medium]]` sections: at most one medium filling the scene, any number inside the
//! closed meshes of objects (see [`crate::media::homogeneous`] and [`crate::media::volumes`]), and media from
//! density grids (read by [`super::grids`]).

use super::parse;
use super::schema::MediumSection;
use crate::error::{RenderError, key_error};
use crate::geometry::Triangle;
use crate::media::grid::{Coefficients, GridMedia};
use crate::media::homogeneous::Medium;
use crate::media::volumes::{Bounded, NO_MEDIUM, Volumes};
use glam::Vec3;
use rift_fx::Invalid;
use rift_fx::shot::check;
use std::collections::HashMap;
use std::path::Path;

/// Coefficients above this (per metre: a mean free path under a nanometre) are refused.
const MAX_COEFFICIENT: f64 = 1e9;

/// The `[[medium]]` sections, checked.
pub(crate) struct MediaSections {
    /// The medium filling the scene, if any.
    pub ambient: Option<Medium>,
    /// Media inside objects: the medium, the object's name and the section's key.
    pub bounded: Vec<(Medium, String, String)>,
    /// Media from density grids, to be read by [`super::grids`].
    pub grids: Vec<GridSection>,
}

/// A `[[medium]]` with a `vdb` file: its coefficients (per metre at density 1, the section's
/// `density` factor applied) and the section's own keys.
pub(crate) struct GridSection {
    pub key: String,
    pub coefficients: Coefficients,
    pub section: MediumSection,
}

impl MediaSections {
    /// The index among [`Self::bounded`] of the medium inside the object called `name`.
    pub fn inside(&self, name: &str) -> Option<usize> {
        self.bounded
            .iter()
            .position(|(_, object, _)| object == name)
    }
}

/// Reads the `[[medium]]` tables of `file`.
pub(crate) fn sections(file: &Path, tables: &[toml::Table]) -> Result<MediaSections, RenderError> {
    let mut out = MediaSections {
        ambient: None,
        bounded: Vec::new(),
        grids: Vec::new(),
    };
    let mut filling: Option<String> = None;
    for (i, table) in tables.iter().enumerate() {
        let key = format!("medium[{i}]");
        let section: MediumSection = parse(file, &key, table)?;
        let medium = checked(&key, &section).map_err(|e| RenderError::Shot(e.in_file(file)))?;
        if section.vdb.is_some() {
            let coefficients = grid_coefficients(&key, &section, &medium)
                .map_err(|e| RenderError::Shot(e.in_file(file)))?;
            out.grids.push(GridSection {
                key,
                coefficients,
                section,
            });
            continue;
        }
        if let Some(field) = grid_only_key(&section) {
            return Err(key_error(
                file,
                format!("{key}.{field}"),
                "only a medium with a `vdb` density grid takes this key",
            ));
        }
        match section.object {
            Some(object) => {
                if out.inside(&object).is_some() {
                    return Err(key_error(
                        file,
                        format!("{key}.object"),
                        format!("another medium is already inside {object:?}"),
                    ));
                }
                out.bounded.push((medium, object, key));
            }
            None => {
                if let Some(first) = &filling {
                    return Err(key_error(
                        file,
                        key,
                        format!("{first} already fills the scene; give this one an `object`"),
                    ));
                }
                filling = Some(key);
                out.ambient = medium.matters().then_some(medium);
            }
        }
    }
    Ok(out)
}

fn checked(key: &str, m: &MediumSection) -> Result<Medium, Invalid> {
    let coefficients = |field: &str, v: Option<[f64; 3]>| -> Result<Vec3, Invalid> {
        let key = format!("{key}.{field}");
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
                format!("{key}.anisotropy"),
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

/// The coefficients of a grid medium, checked: its own keys beside those every medium has.
fn grid_coefficients(
    key: &str,
    m: &MediumSection,
    medium: &Medium,
) -> Result<Coefficients, Invalid> {
    if m.object.is_some() {
        return Err(Invalid::new(
            format!("{key}.object"),
            "a medium from a `vdb` grid is placed by `transform`, not inside an object",
        ));
    }
    let scale = match m.density {
        Some(d) if !(d.is_finite() && (0.0..=MAX_COEFFICIENT).contains(&d)) => {
            return Err(Invalid::new(
                format!("{key}.density"),
                format!("expected a factor from 0 to {MAX_COEFFICIENT:e}, got {d}"),
            ));
        }
        Some(d) => d as f32,
        None => 1.0,
    };
    Ok(Coefficients {
        absorption: (medium.extinction - medium.scattering) * scale,
        scattering: medium.scattering * scale,
        emission: medium.emission * scale,
        anisotropy: medium.anisotropy,
    })
}

/// A key that only grid media take, if a homogeneous medium gives one.
fn grid_only_key(m: &MediumSection) -> Option<&'static str> {
    [
        ("grid", m.grid.is_some()),
        ("density", m.density.is_some()),
        ("transform", m.transform.is_some()),
        ("through", m.through.is_some()),
    ]
    .into_iter()
    .find_map(|(name, given)| given.then_some(name))
}

/// The scene's volumes: `media` with each bounded medium inside its object's triangles, found
/// by `triangle_object` among `triangles` (world space for objects that stand still);
/// `moving[o]` tells whether object `o` moves during the shutter and `names[o]` its name.
pub(crate) fn volumes(
    file: &Path,
    media: MediaSections,
    names: &[&str],
    moving: &[bool],
    triangles: &[Triangle],
    triangle_object: &[u32],
    grids: GridMedia,
) -> Result<Volumes, RenderError> {
    let mut boundary_of_object = vec![NO_MEDIUM; names.len()];
    let mut bounded: Vec<Bounded> = Vec::new();
    for (i, (medium, object, key)) in media.bounded.into_iter().enumerate() {
        let error = |message: String| Err(key_error(file, format!("{key}.object"), message));
        let Some(o) = names.iter().position(|n| *n == object) else {
            return error(format!("no object is called {object:?}"));
        };
        if moving[o] {
            return error(format!(
                "{object:?} moves during the shutter; a medium's object must stand still"
            ));
        }
        let mesh: Vec<Triangle> = triangles
            .iter()
            .zip(triangle_object)
            .filter(|&(_, &owner)| owner as usize == o)
            .map(|(t, _)| *t)
            .collect();
        if let Some(problem) = not_closed(&mesh) {
            return error(format!("the mesh of {object:?} is not closed: {problem}"));
        }
        let b = Bounded::new(medium, mesh);
        if let Some(other) = bounded.iter().find(|other| other.overlaps(&b)) {
            return error(format!(
                "{object:?}'s box overlaps that of the medium {:?}; media inside objects must not overlap",
                other.medium.name
            ));
        }
        boundary_of_object[o] = i as u32;
        bounded.push(b);
    }
    let triangle_boundary = triangle_object
        .iter()
        .map(|&o| boundary_of_object[o as usize])
        .collect();
    Ok(Volumes::new(
        media.ambient,
        bounded,
        triangle_boundary,
        grids,
    ))
}

/// Why `mesh` does not enclose a volume, if it does not: empty, or an edge (between vertices
/// at equal positions) that is not met by exactly two triangles in opposite directions.
fn not_closed(mesh: &[Triangle]) -> Option<String> {
    if mesh.is_empty() {
        return Some("it has no triangles".into());
    }
    let key = |p: Vec3| p.to_array().map(f32::to_bits);
    // Directed edges: each must appear once, and its reverse once.
    let mut directed: HashMap<([u32; 3], [u32; 3]), u32> = HashMap::new();
    for t in mesh {
        for k in 0..3 {
            let edge = (key(t.v[k]), key(t.v[(k + 1) % 3]));
            *directed.entry(edge).or_default() += 1;
        }
    }
    let open = directed
        .iter()
        .filter(|&(&(a, b), &n)| n != 1 || directed.get(&(b, a)) != Some(&1))
        .count();
    (open > 0).then(|| {
        format!("{open} of its edges do not join exactly two consistently wound triangles")
    })
}
