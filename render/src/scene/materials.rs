//! `[[material]]` sections into materials, and which material each part of a mesh takes: its
//! object's, its MTL's (an OBJ's own materials, read as diffuse or standard ones with their
//! maps), or the unseen boundary of a medium. A material's colours and numbers may be
//! textures, and any material may take a normal map; each file is read once for every
//! material that uses it.

use super::schema::{
    ContactKind, MaterialKind, MaterialSection, ShadowingKind, TextureColorSpace, TextureFilter,
    TextureSection,
};
use super::{Entry, metals, optional, parse};
use crate::error::{RenderError, key_error};
use crate::material::bsdf::Bsdf;
use crate::material::bsdf::albedo::MAX_IOR;
use crate::material::bsdf::multiscatter::Multiscatter;
use crate::material::bsdf::standard::Standard;
use crate::material::microfacet::{ConductorFresnel, Ggx, Shadowing};
use crate::material::surface::Material;
use crate::material::{ColorInput, Filter, Inputs, NormalInput, ScalarInput};
use crate::texture::{ColorSpace, Textures};
use glam::Vec3;
use rift_fx::Invalid;
use rift_fx::shot::check;
use std::path::Path;

/// The material given to a medium's boundary when its object names none.
pub(super) const BOUNDARY_MATERIAL: &str = "(medium boundary)";

/// The keys whose value may be a texture.
const TEXTURED_KEYS: [&str; 10] = [
    "emission",
    "normal_map",
    "opacity",
    "reflectance",
    "roughness",
    "base_color",
    "metallic",
    "specular_color",
    "coat",
    "coat_roughness",
];

/// The keys only the standard material takes.
const STANDARD_KEYS: [&str; 6] = [
    "base_color",
    "metallic",
    "specular_color",
    "coat",
    "coat_roughness",
    "coat_ior",
];

/// Where materials' textures are read from and kept.
pub(super) struct TextureReader<'a> {
    /// The shot file (for messages), whose folder texture paths are relative to.
    pub file: &'a Path,
    pub textures: &'a mut Textures,
    /// Bytes the scene may take (`None`: no limit).
    pub budget: Option<u64>,
}

impl TextureReader<'_> {
    /// The texture of the image at `path` (named `shown` in messages) read in `color_space`,
    /// for the key `key`.
    fn load(
        &mut self,
        key: &str,
        path: &Path,
        shown: &str,
        color_space: ColorSpace,
    ) -> Result<u32, RenderError> {
        self.textures
            .load(path, color_space, self.budget)
            .map_err(|e| key_error(self.file, key, format!("{shown:?}: {e}")))
    }
}

/// The `[[material]]` sections (and those USD layers bring), with names checked unique and
/// their textures read.
pub(super) fn materials(
    entries: &[Entry],
    reader: &mut TextureReader,
) -> Result<Vec<Material>, RenderError> {
    let mut materials: Vec<Material> = Vec::new();
    for Entry { file, key, table } in entries {
        let key = key.clone();
        let (plain, textured) = split_textures(file, &key, table)?;
        let m: MaterialSection = parse(file, &key, &plain)?;
        if materials.iter().any(|x| x.name == m.name) {
            return Err(key_error(
                file,
                format!("{key}.name"),
                format!("another material is already called {:?}", m.name),
            ));
        }
        let mut material = material(&key, &m).map_err(|e| RenderError::Shot(e.in_file(file)))?;
        material.inputs = inputs(&key, &m, &textured, reader)?;
        let opacity = m.opacity.is_some() || textured.iter().any(|(n, _)| n == "opacity");
        if material.emits() && opacity {
            return Err(key_error(
                file,
                format!("{key}.opacity"),
                "an emitting material cannot cut out (light would leave where nothing is)",
            ));
        }
        materials.push(material);
    }
    Ok(materials)
}

/// `table` without its texture inputs, and those inputs by key; a texture on a key that cannot
/// take one is refused.
fn split_textures(
    file: &Path,
    key: &str,
    table: &toml::Table,
) -> Result<(toml::Table, Vec<(String, TextureSection)>), RenderError> {
    let mut plain = table.clone();
    let mut textured = Vec::new();
    for (name, value) in table {
        let Some(inner) = value.as_table() else {
            continue;
        };
        let full = format!("{key}.{name}");
        if !TEXTURED_KEYS.contains(&name.as_str()) {
            if inner.contains_key("texture") {
                return Err(key_error(
                    file,
                    full,
                    format!(
                        "cannot take a texture (textures work on {})",
                        TEXTURED_KEYS.join(", ")
                    ),
                ));
            }
            continue;
        }
        plain.remove(name);
        textured.push((name.clone(), parse(file, &full, inner)?));
    }
    Ok((plain, textured))
}

