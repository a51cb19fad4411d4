//! The shot: one TOML file that is the single source of truth for timing, camera, portal rigs and
//! ring looks (syntax in [`schema`]). [`Shot::load`] parses and validates it; every problem is an
//! [`FxError`] naming the file, the key path and, where known, the line.

pub mod check;
pub mod locate;
pub mod pose;
pub mod schema;

use crate::error::{FxError, Invalid};
use crate::rig::{AnimatedTransform, Camera, Opening, Projection, Rig, Similarity, ThereFrame};
use crate::ring::look::{ColorLook, NoiseLook, SpeedLook};
use crate::ring::{ColorRamp, RingLook};
use pose::Facing;
use schema::{
    ColorSection, FovAxis, NoiseSection, PortalSection, RingSection, ShotFile, SpeedSection,
};
use std::path::{Path, PathBuf};

/// An inclusive range of whole frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameRange {
    pub first: i64,
    pub last: i64,
}

impl FrameRange {
    /// Parses `1001` or `1001-1096` (negative frames as `-5--1`).
    pub fn parse(text: &str) -> Result<Self, String> {
        let bad = || format!("expected a frame like 1001 or a range like 1001-1096, got {text:?}");
        let text = text.trim();
        // Split at a '-' that follows a digit, so a leading minus stays with the number.
        let split = text
            .char_indices()
            .skip(1)
            .find(|&(i, c)| c == '-' && text.as_bytes()[i - 1].is_ascii_digit())
            .map(|(i, _)| i);
        let (a, b) = match split {
            Some(i) => (&text[..i], &text[i + 1..]),
            None => (text, text),
        };
        let first: i64 = a.trim().parse().map_err(|_| bad())?;
        let last: i64 = b.trim().parse().map_err(|_| bad())?;
        if last < first {
            return Err(format!("the range {text:?} ends before it starts"));
        }
        Ok(Self { first, last })
    }

    /// The frames, in order.
    pub fn iter(&self) -> impl Iterator<Item = i64> + Clone {
        self.first..=self.last
    }

    /// How many frames.
    pub fn len(&self) -> usize {
        (self.last - self.first + 1) as usize
    }

    /// Never true: a range has at least one frame.
    pub fn is_empty(&self) -> bool {
        false
    }
}

/// Ring tessellation settings (`[fx]`).
#[derive(Clone, Debug, PartialEq)]
pub struct FxSettings {
    pub chord_error_px: f64,
    pub min_segments: u32,
    pub max_segments: u32,
}

impl Default for FxSettings {
    fn default() -> Self {
        Self {
            chord_error_px: 0.25,
            min_segments: 96,
            max_segments: 16384,
        }
    }
}

/// Sections owned by the renderer, kept as TOML until rift-render reads them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderSections {
    pub render: Option<toml::Table>,
    pub objects: Vec<toml::Table>,
    pub materials: Vec<toml::Table>,
    pub media: Vec<toml::Table>,
    pub lights: Vec<toml::Table>,
    pub environment: Option<toml::Table>,
    /// `[[usd]]`: layers of the pipeline's sets, characters, lights and materials.
    pub usd: Vec<toml::Table>,
    /// `portal[i].surface`, one entry per opening.
    pub portal_surfaces: Vec<Option<toml::Table>>,
    /// `portal[i].cull`, one list per opening.
    pub portal_culls: Vec<Vec<toml::Table>>,
    /// `camera.clip`.
    pub camera_clip: Option<toml::Table>,
    /// `camera.stereo`.
    pub camera_stereo: Option<toml::Table>,
}

/// A validated shot.
#[derive(Clone, Debug)]
pub struct Shot {
    /// The file it came from (for messages).
    pub source: PathBuf,
    pub name: String,
    pub fps: f64,
    pub frames: FrameRange,
    /// Shutter open and close, in frames relative to each frame.
    pub shutter: [f64; 2],
    pub camera: Camera,
    /// The UsdGeomCamera `[camera] usd` names, whose lens and transform the renderer reads into
    /// `camera` (`rift_render::scene::usd::camera`); until then `camera` is a stand-in and
    /// `camera_read` is false.
    pub camera_prim: Option<String>,
    pub camera_read: bool,
    pub rig: Rig,
    /// The ring look of each opening (same order as `rig.openings`), if it has a ring.
    pub rings: Vec<Option<RingLook>>,
    pub fx: FxSettings,
    pub render: RenderSections,
}

