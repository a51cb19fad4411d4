//! UsdShade materials into rift's: a bound UsdPreviewSurface becomes a `standard` material
//! (diffuse colour, emissive colour, roughness, metallic, ior, clear coat, opacity as a
//! cut-out, a normal map), each input a constant or a UsdUVTexture with its scale, bias,
//! colour space and channel. An unbound mesh takes its display colour, as USD viewers show it.

use super::Entry;
use super::values::{self, token};
use super::{Source, well_formed};
use crate::error::RenderError;
use openusd::schemas::shade::{Material, Shader};
use openusd::sdf::{self, Value};
use openusd::usd::{Prim, SchemaBase, Stage};
use std::path::{Path, PathBuf};

/// A material made from the stage: its scene name, its section and what it could not say.
pub struct Made {
    pub name: String,
    pub entry: Entry,
    pub warnings: Vec<String>,
}

/// The material bound to `prim` (its own `material:binding`, else its nearest ancestor's),
/// by path.
pub fn bound_material(prim: &Prim) -> anyhow::Result<Option<String>> {
    let stage = prim.stage();
    let mut path = Some(prim.path().clone());
    while let Some(p) = path {
        if p.is_abs_root() {
            break;
        }
        let here = stage.prim(p.clone());
        for rel in ["material:binding", "material:binding:full"] {
            if let Some(target) = here.relationship(rel).targets()?.into_iter().next() {
                if !well_formed(&target) {
                    anyhow::bail!("{rel} targets a malformed path {:?}", target.as_str());
                }
                return Ok(Some(target.as_str().to_owned()));
            }
        }
        path = p.parent();
    }
    Ok(None)
}

/// An unbound mesh's material: its constant `primvars:displayColor`, else USD's 18% grey.
pub fn display_color(prim: &Prim, source: &Source) -> Result<Made, RenderError> {
    let path = prim.path().as_str();
    let value = super::values::value(prim, "primvars:displayColor", source.codes()[0])
        .map_err(|e| source.read_error(path, e))?;
    let color = match &value {
        Some(Value::Vec3fVec(c)) if !c.is_empty() => [c[0].x, c[0].y, c[0].z],
        Some(v) => values::color(v).unwrap_or([0.18; 3]),
        None => [0.18; 3],
    };
    let name = format!("{path}#displayColor");
    let mut table = toml::Table::new();
    table.insert("name".into(), name.clone().into());
    table.insert("type".into(), "diffuse".into());
    table.insert("reflectance".into(), color_value(color));
    Ok(Made {
        entry: Entry {
            file: source.layer.to_owned(),
            key: format!("<{path}>.primvars:displayColor"),
            table,
        },
        name,
        warnings: Vec::new(),
    })
}

/// The scene material for the USD material at `path`.
pub fn material(stage: &Stage, path: &str, source: &Source) -> Result<Made, RenderError> {
    let read = |e| source.read_error(path, e);
    let sdf_path = sdf::path(path).map_err(read)?;
    let material = Material::get(stage, sdf_path)
        .map_err(read)?
        .ok_or_else(|| {
            source.error(
                path,
                None,
                "a mesh binds it, but it is not a Material".into(),
            )
        })?;
    let shader = surface_shader(&material, source)?;
    let id = match &shader {
        Some(s) => s.id().map_err(read)?,
        None => None,
    };
    let mut made = Made {
        name: path.to_owned(),
        entry: Entry {
            file: source.layer.to_owned(),
            key: format!("<{path}>"),
            table: toml::Table::new(),
        },
        warnings: Vec::new(),
    };
    let (Some(shader), Some("UsdPreviewSurface")) = (shader, id.as_deref()) else {
        made.warnings.push(format!(
            "{}: material <{path}> has no UsdPreviewSurface (surface: {}); rendered in \
             USD's 18% grey",
            source.layer.display(),
            id.as_deref().unwrap_or("none")
        ));
        made.entry.table = grey(path);
        return Ok(made);
    };
    let mut surface = Surface {
        shader: &shader,
        source,
        table: toml::Table::new(),
        warnings: Vec::new(),
    };
    surface.read().map_err(|e| match e {
        Problem::Read(e) => source.read_error(shader.path().as_str(), e),
        Problem::Refused(attribute, message) => {
            source.error(shader.path().as_str(), Some(&attribute), message)
        }
    })?;
    surface.table.insert("name".into(), path.into());
    made.entry.table = surface.table;
    made.warnings = surface.warnings;
    Ok(made)
}