/// The textured inputs of material section `m` (at `key`): each texture read, checked against
/// what the material's kind takes.
fn inputs(
    key: &str,
    m: &MaterialSection,
    textured: &[(String, TextureSection)],
    reader: &mut TextureReader,
) -> Result<Option<Box<Inputs>>, RenderError> {
    let file = reader.file;
    let mut inputs = Inputs::default();
    for (name, spec) in textured {
        let full = format!("{key}.{name}");
        let refuse = |what: &str| Err(key_error(file, &full, what.to_owned()));
        match (name.as_str(), m.kind) {
            ("reflectance", MaterialKind::Dielectric) => {
                return refuse("a dielectric material has no reflectance");
            }
            ("reflectance", MaterialKind::Conductor)
                if m.eta.is_some() || m.k.is_some() || m.metal.is_some() =>
            {
                return refuse("a texture gives Schlick's colour: give it without eta, k or metal");
            }
            ("roughness", MaterialKind::Diffuse) => {
                return refuse("a diffuse material has no roughness");
            }
            ("reflectance", MaterialKind::Standard) => {
                return refuse("a standard material's colour is its base_color");
            }
            _ => {}
        }
        if STANDARD_KEYS.contains(&name.as_str()) && m.kind != MaterialKind::Standard {
            return refuse(&format!("only a standard material has {name}"));
        }
        let base = file.parent().unwrap_or(Path::new("."));
        let color = |reader: &mut TextureReader| color_input(&full, spec, base, reader);
        let scalar = |reader: &mut TextureReader| scalar_input(&full, spec, base, reader);
        match name.as_str() {
            "normal_map" => inputs.normal = Some(normal_input(&full, spec, base, reader)?),
            "emission" => inputs.emission = Some(color(reader)?),
            "reflectance" | "base_color" => inputs.reflectance = Some(color(reader)?),
            "specular_color" => inputs.specular_color = Some(color(reader)?),
            "roughness" => inputs.roughness = Some(scalar(reader)?),
            "metallic" => inputs.metallic = Some(scalar(reader)?),
            "opacity" => inputs.opacity = Some(scalar(reader)?),
            "coat" => inputs.coat = Some(scalar(reader)?),
            _ => inputs.coat_roughness = Some(scalar(reader)?),
        }
    }
    Ok((inputs != Inputs::default()).then(|| Box::new(inputs)))
}

/// A colour texture input at `key`.
fn color_input(
    key: &str,
    spec: &TextureSection,
    base: &Path,
    reader: &mut TextureReader,
) -> Result<ColorInput, RenderError> {
    let file = reader.file;
    let texture = section_texture(key, spec, base, reader, ColorSpace::Srgb)?;
    let three = |name: &str, v: &Option<toml::Value>, default: f64| -> Result<Vec3, RenderError> {
        let k = format!("{key}.{name}");
        match v {
            None => Ok(Vec3::splat(default as f32)),
            Some(v) => number_or_color(v)
                .ok_or_else(|| key_error(file, &k, "expected a number or [r, g, b]")),
        }
    };
    Ok(ColorInput {
        texture,
        scale: three("scale", &spec.scale, 1.0)?,
        offset: three("offset", &spec.offset, 0.0)?,
        filter: filter(spec.filter),
    })
}

/// A tangent-space normal map at `key`: linear unless `colorspace` says otherwise, its
/// `scale` the strength of its slopes.
fn normal_input(
    key: &str,
    spec: &TextureSection,
    base: &Path,
    reader: &mut TextureReader,
) -> Result<NormalInput, RenderError> {
    let file = reader.file;
    let given = [
        ("offset", spec.offset.is_some()),
        ("channel", spec.channel.is_some()),
        ("filter", spec.filter.is_some()),
    ];
    for (field, given) in given {
        if given {
            return Err(key_error(
                file,
                format!("{key}.{field}"),
                "a normal map takes only texture, scale (its strength) and colorspace; it is \
                 always read from the full image",
            ));
        }
    }
    let strength = match &spec.scale {
        None => 1.0,
        Some(v) => number(v).filter(|s| *s >= 0.0).ok_or_else(|| {
            key_error(
                file,
                format!("{key}.scale"),
                "expected a number ≥ 0 (the map's strength)",
            )
        })?,
    };
    let texture = section_texture(key, spec, base, reader, ColorSpace::Linear)?;
    Ok(NormalInput { texture, strength })
}