impl Shot {
    /// Reads and validates a shot file.
    pub fn load(path: &Path) -> Result<Self, FxError> {
        let text = crate::io::read_to_string(path).map_err(|cause| FxError::Read {
            file: path.to_owned(),
            cause,
        })?;
        Self::parse(&text, path)
    }

    /// Validates shot text; `path` is only used in messages.
    pub fn parse(text: &str, path: &Path) -> Result<Self, FxError> {
        let de = toml::Deserializer::parse(text).map_err(|e| FxError::Syntax {
            file: path.to_owned(),
            message: crate::error::shorten_long_lines(e.to_string().trim_end(), 160),
        })?;
        let raw: ShotFile = serde_path_to_error::deserialize(de).map_err(|e| {
            let line = e
                .inner()
                .span()
                .map(|s| format!(" (line {})", locate::line_at(text, s.start)))
                .unwrap_or_default();
            let key = match e.path().to_string() {
                p if p == "." => "(top level)".to_owned(),
                p => p,
            };
            FxError::Key {
                file: path.to_owned(),
                key,
                message: format!("{}{line}", e.inner().message()),
            }
        })?;
        from_raw(raw, path).map_err(|e| e.in_text(path, text))
    }

    /// Time in seconds of a (possibly fractional) frame.
    pub fn time_of(&self, frame: f64) -> f64 {
        frame / self.fps
    }

    /// Shutter open and close offsets from a frame's time, in seconds.
    pub fn shutter_seconds(&self) -> [f64; 2] {
        [self.shutter[0] / self.fps, self.shutter[1] / self.fps]
    }
}

fn from_raw(raw: ShotFile, path: &Path) -> Result<Shot, Invalid> {
    let s = &raw.shot;
    let name = check::name("shot.name", &s.name)?;
    let fps = check::positive("shot.fps", s.fps)?;
    if s.frames[1] < s.frames[0] {
        return Err(Invalid::new(
            "shot.frames",
            "expected [first, last] with last ≥ first",
        ));
    }
    let frames = FrameRange {
        first: s.frames[0],
        last: s.frames[1],
    };
    let shutter = [
        check::within("shot.shutter[0]", s.shutter[0], -1.0, 1.0, false)?,
        check::within("shot.shutter[1]", s.shutter[1], -1.0, 1.0, false)?,
    ];
    if shutter[1] < shutter[0] {
        return Err(Invalid::new(
            "shot.shutter",
            "the shutter closes before it opens",
        ));
    }

    let camera = camera(&raw.camera, fps)?;
    let camera_prim = raw.camera.usd.clone();
    let fx = fx_settings(&raw.fx)?;
    let (rig, rings) = rig(&raw.portals, fps)?;
    let render = RenderSections {
        render: raw.render,
        objects: raw.objects,
        materials: raw.materials,
        media: raw.media,
        lights: raw.lights,
        environment: raw.environment,
        usd: raw.usd,
        portal_surfaces: raw.portals.iter().map(|p| p.surface.clone()).collect(),
        portal_culls: raw.portals.into_iter().map(|p| p.cull).collect(),
        camera_clip: raw.camera.clip,
        camera_stereo: raw.camera.stereo,
    };
    Ok(Shot {
        source: path.to_owned(),
        name,
        fps,
        frames,
        shutter,
        camera_read: camera_prim.is_none(),
        camera,
        camera_prim,
        rig,
        rings,
        fx,
        render,
    })
}