/// The shader `material`'s `outputs:surface` connects to (followed here, each target checked
/// well-formed, rather than by the crate, whose composition loops on a malformed one).
fn surface_shader(material: &Material, source: &Source) -> Result<Option<Shader>, RenderError> {
    let path = material.prim().path().as_str();
    let read = |e| source.read_error(path, e);
    let output = material.prim().attribute("outputs:surface");
    let Some(target) = output.connections().map_err(read)?.into_iter().next() else {
        return Ok(None);
    };
    if !well_formed(&target) {
        return Err(source.error(
            path,
            Some("outputs:surface"),
            format!("it connects to a malformed path {:?}", target.as_str()),
        ));
    }
    Shader::get(material.prim().stage(), target.prim_path()).map_err(read)
}

fn grey(name: &str) -> toml::Table {
    let mut table = toml::Table::new();
    table.insert("name".into(), name.into());
    table.insert("type".into(), "diffuse".into());
    table.insert("reflectance".into(), color_value([0.18; 3]));
    table
}

enum Problem {
    Read(anyhow::Error),
    /// An input rift cannot take: the attribute and why.
    Refused(String, String),
}

impl From<anyhow::Error> for Problem {
    fn from(e: anyhow::Error) -> Self {
        Problem::Read(e)
    }
}

/// A UsdPreviewSurface being read into a material table.
struct Surface<'a> {
    shader: &'a Shader,
    source: &'a Source<'a>,
    table: toml::Table,
    warnings: Vec<String>,
}

/// What a UsdPreviewSurface input is: a colour or a number.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    Color,
    Number,
}

/// The UsdPreviewSurface inputs [`Surface::read`] takes (`displacement` to say it is not
/// rendered); any other `inputs:` attribute is said.
const READ_INPUTS: [&str; 13] = [
    "useSpecularWorkflow",
    "specularColor",
    "diffuseColor",
    "roughness",
    "metallic",
    "clearcoat",
    "clearcoatRoughness",
    "emissiveColor",
    "ior",
    "opacity",
    "opacityThreshold",
    "normal",
    "displacement",
];