/// A number texture input at `key`.
fn scalar_input(
    key: &str,
    spec: &TextureSection,
    base: &Path,
    reader: &mut TextureReader,
) -> Result<ScalarInput, RenderError> {
    let file = reader.file;
    let channel = match spec.channel.as_deref() {
        None | Some("r") => 0,
        Some("g") => 1,
        Some("b") => 2,
        Some("a") => 3,
        Some(other) => {
            return Err(key_error(
                file,
                format!("{key}.channel"),
                format!("expected \"r\", \"g\", \"b\" or \"a\", got {other:?}"),
            ));
        }
    };
    let texture = section_texture(key, spec, base, reader, ColorSpace::Linear)?;
    let one = |name: &str, v: &Option<toml::Value>, default: f32| -> Result<f32, RenderError> {
        match v {
            None => Ok(default),
            Some(v) => number(v)
                .ok_or_else(|| key_error(file, format!("{key}.{name}"), "expected a number")),
        }
    };
    Ok(ScalarInput {
        texture,
        channel,
        scale: one("scale", &spec.scale, 1.0)?,
        offset: one("offset", &spec.offset, 0.0)?,
        filter: filter(spec.filter),
    })
}

/// The texture a texture section at `key` names (relative to the shot's folder `base`), read
/// in its `colorspace`, `default` when it gives none.
fn section_texture(
    key: &str,
    spec: &TextureSection,
    base: &Path,
    reader: &mut TextureReader,
    default: ColorSpace,
) -> Result<u32, RenderError> {
    reader.load(
        &format!("{key}.texture"),
        &base.join(&spec.texture),
        &spec.texture,
        color_space(spec.colorspace, default),
    )
}

/// The filter a texture's `filter` key names (trilinear by default).
fn filter(given: Option<TextureFilter>) -> Filter {
    match given {
        Some(TextureFilter::Bilinear) => Filter::Bilinear,
        Some(TextureFilter::Trilinear) | None => Filter::Trilinear,
    }
}

/// The colour space a texture's `colorspace` key names, or `default`.
fn color_space(given: Option<TextureColorSpace>, default: ColorSpace) -> ColorSpace {
    match given {
        Some(TextureColorSpace::Srgb) => ColorSpace::Srgb,
        Some(TextureColorSpace::Linear) => ColorSpace::Linear,
        None => default,
    }
}

/// A finite TOML number.
fn number(v: &toml::Value) -> Option<f32> {
    let x = v.as_float().or_else(|| v.as_integer().map(|i| i as f64))?;
    (x.is_finite() && x.abs() < 1e6).then_some(x as f32)
}

