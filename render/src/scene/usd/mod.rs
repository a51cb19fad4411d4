//! `[[usd]]`: sets, characters, lights and materials read from the pipeline's USD layers
//! (usda, usdc or usdz) with the `openusd` crate, natively at render time.
//!
//! A stage becomes what the shot file would otherwise say: each mesh prim an object named by
//! its prim path (so `copy_of`, `through`, cull volumes and light groups can name it), each
//! bound UsdPreviewSurface a material named by the material's path, each UsdLux light a
//! `[[light]]` and a dome light the `[environment]`. The sections are built as the shot's own
//! tables are and checked by the same code, their messages naming the layer and the prim.
//! What the stage holds that rift does not read is said once per prim, never skipped silently.

pub mod camera;
mod crate_check;
mod instancing;
mod lights;
mod mesh;
mod ops;
mod shading;
mod stage;
mod values;
mod xform;

use stage::{StageLimits, open_stage};

use super::Entry;
use super::schema::{ObjectSection, UsdSection};
use crate::error::{RenderError, key_error};
use rift_fx::Shot;
use std::path::{Path, PathBuf};

/// What the `[[usd]]` sections bring, as the shot's own sections would say it.
#[derive(Default)]
pub struct Imported {
    /// One per mesh prim, named by its path, with its shape attached.
    pub objects: Vec<ObjectSection>,
    pub materials: Vec<Entry>,
    pub lights: Vec<Entry>,
    /// From a dome light.
    pub environment: Option<Entry>,
    /// What the stages hold that rift does not read, each said once (with its prim).
    pub warnings: Vec<String>,
}

/// Maps the stage's time codes to the shot's seconds.
#[derive(Clone, Copy, Debug)]
pub struct Clock {
    /// Stage time codes per second.
    pub codes_per_second: f64,
    /// The section's offset, seconds.
    pub offset: f64,
    /// The shot's frames per second.
    pub fps: f64,
}

impl Clock {
    /// Seconds of shot time at time code `code`.
    pub fn seconds(&self, code: f64) -> f64 {
        code / self.codes_per_second + self.offset
    }

    /// The shot frame at time code `code`.
    pub fn frame(&self, code: f64) -> f64 {
        self.seconds(code) * self.fps
    }

    /// The time code at shot time `seconds`.
    pub fn code(&self, seconds: f64) -> f64 {
        (seconds - self.offset) * self.codes_per_second
    }
}

/// A layer to read, and the shot key that names it.
pub struct Layer<'a> {
    pub path: &'a Path,
    /// The section's key, `usd[i]`.
    pub key: &'a str,
    pub shot_file: &'a Path,
    /// Only the prims under this one.
    pub root: Option<&'a str>,
    /// The camera prim the shot frames itself with, if any.
    pub shot_camera: Option<&'a str>,
}

impl Layer<'_> {
    /// An error about the layer, under its section's `file` key.
    fn error(&self, message: String) -> RenderError {
        key_error(self.shot_file, format!("{}.file", self.key), message)
    }
}

/// Reads the stage of `layer` into `out`: time codes at `offset` seconds and `fps` frames a
/// second, for rays at `span` (seconds), within `budget` bytes ([`caught`]).
pub fn read_layer(
    layer: &Layer,
    clock: (f64, f64),
    span: [f64; 2],
    budget: Option<u64>,
    out: &mut Imported,
) -> Result<(), RenderError> {
    let read = caught(layer, || {
        let mut read = Imported::default();
        read_stage(layer, clock, span, budget, &mut read).map(|()| read)
    })?;
    out.objects.extend(read.objects);
    out.materials.extend(read.materials);
    out.lights.extend(read.lights);
    out.warnings.extend(read.warnings);
    if read.environment.is_some() && out.environment.is_some() {
        return Err(layer.error(
            "a second dome light: rift's environment is one (or give it in the shot)".into(),
        ));
    }
    out.environment = out.environment.take().or(read.environment);
    Ok(())
}

/// `read` of `layer`, a panic of the USD crate's parser (an assertion, an index past an array,
/// on a malformed file) reported as a malformed layer, so bad input never ends the program.
pub(super) fn caught<T>(
    layer: &Layer,
    read: impl FnOnce() -> Result<T, RenderError>,
) -> Result<T, RenderError> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(read)) {
        Ok(result) => result,
        Err(panic) => {
            let what = panic
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| panic.downcast_ref::<&str>().copied())
                .unwrap_or("no message");
            Err(layer.error(format!(
                "{}: the layer is malformed: the USD reader stopped ({what})",
                layer.path.display()
            )))
        }
    }
}

/// Opens the stage of `layer` within `budget`, with its clock (time codes at `offset` seconds
/// and `fps` frames a second).
fn open_layer(
    layer: &Layer,
    (offset, fps): (f64, f64),
    budget: Option<u64>,
) -> Result<(openusd::usd::Stage, Clock), RenderError> {
    let stage = open_stage(layer.path, StageLimits::from_budget(budget))
        .map_err(|message| layer.error(message))?;
    let clock = Clock {
        codes_per_second: stage.time_codes_per_second(),
        offset,
        fps,
    };
    if !(clock.codes_per_second.is_finite() && clock.codes_per_second > 0.0) {
        return Err(layer.error(format!(
            "{}: timeCodesPerSecond is {}; expected a positive number",
            layer.path.display(),
            clock.codes_per_second
        )));
    }
    Ok((stage, clock))
}

