//! UsdLux lights into `[[light]]` sections (sphere, disk, rect and distant lights, a cone from
//! the ShapingAPI) and a dome light into the `[environment]`, in UsdLux's own units: colour ×
//! intensity × 2^exposure, `normalize` as authored. A light's scale sizes it.

use super::Source;
use super::xform::{light_placement, placement};
use super::{Entry, Imported, values};
use crate::error::RenderError;
use glam::{DMat3, DVec3};
use openusd::sdf::Value;
use openusd::usd::Prim;

/// Reads the light `prim` of type `kind` into `out`.
pub fn read(
    prim: &Prim,
    kind: &str,
    source: &Source,
    out: &mut Imported,
) -> Result<(), RenderError> {
    let path = prim.path().as_str();
    let mut light = Light {
        prim,
        source,
        table: toml::Table::new(),
        warnings: Vec::new(),
    };
    if kind == "DomeLight" {
        if out.environment.is_some() {
            return Err(source.error(
                path,
                None,
                "a second dome light: rift's environment is one (or give it in the shot)".into(),
            ));
        }
        light.dome()?;
        out.environment = Some(light.entry());
    } else {
        light.shape(kind)?;
        out.lights.push(light.entry());
    }
    out.warnings.append(&mut light.warnings);
    Ok(())
}

/// A light prim being read into a section table.
struct Light<'a> {
    prim: &'a Prim,
    source: &'a Source<'a>,
    table: toml::Table,
    warnings: Vec<String>,
}