fn camera(c: &schema::CameraSection, fps: f64) -> Result<Camera, Invalid> {
    if let Some(prim) = &c.usd {
        return usd_camera_stand_in(c, prim);
    }
    let [w, h] = resolution(c)?;
    let aspect = w as f64 / h as f64;
    let sensor_mm = match c.sensor_width_mm {
        Some(v) => check::positive("camera.sensor_width_mm", v)?,
        None => 36.0,
    };
    // Horizontal field of view and focal length in mm, from whichever was given.
    let (fov_x, focal_mm) = match (c.fov_degrees, c.focal_length_mm) {
        (Some(_), Some(_)) => {
            return Err(Invalid::new(
                "camera",
                "give `fov_degrees` or `focal_length_mm`, not both",
            ));
        }
        (None, None) => {
            return Err(Invalid::new(
                "camera",
                "missing field `fov_degrees` (or `focal_length_mm`)",
            ));
        }
        (Some(deg), None) => {
            let deg = check::within("camera.fov_degrees", deg, 1e-3, 179.0, false)?;
            let axis = c.fov_axis.unwrap_or(FovAxis::Horizontal);
            let along_x = match axis {
                FovAxis::Horizontal => true,
                FovAxis::Vertical => false,
                FovAxis::Smaller => w <= h,
            };
            let half = (0.5 * deg.to_radians()).tan();
            let half_x = if along_x { half } else { half * aspect };
            let fov_x = 2.0 * half_x.atan();
            (fov_x, 0.5 * sensor_mm / half_x)
        }
        (None, Some(f)) => {
            if c.fov_axis.is_some() {
                return Err(Invalid::new(
                    "camera.fov_axis",
                    "`fov_axis` goes with `fov_degrees`",
                ));
            }
            let f = check::positive("camera.focal_length_mm", f)?;
            (2.0 * (0.5 * sensor_mm / f).atan(), f)
        }
    };
    let fov_y = 2.0 * ((0.5 * fov_x).tan() / aspect).atan();
    let aperture_radius = match (c.fstop, c.aperture_radius) {
        (Some(_), Some(_)) => {
            return Err(Invalid::new(
                "camera",
                "give `fstop` or `aperture_radius`, not both",
            ));
        }
        (Some(n), None) => 0.5 * focal_mm * 1e-3 / check::positive("camera.fstop", n)?,
        (None, Some(r)) => check::non_negative("camera.aperture_radius", r)?,
        (None, None) => 0.0,
    };
    let focus_distance = match c.focus_distance {
        Some(d) => check::positive("camera.focus_distance", d)?,
        None if aperture_radius > 0.0 => {
            return Err(Invalid::new(
                "camera.focus_distance",
                "a lens with an aperture needs `focus_distance`",
            ));
        }
        None => 1.0,
    };
    let Some(spec) = &c.transform else {
        return Err(Invalid::new(
            "camera",
            "missing field `transform` (or `usd`, a camera of the shot's USD layers)",
        ));
    };
    let transform = pose::animated("camera.transform", spec, Facing::NegativeZ, fps)?;
    Ok(Camera {
        transform,
        projection: Projection {
            resolution: [w, h],
            fov_y,
            aperture_radius,
            focus_distance,
        },
        lens: Vec::new(),
    })
}

/// `camera.resolution`, checked.
fn resolution(c: &schema::CameraSection) -> Result<[u32; 2], Invalid> {
    let side = |i: usize| {
        check::integer(
            &format!("camera.resolution[{i}]"),
            c.resolution[i],
            1,
            65536,
            "a positive integer",
        )
    };
    Ok([side(0)?, side(1)?])
}

/// The camera of a shot whose `[camera]` names a USD camera, until the renderer reads it: the
/// resolution, at the origin with a 40° lens. Keys the USD camera gives are refused here.
fn usd_camera_stand_in(c: &schema::CameraSection, prim: &str) -> Result<Camera, Invalid> {
    let given = [
        ("fov_degrees", c.fov_degrees.is_some()),
        ("focal_length_mm", c.focal_length_mm.is_some()),
        ("sensor_width_mm", c.sensor_width_mm.is_some()),
        ("fov_axis", c.fov_axis.is_some()),
        ("fstop", c.fstop.is_some()),
        ("aperture_radius", c.aperture_radius.is_some()),
        ("focus_distance", c.focus_distance.is_some()),
        ("transform", c.transform.is_some()),
    ];
    if let Some((key, _)) = given.iter().find(|(_, g)| *g) {
        return Err(Invalid::new(
            format!("camera.{key}"),
            format!("the USD camera {prim:?} gives it; leave it out or leave out `usd`"),
        ));
    }
    if !prim.starts_with('/') {
        return Err(Invalid::new(
            "camera.usd",
            format!("{prim:?} is not an absolute prim path (`/World/Camera`)"),
        ));
    }
    let [w, h] = resolution(c)?;
    let aspect = w as f64 / h as f64;
    Ok(Camera {
        transform: AnimatedTransform::constant(Similarity::IDENTITY),
        projection: Projection {
            resolution: [w, h],
            fov_y: 2.0 * ((20f64).to_radians().tan() / aspect).atan(),
            aperture_radius: 0.0,
            focus_distance: 1.0,
        },
        lens: Vec::new(),
    })
}