fn read_stage(
    layer: &Layer,
    clock: (f64, f64),
    span: [f64; 2],
    budget: Option<u64>,
    out: &mut Imported,
) -> Result<(), RenderError> {
    let (stage, clock) = open_layer(layer, clock, budget)?;
    if let Ok(Some(openusd::sdf::Value::Token(axis))) = stage.stage_metadata("upAxis")
        && axis.as_str() != "Y"
    {
        out.warnings.push(format!(
            "{}: the stage's up axis is {}; rift reads it as authored, in a world whose up is \
             +Y (place the shot's camera and openings in the stage's own axes)",
            layer.path.display(),
            axis.as_str()
        ));
    }
    let source = Source {
        layer: layer.path,
        key: layer.key,
        shot_file: layer.shot_file,
        root: layer.root,
        clock,
        span,
        budget,
        shot_camera: layer.shot_camera,
        ancestors: Default::default(),
    };
    stage::read(&stage, &source, out)
}

/// True when `path` (a relationship's or connection's target, as the layer gives it) is a
/// well-formed absolute path: the USD crate's composition can loop forever on a malformed one
/// (spaces or line breaks inside it), so rift follows no other.
pub fn well_formed(path: &openusd::sdf::Path) -> bool {
    let text = path.as_str();
    text.starts_with('/')
        && text.len() < 4096
        && text
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "_/.:{}=-".contains(c))
        && openusd::sdf::path(text).is_ok()
}

/// Where a stage came from and what of it is read.
pub struct Source<'a> {
    pub layer: &'a Path,
    /// `usd[i]`, for messages about the section itself.
    pub key: &'a str,
    pub shot_file: &'a Path,
    pub root: Option<&'a str>,
    pub clock: Clock,
    /// Shot seconds rays can reach.
    pub span: [f64; 2],
    pub budget: Option<u64>,
    /// The camera the shot frames itself with (`[camera] usd`), read elsewhere.
    pub shot_camera: Option<&'a str>,
    /// The stage's ancestors' transforms and sample times, read once.
    pub ancestors: xform::Ancestors,
}

impl Source<'_> {
    /// An error about `prim` (its `attribute`, when given), in the layer.
    pub fn error(&self, prim: &str, attribute: Option<&str>, message: String) -> RenderError {
        let key = match attribute {
            Some(a) => format!("<{prim}>.{a}"),
            None => format!("<{prim}>"),
        };
        key_error(self.layer, key, message)
    }

    /// An error the crate reported while reading `prim`.
    pub fn read_error(&self, prim: &str, e: anyhow::Error) -> RenderError {
        self.error(prim, None, format!("cannot be read: {e:#}"))
    }

    /// The time codes rays need: the span's ends mapped to the stage.
    pub fn codes(&self) -> [f64; 2] {
        self.span.map(|s| self.clock.code(s))
    }
}

/// Reads every `[[usd]]` section of `shot` for rays at `times` (seconds; `margin` more on
/// each side for copies seen through openings with time offsets), within `budget` bytes.
pub fn import(
    shot: &Shot,
    times: [f64; 2],
    margin: f64,
    budget: Option<u64>,
) -> Result<Imported, RenderError> {
    let mut out = Imported::default();
    for section in sections(shot)? {
        let layer_source = section.layer(shot);
        let span = [times[0] - margin, times[1] + margin];
        read_layer(
            &layer_source,
            (section.offset, shot.fps),
            span,
            budget,
            &mut out,
        )?;
    }
    Ok(out)
}

/// A `[[usd]]` section, checked: its key, its layer (absolute), root prim and time offset
/// (seconds).
pub(super) struct Section {
    pub key: String,
    pub layer: PathBuf,
    pub root: Option<String>,
    pub offset: f64,
}

impl Section {
    pub fn layer<'a>(&'a self, shot: &'a Shot) -> Layer<'a> {
        Layer {
            path: &self.layer,
            key: &self.key,
            shot_file: &shot.source,
            root: self.root.as_deref(),
            shot_camera: shot.camera_prim.as_deref(),
        }
    }
}

/// The shot's `[[usd]]` sections, checked.
pub(super) fn sections(shot: &Shot) -> Result<Vec<Section>, RenderError> {
    let file = &shot.source;
    let base = file.parent().unwrap_or(Path::new("."));
    let mut out = Vec::new();
    for (i, table) in shot.render.usd.iter().enumerate() {
        let key = format!("usd[{i}]");
        let section: UsdSection = super::parse(file, &key, table)?;
        let offset = match section.time_offset {
            Some(f) if !f.is_finite() || f.abs() > 1e9 => {
                return Err(key_error(
                    file,
                    format!("{key}.time_offset"),
                    "expected a finite number of frames within ±1e9",
                ));
            }
            Some(f) => f / shot.fps,
            None => 0.0,
        };
        // Absolute, so the textures and maps it names are found from any folder.
        let layer = base.join(&section.file);
        let layer = std::fs::canonicalize(&layer).unwrap_or(layer);
        out.push(Section {
            key,
            layer,
            root: section.root,
            offset,
        });
    }
    Ok(out)
}