impl Light<'_> {
    fn path(&self) -> &str {
        self.prim.path().as_str()
    }

    fn entry(&mut self) -> Entry {
        Entry {
            file: self.source.layer.to_owned(),
            key: format!("<{}>", self.path()),
            table: std::mem::take(&mut self.table),
        }
    }

    fn warn(&mut self, what: String) {
        self.warnings.push(format!(
            "{}: <{}>: {what}",
            self.source.layer.display(),
            self.path()
        ));
    }

    /// `inputs:<name>` as a number, at the span's start.
    fn number(&mut self, name: &str) -> Result<Option<f64>, RenderError> {
        Ok(self.value(name)?.as_ref().and_then(values::number))
    }

    /// `inputs:<name>` as a colour, at the span's start.
    fn color(&mut self, name: &str) -> Result<Option<[f64; 3]>, RenderError> {
        let c = self.value(name)?.as_ref().and_then(values::color);
        Ok(c.map(|c| c.map(f64::from)))
    }

    /// `inputs:<name>` at the span's start; keyed values are said once (not blurred).
    fn value(&mut self, name: &str) -> Result<Option<Value>, RenderError> {
        let code = self.source.codes()[0];
        let attr = self.prim.attribute(name);
        let samples = attr
            .num_time_samples()
            .map_err(|e| self.source.read_error(self.path(), e))?;
        if samples > 1 {
            self.warn(format!(
                "{name} is keyed: rift reads it at the shutter's opening, without motion"
            ));
        }
        values::scalar_at(self.prim, name, code).map_err(|e| self.source.read_error(self.path(), e))
    }

    /// A ShapingAPI input: `inputs:shaping:<name>`, or as USD before 21.02 named it,
    /// `shaping:<name>`.
    fn shaping(&mut self, name: &str) -> Result<Option<f64>, RenderError> {
        match self.number(&format!("inputs:shaping:{name}"))? {
            Some(v) => Ok(Some(v)),
            None => self.number(&format!("shaping:{name}")),
        }
    }

    /// The colour × intensity × 2^exposure inputs and `normalize`, as authored.
    fn emission(&mut self) -> Result<(), RenderError> {
        if let Some(c) = self.color("inputs:color")? {
            self.table.insert("color".into(), vec3(c));
        }
        for (usd, key) in [
            ("inputs:intensity", "intensity"),
            ("inputs:exposure", "exposure"),
        ] {
            if let Some(v) = self.number(usd)? {
                self.table.insert(key.into(), v.into());
            }
        }
        if let Some(Value::Bool(true)) = self.value("inputs:normalize")? {
            self.table.insert("normalize".into(), true.into());
        }
        if let Some(Value::Bool(true)) = self.value("inputs:enableColorTemperature")? {
            self.warn("enableColorTemperature: rift does not tint lights by colour temperature; its color alone is used".into());
        }
        for m in ["inputs:diffuse", "inputs:specular"] {
            if self.number(m)?.is_some_and(|v| v != 1.0) {
                self.warn(format!(
                    "{m} is not 1: rift lights every kind of surface alike"
                ));
            }
        }
        Ok(())
    }

    /// A sphere, disk, rect or distant light.
    fn shape(&mut self, kind: &str) -> Result<(), RenderError> {
        let (place, scales) = light_placement(self.prim, self.source)?;
        self.table.insert("name".into(), self.path().into());
        self.emission()?;
        let cone = self.shaping("cone:angle")?.filter(|&a| a < 90.0);
        let mean = |a: f64, b: f64| 0.5 * (a + b);
        let kind_name = match kind {
            "SphereLight" => {
                let point = matches!(self.value("treatAsPoint")?, Some(Value::Bool(true)));
                let radius = if point {
                    0.0
                } else {
                    self.number("inputs:radius")?.unwrap_or(0.5)
                };
                self.uniform(scales, "sphere")?;
                self.table
                    .insert("radius".into(), (radius * scales.x).into());
                if cone.is_some() { "spot" } else { "point" }
            }
            "DiskLight" => {
                let radius = self.number("inputs:radius")?.unwrap_or(0.5);
                if (scales.x - scales.y).abs() > 1e-6 * scales.x {
                    self.warn(
                        "scaled unevenly in its plane: rift's disk stays round (mean scale)".into(),
                    );
                }
                self.table
                    .insert("radius".into(), (radius * mean(scales.x, scales.y)).into());
                "disk"
            }
            "RectLight" => {
                let w = self.number("inputs:width")?.unwrap_or(1.0);
                let h = self.number("inputs:height")?.unwrap_or(1.0);
                self.table.insert("width".into(), (w * scales.x).into());
                self.table.insert("height".into(), (h * scales.y).into());
                if self.value("inputs:texture:file")?.is_some() {
                    self.warn(
                        "its texture is not read: rift's rect lights are of one colour".into(),
                    );
                }
                "rect"
            }
            _ => {
                let angle = self.number("inputs:angle")?.unwrap_or(0.53);
                self.table.insert("angle".into(), angle.into());
                "distant"
            }
        };
        self.table.insert("type".into(), kind_name.into());
        if let Some(angle) = cone {
            self.table.insert("cone_angle".into(), angle.into());
            if let Some(s) = self.shaping("cone:softness")? {
                self.table
                    .insert("cone_softness".into(), s.clamp(0.0, 1.0).into());
            }
        }
        self.table.insert("transform".into(), place.pose_value());
        Ok(())
    }

    /// Warns when a light that stays round is scaled unevenly.
    fn uniform(&mut self, s: DVec3, what: &str) -> Result<(), RenderError> {
        if (s.max_element() - s.min_element()).abs() > 1e-6 * s.max_element() {
            self.warn(format!(
                "scaled unevenly: rift's {what} stays round (its X scale)"
            ));
        }
        Ok(())
    }

    /// A dome light: the environment, its map turned as the OpenEXR lat-long convention
    /// UsdLux follows (its middle column faces +Z, rift's −Z) and as the dome is turned about +Y.
    fn dome(&mut self) -> Result<(), RenderError> {
        let place = placement(self.prim, self.source)?;
        let rotation = DMat3::from_mat4(place.bake);
        let forward = rotation * DVec3::Z;
        if (rotation * DVec3::Y - DVec3::Y * rotation.y_axis.length()).length() > 1e-6 {
            self.warn("turned other than about +Y: rift's environment turns about +Y only".into());
        }
        if !place.keys.is_empty() {
            self.warn(
                "its transform is animated: the environment stands at its first sample".into(),
            );
        }
        let turn = forward.x.atan2(forward.z).to_degrees();
        let color = self.color("inputs:color")?.unwrap_or([1.0; 3]);
        let scale = self.number("inputs:intensity")?.unwrap_or(1.0)
            * self.number("inputs:exposure")?.unwrap_or(0.0).exp2();
        match self.value("inputs:texture:file")? {
            Some(Value::AssetPath(a)) => {
                let folder = self
                    .source
                    .layer
                    .parent()
                    .unwrap_or(std::path::Path::new("."));
                let map = folder.join(a.authored_path.trim_start_matches("./"));
                self.table
                    .insert("map".into(), map.to_string_lossy().into_owned().into());
                self.table.insert("intensity".into(), scale.into());
                self.table.insert(
                    "rotation_degrees".into(),
                    (180.0 - turn).rem_euclid(360.0).into(),
                );
                if color != [1.0; 3] {
                    self.warn("its color does not tint its texture in rift".into());
                }
            }
            _ => {
                let radiance = color.map(|c| c * scale);
                self.table.insert("radiance".into(), vec3(radiance));
            }
        }
        Ok(())
    }
}

fn vec3(c: [f64; 3]) -> toml::Value {
    toml::Value::Array(c.iter().map(|&x| x.into()).collect())
}
