//! The shot file as written: TOML, one file per shot, unknown keys rejected.
//!
//! ```toml
//! [shot]
//! name = "portal_pair"          # used in output file names
//! fps = 24.0
//! frames = [1001, 1096]         # first and last frame, inclusive
//! shutter = [-0.25, 0.25]       # open/close in frames relative to each frame
//!
//! [camera]
//! resolution = [1920, 1080]
//! fov_degrees = 40.0            # or: focal_length_mm = 35.0 (with sensor_width_mm, default 36)
//! fov_axis = "horizontal"       # "horizontal" (default), "vertical" or "smaller"
//! fstop = 2.8                   # or aperture_radius (meters); neither means a pinhole
//! focus_distance = 6.0          # meters
//! [camera.transform]            # a static pose, or keys: see "Poses" below
//! interpolation = "smooth"      # "smooth" (default), "linear" or "step"
//! keys = [
//!   { frame = 1001, position = [0.0, 1.6, 9.0], look_at = [0.0, 1.4, 0.0] },
//!   { frame = 1096, position = [3.0, 1.8, 7.0], look_at = [0.0, 1.4, 0.0] },
//! ]
//! # Or the pipeline's camera, a UsdGeomCamera of the shot's [[usd]] layers (its transform and
//! # its time samples, focal length over aperture, f-stop, focus distance and clipping range),
//! # in place of the lens keys and [camera.transform]; resolution stays here:
//! # usd = "/World/Cameras/shotCam"
//!
//! [fx]                          # ring tessellation (all optional)
//! chord_error_px = 0.25         # largest distance in pixels between a strand and its polyline
//! min_segments = 96             # per strand, whatever the screen size (a floor for far rings;
//!                               # a ring seen through an opening counts as far as it looks there)
//! max_segments = 16384
//!
//! [[portal]]
//! name = "A"
//! here = { position = [-2.0, 1.5, 0.0], rotation_degrees = [0.0, 20.0, 0.0], scale = 1.0 }
//! pair = "B"                    # or an explicit `there` pose, as `here`
//! [portal.ring]                 # omit for an opening without a ring
//! preset = "rift"               # a named look: "rift" (unstable: strands separate, flare and
//!                               # re-form), "calm" or "crackling"; every key below overrides it
//! radius = 1.0                  # mean radius in the opening's frame
//! band = 0.06                   # ring thickness: radial spread of the strands' base radii
//! strands = 24                  # required without a preset
//! counter_rotating = 0.5        # fraction of strands that turn the other way
//! width = 0.012                 # strand width (diameter)
//! width_variation = 0.5         # 0..1, noise modulation of width
//! speed_variation = 0.2         # 0..1, per-strand spread of angular speed
//! seed = 7
//! [portal.ring.noise]
//! amplitude = 0.035             # radial displacement
//! depth = 0.5                   # displacement along the opening's normal, relative to amplitude
//! frequency = 7.0               # features around the ring at the reference size
//! octaves = 3
//! roughness = 0.5               # amplitude gain per octave
//! evolution = 0.5               # how fast the shape changes (instability), noise units per second
//! size_compensation = 1.0       # 0: fixed frequency; 1: features keep their size on screen
//! [portal.ring.instability]     # optional (the rift and crackling presets have it)
//! separation = 1.2              # how far strands drift apart and back, in band widths
//! flare = 0.07                  # height of outward flares along strands, in radii
//! rate = 0.7                    # how fast drift and flares change, cycles per second
//! [portal.ring.speed]
//! turns_per_second = 0.4        # how fast the ring looks when it is `reference_size` on screen
//! reference_size = 0.25         # ring radius as a fraction of the image height
//! size_compensation = 1.0       # 0: fixed world speed; 1: rim speed constant on screen
//! min_visible_turn = 0.1        # turns the ring makes at least while it is on screen
//! [portal.ring.color]
//! ramp = [{ at = 0.0, color = [1.0, 0.25, 0.03] }, { at = 1.0, color = [1.0, 0.9, 0.7] }]
//! intensity = 12.0              # emitted radiance scale
//! intensity_variation = 0.6     # 0..1, noise modulation along the strand
//! flicker = 0.15                # 0..1, per-strand temporal flicker
//! flicker_rate = 9.0            # Hz
//! ```
//!
//! Poses (`camera.transform`, `portal.here`, `portal.there`, and each entry of their `keys`)
//! give `position`, an orientation as one of `rotation_degrees = [x, y, z]` (about X, then Y,
//! then Z), `quaternion = [x, y, z, w]` or `look_at` (with optional `up`; a camera looks down
//! its −Z, an opening's front is its +Z), and a uniform `scale`; or a whole 4×4 `matrix`
//! (row-major, column vectors, translation in the last column) that must be a similarity.
//!
//! The sections `render`, `object`, `material`, `medium`, `light`, `environment`, `camera.clip`,
//! `camera.stereo`, `portal.surface` and `portal.cull` belong to the renderer: `rift fx` keeps them unread.

use serde::Deserialize;

