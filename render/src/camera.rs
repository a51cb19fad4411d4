//! The render camera: a pinhole or thin lens at the shot camera's pose, generating primary rays,
//! and the stereo eye pair derived from it.
//!
//! Stereo eyes are off-axis (parallel) cameras: each sits half the interaxial distance to one
//! side along the camera's X and looks the same way, with its film shifted so that both frame
//! the same rectangle on the convergence plane. Points on that plane have zero parallax, nearer
//! points come out of the screen and farther points go into it, and there is no keystone
//! distortion (which toed-in eyes would add).

use crate::sampling::concentric_disk;
use glam::{Mat4, Vec2, Vec3, Vec4};
use rift_fx::rig::Camera as ShotCamera;

/// A camera frozen at one time (motion blur evaluates the shot camera per ray time).
#[derive(Clone, Copy, Debug)]
pub struct Lens {
    pub position: Vec3,
    /// Camera axes in world space: right, up, and backward (the camera looks down −`back`).
    pub right: Vec3,
    pub up: Vec3,
    pub back: Vec3,
    pub tan_half_fov_y: f32,
    pub aspect: f32,
    pub aperture_radius: f32,
    pub focus_distance: f32,
    /// Horizontal film shift, in units of the tangent of the view angle (stereo eyes).
    pub shift: f32,
}

/// A left/right eye pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stereo {
    /// Distance between the eyes, meters.
    pub interaxial: f32,
    /// Distance to the plane of zero parallax, meters.
    pub convergence: f32,
}

/// One eye of a stereo pair.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Eye {
    Left,
    Right,
}

impl Eye {
    pub const BOTH: [Eye; 2] = [Eye::Left, Eye::Right];

    /// The view name images carry ("left", "right").
    pub fn name(self) -> &'static str {
        match self {
            Eye::Left => "left",
            Eye::Right => "right",
        }
    }
}

impl Lens {
    /// The shot camera at time `t`.
    pub fn at(camera: &ShotCamera, t: f64) -> Self {
        let frame = camera.transform.at(t);
        let axis = |v: glam::DVec3| frame.transform_direction(v).as_vec3().normalize();
        let p = &camera.projection;
        Self {
            position: frame.translation.as_vec3(),
            right: axis(glam::DVec3::X),
            up: axis(glam::DVec3::Y),
            back: axis(glam::DVec3::Z),
            tan_half_fov_y: p.tan_half_fov_y() as f32,
            aspect: p.aspect() as f32,
            aperture_radius: p.aperture_radius as f32,
            focus_distance: p.focus_distance as f32,
            shift: 0.0,
        }
    }

    /// This camera as `eye` of `stereo`: moved half the interaxial distance along its X, with
    /// the film shifted to converge on the convergence plane.
    pub fn eye(mut self, stereo: &Stereo, eye: Eye) -> Self {
        let offset = match eye {
            Eye::Left => -0.5 * stereo.interaxial,
            Eye::Right => 0.5 * stereo.interaxial,
        };
        self.position += self.right * offset;
        self.shift = -offset / stereo.convergence;
        self
    }

    /// A primary ray through film position `ndc` (x, y in [0, 1], y down) using `lens_u` for the
    /// aperture: (origin, unit direction).
    pub fn ray(&self, ndc: Vec2, lens_u: Vec2) -> (Vec3, Vec3) {
        let x = (2.0 * ndc.x - 1.0) * self.tan_half_fov_y * self.aspect + self.shift;
        let y = (1.0 - 2.0 * ndc.y) * self.tan_half_fov_y;
        let dir = (self.right * x + self.up * y - self.back).normalize();
        if self.aperture_radius <= 0.0 {
            return (self.position, dir);
        }
        // Thin lens: every ray through the film point meets the pinhole ray on the focus plane.
        let focus_t = self.focus_distance / dir.dot(-self.back);
        let focus = self.position + dir * focus_t;
        let d = concentric_disk(lens_u) * self.aperture_radius;
        let origin = self.position + self.right * d.x + self.up * d.y;
        (origin, (focus - origin).normalize())
    }