fn fx_settings(f: &schema::FxSection) -> Result<FxSettings, Invalid> {
    let d = FxSettings::default();
    let chord_error_px = match f.chord_error_px {
        Some(v) => check::positive("fx.chord_error_px", v)?,
        None => d.chord_error_px,
    };
    let min_segments = match f.min_segments {
        Some(v) => check::integer("fx.min_segments", v, 3, 1 << 20, "an integer ≥ 3")?,
        None => d.min_segments,
    };
    let max_segments = match f.max_segments {
        Some(v) => check::integer(
            "fx.max_segments",
            v,
            min_segments as i64,
            1 << 20,
            "an integer ≥ fx.min_segments",
        )?,
        None => d.max_segments.max(min_segments),
    };
    Ok(FxSettings {
        chord_error_px,
        min_segments,
        max_segments,
    })
}

/// The most openings a shot may hold: far beyond any shot, and what keeps the name checks
/// (each against all before it), the renderer's per-pair measurements and its 16-bit opening
/// indices within bounds on hostile input.
pub const MAX_OPENINGS: usize = 4096;

fn rig(portals: &[PortalSection], fps: f64) -> Result<(Rig, Vec<Option<RingLook>>), Invalid> {
    if portals.len() > MAX_OPENINGS {
        return Err(Invalid::new(
            format!("portal[{MAX_OPENINGS}]"),
            format!(
                "a shot holds at most {MAX_OPENINGS} openings, this one {}",
                portals.len()
            ),
        ));
    }
    let mut names: Vec<String> = Vec::with_capacity(portals.len());
    for (i, p) in portals.iter().enumerate() {
        let n = check::name(&format!("portal[{i}].name"), &p.name)?;
        if names.contains(&n) {
            return Err(Invalid::new(
                format!("portal[{i}].name"),
                format!("another opening is already called {n:?}"),
            ));
        }
        names.push(n);
    }
    // Resolve pairings first: a pairing may be written on either side, or both.
    let mut partner: Vec<Option<usize>> = vec![None; portals.len()];
    for (i, p) in portals.iter().enumerate() {
        let Some(target) = &p.pair else { continue };
        let key = format!("portal[{i}].pair");
        if p.there.is_some() {
            return Err(Invalid::new(key, "give `pair` or `there`, not both"));
        }
        let j = names
            .iter()
            .position(|n| n == target)
            .ok_or_else(|| Invalid::new(&key, format!("no opening is called {target:?}")))?;
        if j == i {
            return Err(Invalid::new(key, "an opening cannot pair with itself"));
        }
        if portals[j].there.is_some() {
            return Err(Invalid::new(
                key,
                format!(
                    "{target:?} has an explicit `there`; a paired opening's there frame comes from its partner"
                ),
            ));
        }
        for (a, b) in [(i, j), (j, i)] {
            match partner[a] {
                Some(existing) if existing != b => {
                    return Err(Invalid::new(
                        key,
                        format!(
                            "{:?} is already paired with {:?}",
                            names[a], names[existing]
                        ),
                    ));
                }
                _ => partner[a] = Some(b),
            }
        }
    }

    let mut openings = Vec::with_capacity(portals.len());
    let mut rings = Vec::with_capacity(portals.len());
    for (i, p) in portals.iter().enumerate() {
        let here = pose::animated(
            &format!("portal[{i}].here"),
            &p.here,
            Facing::PositiveZ,
            fps,
        )?;
        let there = match (&p.there, partner[i]) {
            (Some(t), _) => ThereFrame::Explicit(pose::animated(
                &format!("portal[{i}].there"),
                t,
                Facing::PositiveZ,
                fps,
            )?),
            (None, Some(j)) => ThereFrame::Paired(j),
            (None, None) => {
                return Err(Invalid::new(
                    format!("portal[{i}]"),
                    "an opening needs `pair` or `there` (where it leads)",
                ));
            }
        };
        openings.push(Opening {
            name: names[i].clone(),
            here,
            there,
        });
        rings.push(match &p.ring {
            Some(r) => Some(ring_look(&format!("portal[{i}].ring"), r)?),
            None => None,
        });
    }
    Ok((Rig { openings }, rings))
}

