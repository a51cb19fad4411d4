//! `[[material]]` sections into materials, and which material each part of a mesh takes: its
//! object's, its MTL's (an OBJ's own materials), or the unseen boundary of a medium.

use super::schema::{MaterialKind, MaterialSection, ShadowingKind};
use super::{metals, optional, parse};
use crate::error::{RenderError, key_error};
use crate::material::bsdf::multiscatter::Multiscatter;
use crate::material::bsdf::{Bsdf, Material};
use crate::material::microfacet::{ConductorFresnel, Ggx, Shadowing};
use glam::Vec3;
use rift_fx::Invalid;
use rift_fx::shot::check;
use std::path::Path;

/// The material given to a medium's boundary when its object names none.
pub(super) const BOUNDARY_MATERIAL: &str = "(medium boundary)";

/// The `[[material]]` sections, with names checked unique.
pub(super) fn materials(file: &Path, tables: &[toml::Table]) -> Result<Vec<Material>, RenderError> {
    let mut materials: Vec<Material> = Vec::new();
    for (i, table) in tables.iter().enumerate() {
        let key = format!("material[{i}]");
        let m: MaterialSection = parse(file, &key, table)?;
        if materials.iter().any(|x| x.name == m.name) {
            return Err(key_error(
                file,
                format!("{key}.name"),
                format!("another material is already called {:?}", m.name),
            ));
        }
        materials.push(material(&key, &m).map_err(|e| RenderError::Shot(e.in_file(file)))?);
    }
    Ok(materials)
}

/// The index of the material called `name`, adding it with `make` when there is none yet.
pub(super) fn find_or_add(
    materials: &mut Vec<Material>,
    name: &str,
    make: impl FnOnce() -> Material,
) -> usize {
    find(materials, name).unwrap_or_else(|| {
        materials.push(make());
        materials.len() - 1
    })
}

/// A material from an MTL entry: Kd as diffuse reflectance, Ke as one-sided emission.
pub(super) fn from_mtl(name: &str, diffuse: Option<Vec3>, emission: Option<Vec3>) -> Material {
    Material {
        name: name.to_owned(),
        bsdf: Bsdf::Diffuse {
            reflectance: diffuse.unwrap_or(Vec3::splat(0.8)),
        },
        emission: emission.unwrap_or(Vec3::ZERO),
        two_sided_emission: false,
        one_sided: false,
    }
}

/// The material of a medium's boundary (never shaded; it still needs an index).
pub(super) fn boundary() -> Material {
    Material {
        name: BOUNDARY_MATERIAL.into(),
        bsdf: Bsdf::Diffuse {
            reflectance: Vec3::ZERO,
        },
        emission: Vec3::ZERO,
        two_sided_emission: false,
        one_sided: false,
    }
}

pub(super) fn find(materials: &[Material], name: &str) -> Option<usize> {
    materials.iter().position(|m| m.name == name)
}

pub(super) fn color(key: &str, v: Option<[f64; 3]>, default: Vec3) -> Result<Vec3, Invalid> {
    v.map_or(Ok(default), |c| check::color(key, c).map(|c| c.as_vec3()))
}

/// One `[[material]]` section (at `key`) as a material. Keys every kind checks come first, so a
/// value out of range is named before a key its kind does not take.
fn material(key: &str, m: &MaterialSection) -> Result<Material, Invalid> {
    let reflectance = color(
        &format!("{key}.reflectance"),
        m.reflectance,
        Vec3::splat(0.8),
    )?;
    if reflectance.max_element() > 1.0 {
        return Err(Invalid::new(
            format!("{key}.reflectance"),
            "a reflectance above 1 creates energy",
        ));
    }
    let roughness = optional(m.roughness, 0.0, |r| {
        check::within(&format!("{key}.roughness"), r, 0.0, 1.0, false)
    })? as f32;
    let ggx = Ggx::from_roughness(roughness).with_shadowing(match m.shadowing {
        Some(ShadowingKind::HeightCorrelated) | None => Shadowing::HeightCorrelated,
        Some(ShadowingKind::Separable) => Shadowing::Separable,
    });
    let bsdf = match m.kind {
        MaterialKind::Diffuse => diffuse(key, m, reflectance)?,
        MaterialKind::Conductor => conductor(key, m, ggx)?,
        MaterialKind::Dielectric => dielectric(key, m, ggx)?,
    };
    Ok(Material {
        name: m.name.clone(),
        bsdf,
        emission: color(&format!("{key}.emission"), m.emission, Vec3::ZERO)?,
        two_sided_emission: m.two_sided_emission.unwrap_or(false),
        one_sided: m.one_sided.unwrap_or(false),
    })
}

/// The error for `field`, which a `what` material does not take.
fn unused(key: &str, field: &str, what: &str) -> Invalid {
    Invalid::new(
        format!("{key}.{field}"),
        format!("a {what} material has no {field}"),
    )
}