/// A number (the same on every channel) or an [r, g, b] of numbers.
fn number_or_color(v: &toml::Value) -> Option<Vec3> {
    if let Some(x) = number(v) {
        return Some(Vec3::splat(x));
    }
    match v.as_array()?.as_slice() {
        [r, g, b] => Some(Vec3::new(number(r)?, number(g)?, number(b)?)),
        _ => None,
    }
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

/// A material from an MTL entry: Kd (or its map_Kd, an sRGB colour texture scaled by Kd when
/// both are given) as diffuse reflectance, Ke (or map_Ke, likewise) as one-sided emission,
/// `norm`/`map_Bump` as a normal map, `d`/`map_d` as opacity (cut-outs). With Ks, Ns, Pr, Pm
/// or their maps it is a standard material, read as Blender writes them: roughness Pr (or
/// 1 − √(Ns/1000)), metallic Pm, and Ks's mean as the specular level (0.5: ior 1.5). Maps'
/// paths are relative to `folder`, the mesh's; `key` names the object in messages.
pub(super) fn from_mtl(
    mtl: &super::mesh::MtlMaterial,
    folder: &Path,
    key: &str,
    reader: &mut TextureReader,
) -> Result<Material, RenderError> {
    let diffuse = mtl.diffuse.unwrap_or(Vec3::splat(0.8));
    let inputs = mtl_inputs(mtl, folder, key, reader)?;
    let standard = mtl.specular.is_some()
        || mtl.shininess.is_some()
        || mtl.roughness.is_some()
        || mtl.metallic.is_some()
        || inputs.roughness.is_some()
        || inputs.metallic.is_some();
    let bsdf = match standard {
        true => Bsdf::Standard(mtl_standard(mtl, diffuse)),
        false => Bsdf::Diffuse {
            reflectance: diffuse,
        },
    };
    Ok(Material {
        name: mtl.name.clone(),
        bsdf,
        emission: mtl.emission.unwrap_or(Vec3::ZERO),
        two_sided_emission: false,
        one_sided: false,
        inputs: (inputs != Inputs::default()).then(|| Box::new(inputs)),
        opacity: mtl.opacity.unwrap_or(1.0),
        optical_contact: false,
    })
}

/// The textured inputs an MTL entry's maps give: map_Kd and map_Ke as sRGB colours scaled by
/// Kd and Ke, map_Pr and map_Pm as linear numbers, the normal map with its strength, and
/// map_d's alpha (or first) channel as opacity.
fn mtl_inputs(
    mtl: &super::mesh::MtlMaterial,
    folder: &Path,
    key: &str,
    reader: &mut TextureReader,
) -> Result<Inputs, RenderError> {
    let mut load = |map: &String, space| reader.load(key, &folder.join(map), map, space);
    let scalar = |texture| ScalarInput {
        texture,
        channel: 0,
        scale: 1.0,
        offset: 0.0,
        filter: Filter::Trilinear,
    };
    let colour = |texture, scale: Option<Vec3>| ColorInput {
        texture,
        scale: scale.unwrap_or(Vec3::ONE),
        offset: Vec3::ZERO,
        filter: Filter::Trilinear,
    };
    let mut inputs = Inputs::default();
    if let Some(map) = &mtl.diffuse_map {
        inputs.reflectance = Some(colour(load(map, ColorSpace::Srgb)?, mtl.diffuse));
    }
    if let Some(map) = &mtl.emission_map {
        inputs.emission = Some(colour(load(map, ColorSpace::Srgb)?, mtl.emission));
    }
    if let Some(map) = &mtl.roughness_map {
        inputs.roughness = Some(scalar(load(map, ColorSpace::Linear)?));
    }
    if let Some(map) = &mtl.metallic_map {
        inputs.metallic = Some(scalar(load(map, ColorSpace::Linear)?));
    }
    if let Some((map, strength)) = &mtl.normal_map {
        let texture = load(map, ColorSpace::Linear)?;
        inputs.normal = Some(NormalInput {
            texture,
            strength: *strength,
        });
    }
    if let Some(map) = &mtl.opacity_map {
        let texture = load(map, ColorSpace::Linear)?;
        // The alpha channel where the image has one, else its first.
        let channels = reader.textures.list()[texture as usize].channels();
        let channel = if channels == 2 || channels == 4 {
            channels - 1
        } else {
            0
        };
        inputs.opacity = Some(ScalarInput {
            channel: channel.min(3),
            ..scalar(texture)
        });
    }
    Ok(inputs)
}

/// The standard material an MTL's Ks, Ns, Pr and Pm describe over the base colour `base`.
fn mtl_standard(mtl: &super::mesh::MtlMaterial, base: Vec3) -> Standard {
    let from_shininess = mtl
        .shininess
        .map(|ns| 1.0 - (ns.clamp(0.0, 1000.0) / 1000.0).sqrt());
    let roughness = mtl.roughness.or(from_shininess).unwrap_or(0.5);
    // The specular level as the Principled BSDF has it: F0 = 0.08 × level.
    let f0 = mtl
        .specular
        .map_or(0.04, |ks| 0.08 * (ks.element_sum() / 3.0).clamp(0.0, 1.0));
    let ior = ((1.0 + f0.sqrt()) / (1.0 - f0.sqrt())).min(MAX_IOR);
    Standard::new(
        base.clamp(Vec3::ZERO, Vec3::ONE),
        mtl.metallic.unwrap_or(0.0),
        Vec3::ONE,
        ior,
        Ggx::from_roughness(roughness),
        0.0,
        Ggx::from_roughness(0.0),
        1.5,
    )
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
        inputs: None,
        opacity: 1.0,
        optical_contact: false,
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
    let reflectance = albedo(key, "reflectance", m.reflectance, 0.8)?;
    let roughness = fraction(key, "roughness", m.roughness, 0.0)?;
    let ggx = Ggx::from_roughness(roughness).with_shadowing(match m.shadowing {
        Some(ShadowingKind::HeightCorrelated) | None => Shadowing::HeightCorrelated,
        Some(ShadowingKind::Separable) => Shadowing::Separable,
    });
    if m.kind != MaterialKind::Standard {
        no_standard_keys(key, m)?;
    }
    let bsdf = match m.kind {
        MaterialKind::Diffuse => diffuse(key, m, reflectance)?,
        MaterialKind::Conductor => conductor(key, m, ggx)?,
        MaterialKind::Dielectric => dielectric(key, m, ggx)?,
        MaterialKind::Standard => standard(key, m, ggx)?,
    };
    let emission = color(&format!("{key}.emission"), m.emission, Vec3::ZERO)?;
    let optical_contact = optical_contact(key, m, &bsdf)?;
    Ok(Material {
        name: m.name.clone(),
        bsdf,
        emission,
        two_sided_emission: m.two_sided_emission.unwrap_or(false),
        one_sided: m.one_sided.unwrap_or(false),
        inputs: None,
        opacity: fraction(key, "opacity", m.opacity, 1.0)?,
        optical_contact,
    })
}

/// True when `contact = "optical"`; only a material that lets light through takes it (between
/// two opaque surfaces no light passes, so how they touch makes no difference).
fn optical_contact(key: &str, m: &MaterialSection, bsdf: &Bsdf) -> Result<bool, Invalid> {
    match m.contact {
        None | Some(ContactKind::Gap) => Ok(false),
        Some(ContactKind::Optical) if bsdf.transmits() => Ok(true),
        Some(ContactKind::Optical) => Err(Invalid::new(
            format!("{key}.contact"),
            "only a material that lets light through (a dielectric) can touch in optical contact",
        )),
    }
}

/// A number from 0 to 1 at `key.field` (`default` when not given).
fn fraction(key: &str, field: &str, v: Option<f64>, default: f64) -> Result<f32, Invalid> {
    optional(v, default, |x| {
        check::within(&format!("{key}.{field}"), x, 0.0, 1.0, false)
    })
    .map(|x| x as f32)
}

/// A colour at `key.field` that reflects no more than it receives: each channel at most 1
/// (`default` on every channel when not given).
fn albedo(key: &str, field: &str, v: Option<[f64; 3]>, default: f32) -> Result<Vec3, Invalid> {
    let c = color(&format!("{key}.{field}"), v, Vec3::splat(default))?;
    match c.max_element() <= 1.0 {
        true => Ok(c),
        false => Err(Invalid::new(
            format!("{key}.{field}"),
            format!("a {field} above 1 creates energy"),
        )),
    }
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

/// Refuses the standard material's own keys on a material of another kind.
fn no_standard_keys(key: &str, m: &MaterialSection) -> Result<(), Invalid> {
    let given = [
        m.base_color.is_some(),
        m.metallic.is_some(),
        m.specular_color.is_some(),
        m.coat.is_some(),
        m.coat_roughness.is_some(),
        m.coat_ior.is_some(),
    ];
    match STANDARD_KEYS.iter().zip(given).find(|(_, given)| *given) {
        Some((field, _)) => Err(Invalid::new(
            format!("{key}.{field}"),
            format!("only a standard material has {field} (type = \"standard\")"),
        )),
        None => Ok(()),
    }
}

/// The standard layered material ([`Standard`]): every input checked within its range.
fn standard(key: &str, m: &MaterialSection, ggx: Ggx) -> Result<Bsdf, Invalid> {
    no_metal_keys(key, m, "standard")?;
    if m.reflectance.is_some() {
        return Err(Invalid::new(
            format!("{key}.reflectance"),
            "a standard material's colour is its base_color",
        ));
    }
    if m.multiscatter.is_some() {
        return Err(Invalid::new(
            format!("{key}.multiscatter"),
            "a standard material always keeps its energy: leave multiscatter out",
        ));
    }
    let ior = |field: &str, v: Option<f64>| {
        optional(v, 1.5, |x| {
            check::within(&format!("{key}.{field}"), x, 1.0, MAX_IOR as f64, false)
        })
        .map(|x| x as f32)
    };
    let coat_roughness = fraction(key, "coat_roughness", m.coat_roughness, 0.0)?;
    // UsdPreviewSurface's and the Principled BSDF's default roughness.
    let ggx = match m.roughness {
        Some(_) => ggx,
        None => Ggx::from_roughness(0.5).with_shadowing(ggx.shadowing),
    };
    Ok(Bsdf::Standard(Standard::new(
        albedo(key, "base_color", m.base_color, 0.8)?,
        fraction(key, "metallic", m.metallic, 0.0)?,
        albedo(key, "specular_color", m.specular_color, 1.0)?,
        ior("ior", m.ior)?,
        ggx,
        fraction(key, "coat", m.coat, 0.0)?,
        Ggx::from_roughness(coat_roughness).with_shadowing(ggx.shadowing),
        ior("coat_ior", m.coat_ior)?,
    )))
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