/// `[portal.ring.instability]` over the look's own (a preset's, or none): a preset without
/// instability has no such keys to override.
fn instability(key: &str, r: &RingSection, look: &mut RingLook) -> Result<(), Invalid> {
    let Some(section) = &r.instability else {
        return Ok(());
    };
    let k = |name: &str| format!("{key}.{name}");
    let base = match (&look.instability, &r.preset) {
        (Some(own), _) => own.clone(),
        (None, Some(name)) => {
            return Err(Invalid::new(
                key,
                format!(
                    "the {name:?} preset has no instability to override; use the \"rift\" or \
                     \"crackling\" preset, or no preset"
                ),
            ));
        }
        (None, None) => crate::ring::InstabilityLook {
            separation: 0.0,
            flare: 0.0,
            rate: 1.0,
        },
    };
    let mut own = base;
    set(
        &mut own.separation,
        section.separation,
        &k("separation"),
        |key, v| check::within(key, v, 0.0, 10.0, false),
    )?;
    set(&mut own.flare, section.flare, &k("flare"), |key, v| {
        check::within(key, v, 0.0, 1.0, false)
    })?;
    set(&mut own.rate, section.rate, &k("rate"), |key, v| {
        check::within(key, v, 0.0, 100.0, false)
    })?;
    look.instability = Some(own);
    Ok(())
}

/// A `[portal.ring]` section (at `key`) as a ring look: its preset (or the defaults), every key
/// given over it, and a check that the strands stay clear of the centre.
fn ring_look(key: &str, r: &RingSection) -> Result<RingLook, Invalid> {
    let k = |name: &str| format!("{key}.{name}");
    let mut look = base_look(key, r)?;
    if let Some(strands) = r.strands {
        look.strands = check::integer(&k("strands"), strands, 1, 100_000, "a positive integer")?;
    }
    instability(&k("instability"), r, &mut look)?;
    shape_keys(key, r, &mut look)?;
    noise_keys(&k("noise"), &r.noise, &mut look.noise)?;
    speed_keys(&k("speed"), &r.speed, &mut look.speed)?;
    color_keys(&k("color"), &r.color, &mut look.color)?;
    // The strands must stay clear of the centre whatever the noise does.
    let inner = look.min_radius() - 0.5 * look.width * (1.0 + look.width_variation);
    if inner <= 0.0 {
        return Err(Invalid::new(
            k("radius"),
            format!(
                "the ring would cross its centre: radius {} is not larger than band/2 + noise.amplitude + width ({:.4})",
                look.radius,
                look.radius - inner
            ),
        ));
    }
    Ok(look)
}

/// The look the section's keys apply over: its `preset`, scaled to its radius, or the defaults
/// (which need `strands`).
fn base_look(key: &str, r: &RingSection) -> Result<RingLook, Invalid> {
    let k = |name: &str| format!("{key}.{name}");
    let radius = check::positive_length(&k("radius"), r.radius)?;
    match &r.preset {
        Some(name) => crate::ring::presets::preset(name, radius).ok_or_else(|| {
            Invalid::new(
                k("preset"),
                format!(
                    "no ring preset is called {name:?}; known: {}",
                    crate::ring::presets::NAMES.join(", ")
                ),
            )
        }),
        None if r.strands.is_none() => Err(Invalid::new(
            k("strands"),
            "missing: give `strands`, or a `preset` that sets it",
        )),
        None => Ok(RingLook::with_defaults(radius, 1)),
    }
}

/// A number in [0, 1] at `key`.
fn unit(key: &str, v: f64) -> Result<f64, Invalid> {
    check::within(key, v, 0.0, 1.0, false)
}

/// The band, counter-rotation, width and its variation, speed variation and seed.
fn shape_keys(key: &str, r: &RingSection, look: &mut RingLook) -> Result<(), Invalid> {
    let k = |name: &str| format!("{key}.{name}");
    let unit_open = |key: &str, v: f64| check::within(key, v, 0.0, 1.0, true);
    set(
        &mut look.band,
        r.band,
        &k("band"),
        check::non_negative_length,
    )?;
    set(
        &mut look.counter_rotating,
        r.counter_rotating,
        &k("counter_rotating"),
        unit,
    )?;
    set(
        &mut look.width,
        r.width,
        &k("width"),
        check::positive_length,
    )?;
    set(
        &mut look.width_variation,
        r.width_variation,
        &k("width_variation"),
        unit_open,
    )?;
    set(
        &mut look.speed_variation,
        r.speed_variation,
        &k("speed_variation"),
        unit_open,
    )?;
    if let Some(seed) = r.seed {
        look.seed = check::integer(&k("seed"), seed, 0, u32::MAX as i64, "an integer ≥ 0")?;
    }
    Ok(())
}

