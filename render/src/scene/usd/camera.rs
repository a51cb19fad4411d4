//! The shot's camera from the pipeline (`[camera] usd = "/World/Camera"`): a UsdGeomCamera of the
//! shot's `[[usd]]` layers. Its world transform at every time sample over the shot's frames
//! becomes the camera's keys; its lens (focal length over horizontal aperture for the field of
//! view, f-stop and focus distance for depth of field, in USD's units: focal length and
//! apertures in tenths of a scene unit) at each of its time samples over the shot, so a zoom or
//! a focus pull is the stage's, each frame rendered with the lens at its time; its clipping
//! range becomes the shot's, read at the first frame.

use super::{Section, Source, caught, open_layer, sections, values, xform};
use crate::error::{RenderError, key_error};
use openusd::sdf::Value;
use openusd::usd::Prim;
use rift_fx::Shot;
use rift_fx::rig::{Camera, LensKey, Projection};

/// Lens attributes that may change over the shot, followed at their time samples.
const LENS_ANIMATED: [&str; 4] = [
    "focalLength",
    "horizontalAperture",
    "fStop",
    "focusDistance",
];

/// Camera attributes read at the first frame (a time-sampled one is said).
const FIRST_FRAME: [&str; 2] = ["clippingRange", "projection"];

/// Reads the USD camera `shot` names into `shot.camera` (and its clipping range into
/// `[camera.clip]` where the shot gives none), within `budget` bytes; what it reads otherwise
/// than USD says, for the user. Nothing happens for a shot with a camera of its own.
pub fn read_camera(shot: &mut Shot, budget: Option<u64>) -> Result<Vec<String>, RenderError> {
    let Some(prim_path) = shot.camera_prim.clone().filter(|_| !shot.camera_read) else {
        return Ok(Vec::new());
    };
    let missing = || {
        key_error(
            &shot.source,
            "camera.usd",
            format!("no [[usd]] layer of the shot has a camera at {prim_path:?}"),
        )
    };
    let path = openusd::sdf::path(&prim_path)
        .ok()
        .filter(super::well_formed)
        .ok_or_else(missing)?;
    for section in sections(shot)? {
        let layer = section.layer(shot);
        let read = caught(&layer, || {
            let (stage, clock) = open_layer(&layer, (section.offset, shot.fps), budget)?;
            let prim = stage.prim(path.clone());
            let kind = prim.type_name().ok().flatten();
            if !prim.is_valid().unwrap_or(false)
                || kind.as_ref().map(|t| t.as_str()) != Some("Camera")
            {
                return Ok(None);
            }
            let source = source(shot, &section, clock, budget);
            read(shot, &prim, &source).map(Some)
        })?;
        if let Some((camera, clip, warnings)) = read {
            shot.camera = camera;
            if shot.render.camera_clip.is_none() {
                shot.render.camera_clip = clip;
            }
            shot.camera_read = true;
            return Ok(warnings);
        }
    }
    Err(missing())
}

/// Where the camera's samples are read: every time the shot's frames and shutter reach.
fn source<'a>(
    shot: &'a Shot,
    section: &'a Section,
    clock: super::Clock,
    budget: Option<u64>,
) -> Source<'a> {
    let [open, close] = shot.shutter_seconds();
    Source {
        layer: &section.layer,
        key: "camera.usd",
        shot_file: &shot.source,
        root: None,
        clock,
        span: [
            shot.time_of(shot.frames.first as f64) + open,
            shot.time_of(shot.frames.last as f64) + close,
        ],
        budget,
        shot_camera: None,
        ancestors: Default::default(),
    }
}

type Read = (Camera, Option<toml::Table>, Vec<String>);

/// The camera `prim`: its placement over the shot and its lens, and the clipping range as a
/// `[camera.clip]` table.
fn read(shot: &Shot, prim: &Prim, source: &Source) -> Result<Read, RenderError> {
    let path = prim.path().as_str();
    let samples = xform::world_samples(prim, source)?;
    let transform = xform::animated(source, &samples).ok_or_else(|| {
        source.error(
            path,
            Some("xformOp"),
            "its transform stretches or shears the camera, which rift cannot place".into(),
        )
    })?;
    let code = source.codes()[0];
    if let Some(Value::Token(t)) =
        values::value(prim, "projection", code).map_err(|e| source.read_error(path, e))?
        && t.as_str() != "perspective"
    {
        return Err(source.error(
            path,
            Some("projection"),
            format!("a {} camera: rift renders perspective cameras", t.as_str()),
        ));
    }
    let resolution = shot.camera.projection.resolution;
    let lens = lens_keys(prim, source, resolution)?;
    let first = lens[0];
    let camera = Camera {
        transform,
        projection: Projection {
            resolution,
            fov_y: first.fov_y,
            aperture_radius: first.aperture_radius,
            focus_distance: first.focus_distance,
        },
        // One key is a fixed lens.
        lens: if lens.len() > 1 { lens } else { Vec::new() },
    };
    Ok((camera, clip(prim, source, code)?, warnings(prim, source)))
}