impl Surface<'_> {
    fn read(&mut self) -> Result<(), Problem> {
        self.unread_inputs()?;
        self.table.insert("type".into(), "standard".into());
        if self.number("useSpecularWorkflow")? == Some(1.0) {
            self.warn("useSpecularWorkflow = 1: rift's standard material has a metallic workflow; its specularColor tints the specular layer".into());
            self.input("specularColor", "specular_color", Kind::Color)?;
        }
        self.input("diffuseColor", "base_color", Kind::Color)?;
        self.input("roughness", "roughness", Kind::Number)?;
        self.input("metallic", "metallic", Kind::Number)?;
        self.input("clearcoat", "coat", Kind::Number)?;
        self.input("clearcoatRoughness", "coat_roughness", Kind::Number)?;
        self.input("emissiveColor", "emission", Kind::Color)?;
        if let Some(ior) = self.number("ior")? {
            self.table.insert("ior".into(), (ior as f64).into());
        }
        self.opacity()?;
        self.normal()?;
        if self.connected("displacement")?.is_some()
            || self.number("displacement")?.is_some_and(|d| d != 0.0)
        {
            self.warn("displacement is not rendered".into());
        }
        Ok(())
    }

    /// Says which `inputs:` the shader authors that rift does not read (UsdPreviewSurface's
    /// `occlusion`, which a path tracer computes, or inputs of another renderer's).
    fn unread_inputs(&mut self) -> Result<(), Problem> {
        let names = self.shader.prim().property_names()?;
        let unread: Vec<&str> = (names.iter())
            .filter_map(|name| name.as_str().strip_prefix("inputs:"))
            .filter(|input| !READ_INPUTS.contains(input))
            .collect();
        if !unread.is_empty() {
            let list = unread.join(", ");
            self.warn(format!("inputs {list}: not read by rift, left out"));
        }
        Ok(())
    }

    fn warn(&mut self, what: String) {
        self.warnings.push(format!(
            "{}: <{}>: {what}",
            self.source.layer.display(),
            self.shader.path().as_str()
        ));
    }

    /// `inputs:<name>` into `key`: its constant, or the texture connected to it.
    fn input(&mut self, name: &str, key: &str, kind: Kind) -> Result<(), Problem> {
        if let Some(texture) = self.texture(name, kind)? {
            self.table.insert(key.into(), texture.into());
            return Ok(());
        }
        let value = match kind {
            Kind::Color => self.color(name)?.map(color_value),
            Kind::Number => self.number(name)?.map(|v| (v as f64).into()),
        };
        if let Some(v) = value {
            self.table.insert(key.into(), v);
        }
        Ok(())
    }

    /// Opacity: a cut-out where it is below 1 (its threshold, when given, makes it a mask).
    fn opacity(&mut self) -> Result<(), Problem> {
        let threshold = self.number("opacityThreshold")?.unwrap_or(0.0);
        if threshold > 0.0 {
            self.warn(format!(
                "opacityThreshold {threshold}: rift lets rays through in proportion to opacity \
                 (a stochastic cut-out) rather than at a threshold"
            ));
        }
        if let Some(texture) = self.texture("opacity", Kind::Number)? {
            self.table.insert("opacity".into(), texture.into());
        } else if let Some(o) = self.number("opacity")?.filter(|&o| o < 1.0) {
            self.table.insert("opacity".into(), (o as f64).into());
        }
        Ok(())
    }

    /// `inputs:normal` from a texture: a tangent-space normal map. Its scale and bias must
    /// be the usual 2 and −1 (rift decodes them itself).
    fn normal(&mut self) -> Result<(), Problem> {
        let Some(Texture {
            path, scale, bias, ..
        }) = self.connected_texture("normal")?
        else {
            return Ok(());
        };
        let usual = scale[..3].iter().all(|&s| (s - 2.0).abs() < 1e-4)
            && bias[..3].iter().all(|&b| (b + 1.0).abs() < 1e-4);
        if !usual {
            return Err(Problem::Refused(
                "inputs:normal".into(),
                format!(
                    "its texture's scale {scale:?} and bias {bias:?} are not the usual \
                     (2, 2, 2) and (-1, -1, -1) of a tangent-space normal map"
                ),
            ));
        }
        let mut t = toml::Table::new();
        t.insert("texture".into(), path.into());
        self.table.insert("normal_map".into(), t.into());
        Ok(())
    }

    /// The number at `inputs:<name>`, unconnected.
    fn number(&self, name: &str) -> Result<Option<f32>, Problem> {
        let v = self.authored(name)?;
        Ok(v.as_ref().and_then(values::number).map(|n| n as f32))
    }

    /// The colour at `inputs:<name>`, unconnected.
    fn color(&self, name: &str) -> Result<Option<[f32; 3]>, Problem> {
        Ok(self.authored(name)?.as_ref().and_then(values::color))
    }

    /// The value authored at `inputs:<name>`.
    fn authored(&self, name: &str) -> Result<Option<Value>, Problem> {
        let attr = self.shader.prim().attribute(format!("inputs:{name}"));
        Ok(attr.get::<Value>()?)
    }

    /// What `inputs:<name>` connects to: the source prim and its output's name.
    fn connected(&self, name: &str) -> Result<Option<(Prim, String)>, Problem> {
        let attr = self.shader.prim().attribute(format!("inputs:{name}"));
        let Some(target) = attr.connections()?.into_iter().next() else {
            return Ok(None);
        };
        if !well_formed(&target) {
            return Err(Problem::Refused(
                format!("inputs:{name}"),
                format!("it connects to a malformed path {:?}", target.as_str()),
            ));
        }
        let Some((prim, property)) = target.split_property() else {
            return Ok(None);
        };
        let output = property
            .strip_prefix("outputs:")
            .unwrap_or(property)
            .to_owned();
        Ok(Some((self.shader.stage().prim(prim), output)))
    }

    /// The texture connected to `inputs:<name>`, as a rift texture table.
    fn texture(&mut self, name: &str, kind: Kind) -> Result<Option<toml::Table>, Problem> {
        let Some(texture) = self.connected_texture(name)? else {
            return Ok(None);
        };
        let (scale, bias) = (texture.scale, texture.bias);
        let mut t = toml::Table::new();
        t.insert("texture".into(), texture.path.into());
        match (kind, texture.output.as_str()) {
            (Kind::Color, "rgb") => {
                if scale[..3] != [1.0; 3] {
                    t.insert("scale".into(), color_value([scale[0], scale[1], scale[2]]));
                }
                if bias[..3] != [0.0; 3] {
                    t.insert("offset".into(), color_value([bias[0], bias[1], bias[2]]));
                }
            }
            (Kind::Number, channel @ ("r" | "g" | "b" | "a")) => {
                let i = "rgba".find(channel).unwrap_or(0);
                t.insert("channel".into(), channel.into());
                if scale[i] != 1.0 {
                    t.insert("scale".into(), (scale[i] as f64).into());
                }
                if bias[i] != 0.0 {
                    t.insert("offset".into(), (bias[i] as f64).into());
                }
            }
            (_, output) => {
                return Err(Problem::Refused(
                    format!("inputs:{name}"),
                    format!(
                        "it reads the texture's output {output:?}, which does not fit the \
                         input (a colour takes \"rgb\", a number \"r\", \"g\", \"b\" or \"a\")"
                    ),
                ));
            }
        }
        if let Some(space) = texture.color_space {
            t.insert("colorspace".into(), space.into());
        }
        Ok(Some(t))
    }

    /// The UsdUVTexture connected to `inputs:<name>`.
    fn connected_texture(&mut self, name: &str) -> Result<Option<Texture>, Problem> {
        let Some((prim, output)) = self.connected(name)? else {
            return Ok(None);
        };
        let prim_path = prim.path().as_str().to_owned();
        let id = token(&prim, "info:id", 0.0)?;
        if id.as_deref() != Some("UsdUVTexture") {
            return Err(Problem::Refused(
                format!("inputs:{name}"),
                format!(
                    "it connects to <{prim_path}> ({}), which rift does not read; connect a \
                     UsdUVTexture or give a value",
                    id.as_deref().unwrap_or("no shader id")
                ),
            ));
        }
        let texture = Texture::read(&prim, output, self.source)?;
        for wrap in ["wrapS", "wrapT"] {
            let mode = token(&prim, &format!("inputs:{wrap}"), 0.0)?;
            if let Some(mode) = mode.filter(|m| m != "repeat" && m != "useMetadata") {
                self.warn(format!(
                    "texture <{prim_path}> asks {wrap} = {mode:?}; rift repeats textures"
                ));
            }
        }
        self.check_uv_set(&prim)?;
        let four = |n: &str, default: [f32; 4]| -> Result<[f32; 4], Problem> {
            Ok(
                match prim.attribute(format!("inputs:{n}")).get::<Value>()? {
                    Some(Value::Vec4f(v)) => [v.x, v.y, v.z, v.w],
                    Some(Value::Vec4d(v)) => [v.x as f32, v.y as f32, v.z as f32, v.w as f32],
                    _ => default,
                },
            )
        };
        Ok(Some(Texture {
            scale: four("scale", [1.0; 4])?,
            bias: four("bias", [0.0; 4])?,
            ..texture
        }))
    }

    /// Warns when a texture reads UVs from a primvar other than the ones rift reads.
    fn check_uv_set(&mut self, texture: &Prim) -> Result<(), Problem> {
        let st = texture.attribute("inputs:st");
        let Some(target) = st.connections()?.into_iter().next().filter(well_formed) else {
            return Ok(());
        };
        let reader = self.shader.stage().prim(target.prim_path());
        let varname = match reader.attribute("inputs:varname").get::<Value>()? {
            Some(Value::Token(t)) => t.as_str().to_owned(),
            Some(Value::String(s)) => s,
            _ => return Ok(()),
        };
        if varname != "st" && varname != "UVMap" {
            self.warn(format!(
                "a texture reads UVs from primvar {varname:?}; rift reads primvars:st (or \
                 primvars:UVMap)"
            ));
        }
        Ok(())
    }
}