/// The whole file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShotFile {
    pub shot: ShotSection,
    pub camera: CameraSection,
    #[serde(default)]
    pub fx: FxSection,
    #[serde(default, rename = "portal")]
    pub portals: Vec<PortalSection>,
    /// Renderer-owned sections, parsed by rift-render.
    pub render: Option<toml::Table>,
    #[serde(default, rename = "object")]
    pub objects: Vec<toml::Table>,
    #[serde(default, rename = "material")]
    pub materials: Vec<toml::Table>,
    #[serde(default, rename = "medium")]
    pub media: Vec<toml::Table>,
    #[serde(default, rename = "light")]
    pub lights: Vec<toml::Table>,
    pub environment: Option<toml::Table>,
    /// USD layers whose sets, characters, lights and materials the renderer reads.
    #[serde(default)]
    pub usd: Vec<toml::Table>,
}

/// `[shot]`: timing.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShotSection {
    pub name: String,
    pub fps: f64,
    pub frames: [i64; 2],
    #[serde(default = "default_shutter")]
    pub shutter: [f64; 2],
}

fn default_shutter() -> [f64; 2] {
    [-0.25, 0.25]
}

/// `[camera]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSection {
    pub resolution: [i64; 2],
    pub fov_degrees: Option<f64>,
    pub focal_length_mm: Option<f64>,
    pub sensor_width_mm: Option<f64>,
    pub fov_axis: Option<FovAxis>,
    pub fstop: Option<f64>,
    pub aperture_radius: Option<f64>,
    pub focus_distance: Option<f64>,
    pub transform: Option<PoseSpec>,
    /// A UsdGeomCamera of the shot's `[[usd]]` layers, by prim path, in place of the lens and
    /// transform keys (the renderer reads it: `Shot::camera_prim`).
    pub usd: Option<String>,
    /// `[camera.clip]` and `[camera.stereo]` belong to the renderer.
    pub clip: Option<toml::Table>,
    pub stereo: Option<toml::Table>,
}

/// Which image axis `fov_degrees` spans.
#[derive(Debug, Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum FovAxis {
    Horizontal,
    Vertical,
    Smaller,
}

/// How keys are interpolated.
#[derive(Debug, Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum InterpolationSpec {
    Smooth,
    Linear,
    Step,
}

/// A pose, or (at the top level) a list of keyed poses.
#[derive(Debug, Deserialize, Default, Clone)]
#[serde(deny_unknown_fields)]
pub struct PoseSpec {
    /// Only inside `keys`.
    pub frame: Option<f64>,
    pub position: Option<[f64; 3]>,
    pub rotation_degrees: Option<[f64; 3]>,
    pub quaternion: Option<[f64; 4]>,
    pub look_at: Option<[f64; 3]>,
    pub up: Option<[f64; 3]>,
    pub scale: Option<f64>,
    pub matrix: Option<[[f64; 4]; 4]>,
    /// Only at the top level.
    pub interpolation: Option<InterpolationSpec>,
    /// Only at the top level.
    pub keys: Option<Vec<PoseSpec>>,
}

/// `[fx]`: tessellation settings.
#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct FxSection {
    pub chord_error_px: Option<f64>,
    pub min_segments: Option<i64>,
    pub max_segments: Option<i64>,
}

/// One `[[portal]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PortalSection {
    pub name: String,
    pub here: PoseSpec,
    pub there: Option<PoseSpec>,
    pub pair: Option<String>,
    pub ring: Option<RingSection>,
    /// Renderer-owned: shading signals and cull volumes.
    pub surface: Option<toml::Table>,
    #[serde(default)]
    pub cull: Vec<toml::Table>,
}

/// `[portal.ring]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RingSection {
    pub preset: Option<String>,
    pub radius: f64,
    pub band: Option<f64>,
    pub strands: Option<i64>,
    pub counter_rotating: Option<f64>,
    pub width: Option<f64>,
    pub width_variation: Option<f64>,
    pub speed_variation: Option<f64>,
    pub seed: Option<i64>,
    #[serde(default)]
    pub noise: NoiseSection,
    #[serde(default)]
    pub speed: SpeedSection,
    #[serde(default)]
    pub color: ColorSection,
    pub instability: Option<InstabilitySection>,
}

/// `[portal.ring.instability]`.
#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct InstabilitySection {
    pub separation: Option<f64>,
    pub flare: Option<f64>,
    pub rate: Option<f64>,
}

/// `[portal.ring.noise]`.
#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct NoiseSection {
    pub amplitude: Option<f64>,
    pub depth: Option<f64>,
    pub frequency: Option<f64>,
    pub octaves: Option<i64>,
    pub roughness: Option<f64>,
    pub evolution: Option<f64>,
    pub size_compensation: Option<f64>,
}

/// `[portal.ring.speed]`.
#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct SpeedSection {
    pub turns_per_second: Option<f64>,
    pub reference_size: Option<f64>,
    pub size_compensation: Option<f64>,
    pub min_visible_turn: Option<f64>,
}

/// `[portal.ring.color]`.
#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct ColorSection {
    pub ramp: Option<Vec<RampStop>>,
    pub intensity: Option<f64>,
    pub intensity_variation: Option<f64>,
    pub flicker: Option<f64>,
    pub flicker_rate: Option<f64>,
}

/// One colour-ramp stop.
#[derive(Debug, Deserialize, Clone, Copy)]
#[serde(deny_unknown_fields)]
pub struct RampStop {
    pub at: f64,
    pub color: [f64; 3],
}