    /// World-to-camera matrix in the layout OpenEXR's `worldToCamera` uses (Imath: row
    /// vectors, the translation in elements 12–14); the camera looks down its −Z.
    pub fn world_to_camera(&self) -> [f32; 16] {
        self.view().to_cols_array()
    }

    /// World-to-NDC matrix in the same layout: x/w and y/w run from −1 to 1 across the frame
    /// (y up) and w is the depth in front of the camera.
    pub fn world_to_ndc(&self) -> [f32; 16] {
        let sx = 1.0 / (self.tan_half_fov_y * self.aspect);
        let sy = 1.0 / self.tan_half_fov_y;
        // The film shift moves x/w by −shift·sx (w = −z).
        let projection = Mat4::from_cols(
            Vec4::new(sx, 0.0, 0.0, 0.0),
            Vec4::new(0.0, sy, 0.0, 0.0),
            Vec4::new(sx * self.shift, 0.0, 0.0, -1.0),
            Vec4::new(0.0, 0.0, 1.0, 0.0),
        );
        (projection * self.view()).to_cols_array()
    }

    /// World-to-camera as a column-vector matrix.
    fn view(&self) -> Mat4 {
        Mat4::from_cols(
            self.right.extend(0.0),
            self.up.extend(0.0),
            self.back.extend(0.0),
            self.position.extend(1.0),
        )
        .inverse()
    }
}

/// Clipping of camera rays that have not passed a portal: a near and a far depth along the view
/// axis and any number of camera-space half-spaces. Teleported rays are never clipped, so
/// geometry culled in front of the camera stays visible through openings.
#[derive(Clone, Debug, PartialEq)]
pub struct Clip {
    pub near: f32,
    pub far: f32,
    /// Camera-space planes [a, b, c, d]: a point is kept where a·x + b·y + c·z + d ≥ 0.
    pub planes: Vec<Vec4>,
    /// The same in world space (planes that stay put while the camera moves).
    pub world_planes: Vec<Vec4>,
}

impl Default for Clip {
    fn default() -> Self {
        Self {
            near: 0.0,
            far: f32::INFINITY,
            planes: Vec::new(),
            world_planes: Vec::new(),
        }
    }
}

impl Clip {
    /// True when nothing is clipped.
    pub fn is_none(&self) -> bool {
        *self == Self::default()
    }

    /// The interval of ray parameters of `origin + t·dir` (a camera ray of `lens`) that stays
    /// visible, or `None` when the whole ray is clipped. The kept region is convex (an
    /// intersection of half-spaces), so it is one interval.
    pub fn interval(&self, lens: &Lens, origin: Vec3, dir: Vec3) -> Option<(f32, f32)> {
        let local = |v: Vec3| Vec3::new(v.dot(lens.right), v.dot(lens.up), v.dot(lens.back));
        let o = local(origin - lens.position);
        let d = local(dir);
        let (mut lo, mut hi) = (0.0f32, f32::INFINITY);
        // Keeps the t where at0 + slope·t ≥ 0.
        let mut keep = |at0: f32, slope: f32| {
            if slope > 0.0 {
                lo = lo.max(-at0 / slope);
            } else if slope < 0.0 {
                hi = hi.min(-at0 / slope);
            } else if at0 < 0.0 {
                hi = -1.0;
            }
        };
        // Depth is −z: near ≤ −z ≤ far.
        keep(-o.z - self.near, -d.z);
        if self.far.is_finite() {
            keep(o.z + self.far, d.z);
        }
        for p in &self.planes {
            keep(p.truncate().dot(o) + p.w, p.truncate().dot(d));
        }
        for p in &self.world_planes {
            keep(p.truncate().dot(origin) + p.w, p.truncate().dot(dir));
        }
        (lo < hi).then_some((lo, hi))
    }
}