/// `[portal.ring.noise]` (at `key`) over `noise`.
fn noise_keys(key: &str, n: &NoiseSection, noise: &mut NoiseLook) -> Result<(), Invalid> {
    let k = |name: &str| format!("{key}.{name}");
    let roughness = |key: &str, v: f64| check::within(key, v, 1e-6, 1.0, false);
    let amplitude = k("amplitude");
    set(
        &mut noise.amplitude,
        n.amplitude,
        &amplitude,
        check::non_negative_length,
    )?;
    set(&mut noise.depth, n.depth, &k("depth"), check::non_negative)?;
    set(
        &mut noise.frequency,
        n.frequency,
        &k("frequency"),
        check::positive,
    )?;
    if let Some(o) = n.octaves {
        noise.octaves = check::integer(&k("octaves"), o, 1, 12, "an integer from 1")?;
    }
    set(
        &mut noise.roughness,
        n.roughness,
        &k("roughness"),
        roughness,
    )?;
    set(
        &mut noise.evolution,
        n.evolution,
        &k("evolution"),
        check::non_negative,
    )?;
    let compensation = k("size_compensation");
    set(
        &mut noise.size_compensation,
        n.size_compensation,
        &compensation,
        unit,
    )
}

/// `[portal.ring.speed]` (at `key`) over `speed`.
fn speed_keys(key: &str, s: &SpeedSection, speed: &mut SpeedLook) -> Result<(), Invalid> {
    let k = |name: &str| format!("{key}.{name}");
    let turns = k("turns_per_second");
    set(
        &mut speed.turns_per_second,
        s.turns_per_second,
        &turns,
        check::finite,
    )?;
    let size = k("reference_size");
    set(
        &mut speed.reference_size,
        s.reference_size,
        &size,
        check::positive,
    )?;
    let compensation = k("size_compensation");
    set(
        &mut speed.size_compensation,
        s.size_compensation,
        &compensation,
        unit,
    )?;
    let least = k("min_visible_turn");
    set(
        &mut speed.min_visible_turn,
        s.min_visible_turn,
        &least,
        check::non_negative,
    )
}

/// `[portal.ring.color]` (at `key`) over `color`.
fn color_keys(key: &str, c: &ColorSection, color: &mut ColorLook) -> Result<(), Invalid> {
    let k = |name: &str| format!("{key}.{name}");
    if let Some(stops) = &c.ramp {
        color.ramp = ramp(&k("ramp"), stops)?;
    }
    set(
        &mut color.intensity,
        c.intensity,
        &k("intensity"),
        check::non_negative,
    )?;
    let variation = k("intensity_variation");
    set(
        &mut color.intensity_variation,
        c.intensity_variation,
        &variation,
        unit,
    )?;
    set(&mut color.flicker, c.flicker, &k("flicker"), unit)?;
    let rate = k("flicker_rate");
    set(
        &mut color.flicker_rate,
        c.flicker_rate,
        &rate,
        check::non_negative,
    )
}

/// Overwrites `target` (holding its default) with `value` when given, after `valid` accepts it.
fn set(
    target: &mut f64,
    value: Option<f64>,
    key: &str,
    valid: impl Fn(&str, f64) -> Result<f64, Invalid>,
) -> Result<(), Invalid> {
    if let Some(v) = value {
        *target = valid(key, v)?;
    }
    Ok(())
}

fn ramp(key: &str, stops: &[schema::RampStop]) -> Result<ColorRamp, Invalid> {
    if stops.is_empty() {
        return Err(Invalid::new(key, "expected at least one stop"));
    }
    let mut out = Vec::with_capacity(stops.len());
    for (i, s) in stops.iter().enumerate() {
        let at = check::within(&format!("{key}[{i}].at"), s.at, 0.0, 1.0, false)?;
        if out.last().is_some_and(|&(prev, _)| at <= prev) {
            return Err(Invalid::new(
                format!("{key}[{i}].at"),
                "stops must be in increasing order",
            ));
        }
        out.push((at, check::color(&format!("{key}[{i}].color"), s.color)?));
    }
    Ok(ColorRamp { stops: out })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_ranges() {
        assert_eq!(
            FrameRange::parse("1001").unwrap(),
            FrameRange {
                first: 1001,
                last: 1001
            }
        );
        assert_eq!(FrameRange::parse("1001-1096").unwrap().len(), 96);
        assert_eq!(
            FrameRange::parse("-5--1").unwrap(),
            FrameRange {
                first: -5,
                last: -1
            }
        );
        assert!(FrameRange::parse("1005-1001").is_err());
        assert!(FrameRange::parse("abc").is_err());
        assert!(FrameRange::parse("").is_err());
    }
}