/// Refuses a conductor's complex index or named metal on a `what` material.
fn no_metal_keys(key: &str, m: &MaterialSection, what: &str) -> Result<(), Invalid> {
    let field = [
        ("metal", m.metal.is_some()),
        ("eta", m.eta.is_some()),
        ("k", m.k.is_some()),
    ]
    .into_iter()
    .find_map(|(field, given)| given.then_some(field));
    field.map_or(Ok(()), |field| Err(unused(key, field, what)))
}

/// A Lambertian BSDF of `reflectance`; rough-surface keys are refused.
fn diffuse(key: &str, m: &MaterialSection, reflectance: Vec3) -> Result<Bsdf, Invalid> {
    no_metal_keys(key, m, "diffuse")?;
    let given = [
        ("roughness", m.roughness.is_some()),
        ("shadowing", m.shadowing.is_some()),
        ("multiscatter", m.multiscatter.is_some()),
        ("ior", m.ior.is_some()),
    ];
    if let Some((field, _)) = given.into_iter().find(|(_, given)| *given) {
        return Err(unused(key, field, "diffuse"));
    }
    Ok(Bsdf::Diffuse { reflectance })
}

/// A GGX conductor, with the energy lost between facets added back when `multiscatter` asks.
fn conductor(key: &str, m: &MaterialSection, ggx: Ggx) -> Result<Bsdf, Invalid> {
    if m.ior.is_some() {
        return Err(unused(key, "ior", "conductor"));
    }
    let fresnel = conductor_fresnel(key, m)?;
    let multiscatter = match m.multiscatter {
        Some(true) => Multiscatter::new(&fresnel, ggx),
        _ => None,
    };
    Ok(Bsdf::Conductor {
        fresnel,
        ggx,
        multiscatter,
    })
}

/// A smooth or rough (GGX) dielectric of index `ior` (default 1.5).
fn dielectric(key: &str, m: &MaterialSection, ggx: Ggx) -> Result<Bsdf, Invalid> {
    no_metal_keys(key, m, "dielectric")?;
    if m.reflectance.is_some() {
        return Err(unused(key, "reflectance", "dielectric"));
    }
    if m.one_sided == Some(true) {
        return Err(Invalid::new(
            format!("{key}.one_sided"),
            "a dielectric lets light through from both sides; it cannot be one-sided",
        ));
    }
    if m.multiscatter.is_some() {
        return Err(Invalid::new(
            format!("{key}.multiscatter"),
            "energy compensation is for conductors only (dielectrics: not yet)",
        ));
    }
    let ior = optional(m.ior, 1.5, |v| {
        check::within(&format!("{key}.ior"), v, 1e-3, 1e3, false)
    })? as f32;
    Ok(Bsdf::Dielectric { ior, ggx })
}

/// A conductor's Fresnel term: Schlick's from `reflectance` (the default, white), or the exact
/// term from `eta` and `k`, or from a named `metal`'s.
fn conductor_fresnel(key: &str, m: &MaterialSection) -> Result<ConductorFresnel, Invalid> {
    let conflict = |a: &str, b: &str| {
        Invalid::new(
            format!("{key}.{b}"),
            format!("give `{a}` or `{b}`, not both: they are two ways to set the same colour"),
        )
    };
    let complex = |field: &str, v: [f64; 3]| -> Result<Vec3, Invalid> {
        let c = glam::DVec3::from_array(v);
        if c.is_finite() && c.min_element() > 0.0 && c.max_element() <= 1e3 {
            Ok(c.as_vec3())
        } else {
            Err(Invalid::new(
                format!("{key}.{field}"),
                format!(
                    "expected three finite numbers > 0 and ≤ 1000 (one per channel), got {v:?}"
                ),
            ))
        }
    };
    match (m.reflectance, m.eta, m.k, &m.metal) {
        (Some(_), Some(_), _, _) => Err(conflict("reflectance", "eta")),
        (Some(_), _, Some(_), _) => Err(conflict("reflectance", "k")),
        (Some(_), _, _, Some(_)) => Err(conflict("reflectance", "metal")),
        (_, Some(_), _, Some(_)) => Err(conflict("metal", "eta")),
        (_, _, Some(_), Some(_)) => Err(conflict("metal", "k")),
        (None, None, None, Some(name)) => {
            let (eta, k) = metals::named(name).ok_or_else(|| {
                let known: Vec<_> = metals::names().collect();
                Invalid::new(
                    format!("{key}.metal"),
                    format!("no metal is called {name:?}; known: {}", known.join(", ")),
                )
            })?;
            Ok(ConductorFresnel::Complex { eta, k })
        }
        (None, Some(eta), Some(k), None) => Ok(ConductorFresnel::Complex {
            eta: complex("eta", eta)?,
            k: complex("k", k)?,
        }),
        (None, Some(_), None, None) => Err(Invalid::new(
            format!("{key}.k"),
            "`eta` needs `k` beside it (the imaginary part of the index, per channel)",
        )),
        (None, None, Some(_), None) => Err(Invalid::new(
            format!("{key}.eta"),
            "`k` needs `eta` beside it (the real part of the index, per channel)",
        )),
        (reflectance, None, None, None) => Ok(ConductorFresnel::Schlick(color(
            &format!("{key}.reflectance"),
            reflectance,
            Vec3::ONE,
        )?)),
    }
}