/// A UsdUVTexture's file (resolved against the layer that authored it) and how it is read.
struct Texture {
    path: String,
    /// Which of its outputs the input reads: "rgb", "r", "g", "b" or "a".
    output: String,
    color_space: Option<&'static str>,
    /// Its `scale` and `bias` per channel (r, g, b, a).
    scale: [f32; 4],
    bias: [f32; 4],
}

impl Texture {
    fn read(prim: &Prim, output: String, source: &Source) -> Result<Self, Problem> {
        // The stage resolves an asset path against the layer that authored it (a sublayer or
        // reference in another folder); a file it cannot find keeps the authored path, anchored
        // to the root layer's folder below, whose error names it.
        let (file, resolved) = match prim.attribute("inputs:file").get::<Value>()? {
            Some(Value::AssetPath(a)) => {
                let resolved = a.resolved_path().map(PathBuf::from);
                (a.authored_path, resolved)
            }
            Some(Value::String(s)) => (s, None),
            _ => {
                return Err(Problem::Refused(
                    "inputs:file".into(),
                    format!("texture <{}> names no file", prim.path().as_str()),
                ));
            }
        };
        let relative = file.trim_start_matches("./");
        let path = if source.layer.extension().is_some_and(|e| e == "usdz") {
            // Packed beside the layer in its package, named as USD names packed files.
            format!("{}[{relative}]", source.layer.display()).into()
        } else if let Some(resolved) = resolved {
            resolved
        } else {
            let folder = source.layer.parent().unwrap_or(Path::new("."));
            folder.join(relative)
        };
        let color_space = match token(prim, "inputs:sourceColorSpace", 0.0)?.as_deref() {
            Some("raw") => Some("linear"),
            Some("sRGB") => Some("srgb"),
            _ => None,
        };
        Ok(Self {
            path: path.to_string_lossy().into_owned(),
            output,
            color_space,
            scale: [1.0; 4],
            bias: [0.0; 4],
        })
    }
}

fn color_value(c: [f32; 3]) -> toml::Value {
    toml::Value::Array(c.iter().map(|&x| toml::Value::Float(x as f64)).collect())
}