/// The lens at each time any of its attributes is sampled within the shot (one key, at the
/// first frame, when none is), so a zoom or a focus pull follows the stage's own samples.
fn lens_keys(
    prim: &Prim,
    source: &Source,
    resolution: [u32; 2],
) -> Result<Vec<LensKey>, RenderError> {
    let mut codes = Vec::new();
    for name in LENS_ANIMATED {
        let times = (prim.attribute(name).time_sample_times())
            .map_err(|e| source.read_error(prim.path().as_str(), e))?;
        if !times.is_empty() {
            codes.extend(xform::within(&times, source.codes()));
        }
    }
    codes.sort_by(f64::total_cmp);
    codes.dedup();
    if codes.is_empty() {
        codes.push(source.codes()[0]);
    }
    codes
        .into_iter()
        .map(|code| lens_at(prim, source, code, resolution))
        .collect()
}

/// The lens `prim` gives at time code `code`: focal length over horizontal aperture for the
/// field of view; f-stop and focus distance for depth of field.
fn lens_at(
    prim: &Prim,
    source: &Source,
    code: f64,
    [w, h]: [u32; 2],
) -> Result<LensKey, RenderError> {
    let path = prim.path().as_str();
    let number = |name: &str, default: f64| -> Result<f64, RenderError> {
        let value = values::scalar_at(prim, name, code).map_err(|e| source.read_error(path, e))?;
        match value {
            None => Ok(default),
            Some(v) => values::number(&v).filter(|x| x.is_finite()).ok_or_else(|| {
                source.error(
                    path,
                    Some(name),
                    format!("expected a finite number, found {}", values::kind(&v)),
                )
            }),
        }
    };
    let focal = number("focalLength", 50.0)?;
    let aperture = number("horizontalAperture", 20.955)?;
    let f_stop = number("fStop", 0.0)?;
    let focus = number("focusDistance", 0.0)?;
    if focal <= 0.0 || aperture <= 0.0 {
        return Err(source.error(
            path,
            Some(if focal <= 0.0 {
                "focalLength"
            } else {
                "horizontalAperture"
            }),
            "expected a positive length".into(),
        ));
    }
    let half_x = 0.5 * aperture / focal;
    let aspect = w as f64 / h as f64;
    // Depth of field: the lens's opening, its focal length in scene units (USD gives tenths).
    let aperture_radius = match f_stop > 0.0 {
        true if focus <= 0.0 => {
            return Err(source.error(
                path,
                Some("focusDistance"),
                format!("fStop is {f_stop}, but the camera focuses nowhere (give focusDistance)"),
            ));
        }
        true => 0.5 * (0.1 * focal) / f_stop,
        false => 0.0,
    };
    Ok(LensKey {
        time: source.clock.seconds(code),
        fov_y: 2.0 * (half_x / aspect).atan(),
        aperture_radius,
        focus_distance: if focus > 0.0 { focus } else { 1.0 },
    })
}

/// The clipping range, where the camera authors one, as a `[camera.clip]` table.
fn clip(prim: &Prim, source: &Source, code: f64) -> Result<Option<toml::Table>, RenderError> {
    let path = prim.path().as_str();
    let value =
        values::value(prim, "clippingRange", code).map_err(|e| source.read_error(path, e))?;
    let range = match value {
        None => return Ok(None),
        Some(Value::Vec2f(v)) => [v.x as f64, v.y as f64],
        Some(Value::Vec2d(v)) => [v.x, v.y],
        Some(_) => {
            return Err(source.error(path, Some("clippingRange"), "expected two numbers".into()));
        }
    };
    if !(range[0] >= 0.0 && range[1] > range[0] && range[1].is_finite()) {
        return Err(source.error(
            path,
            Some("clippingRange"),
            format!(
                "({}, {}) is not a near and a farther far distance",
                range[0], range[1]
            ),
        ));
    }
    let mut table = toml::Table::new();
    table.insert("near".into(), range[0].into());
    table.insert("far".into(), range[1].into());
    Ok(Some(table))
}

/// Clipping or projection sampled over time: rift reads them at the first frame.
fn warnings(prim: &Prim, source: &Source) -> Vec<String> {
    let animated: Vec<&str> = FIRST_FRAME
        .into_iter()
        .filter(|name| {
            prim.attribute(*name)
                .time_sample_times()
                .is_ok_and(|t| xform::within(&t, source.codes()).len() > 1)
        })
        .collect();
    match animated.is_empty() {
        true => Vec::new(),
        false => vec![format!(
            "{}: <{}>: {} changes over the shot; rift reads it at the first frame",
            source.layer.display(),
            prim.path().as_str(),
            animated.join(", ")
        )],
    }
}
