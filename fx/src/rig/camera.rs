//! The shot camera: a keyframed frame looking down its local −Z with +Y up, and a projection.

use super::keyframes::AnimatedTransform;
use super::similarity::Similarity;
use glam::DVec3;

/// How the camera maps the scene to the image. Lengths are in meters of the camera's own space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projection {
    /// Image width and height in pixels.
    pub resolution: [u32; 2],
    /// Vertical field of view, radians.
    pub fov_y: f64,
    /// Radius of the lens aperture in meters; 0 is a pinhole.
    pub aperture_radius: f64,
    /// Distance to the plane in focus, meters.
    pub focus_distance: f64,
}

impl Projection {
    /// Width over height.
    pub fn aspect(&self) -> f64 {
        self.resolution[0] as f64 / self.resolution[1] as f64
    }

    /// tan(fov_y / 2): the half height of the image plane at unit distance.
    pub fn tan_half_fov_y(&self) -> f64 {
        (0.5 * self.fov_y).tan()
    }

    /// Focal length expressed in pixels (vertical).
    pub fn focal_pixels(&self) -> f64 {
        0.5 * self.resolution[1] as f64 / self.tan_half_fov_y()
    }

    /// The projection a camera carries through a teleport of uniform scale `scale`: angles stay,
    /// lengths (aperture, focus distance) scale, so the image through the portal is the same.
    pub fn scaled(&self, scale: f64) -> Self {
        Self {
            aperture_radius: self.aperture_radius * scale,
            focus_distance: self.focus_distance * scale,
            ..*self
        }
    }
}

/// A keyframed camera.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// Camera-to-world transform over time.
    pub transform: AnimatedTransform,
    pub projection: Projection,
}

impl Camera {
    /// World-space position at time `t`.
    pub fn position(&self, t: f64) -> DVec3 {
        self.transform.at(t).translation
    }

    /// True when a world point is inside the view frustum at time `t`, allowing `margin`
    /// (in units of the half image height) around the frame.
    pub fn sees(&self, point: DVec3, t: f64, margin: f64) -> bool {
        let local = self.transform.at(t).inverse().transform_point(point);
        if local.z >= 0.0 {
            return false;
        }
        let depth = -local.z;
        let half_h = self.projection.tan_half_fov_y() * depth;
        let half_w = half_h * self.projection.aspect();
        local.y.abs() <= half_h * (1.0 + margin) && local.x.abs() <= half_w + half_h * margin
    }

    /// The whole camera after a fixed teleport (the constraint solver's M_T = T·M_H at every
    /// time), with projection lengths scaled so the image matches.
    pub fn through(&self, teleport: &Similarity) -> Self {
        Self {
            transform: self.transform.then(teleport),
            projection: self.projection.scaled(teleport.scale),
        }
    }

    /// The camera's frame and projection at time `t` after a teleport: the constraint solver's
    /// M_T = T·M_H, with projection lengths scaled by the teleport's scale so the image matches.
    pub fn frame_through(&self, teleport: &Similarity, t: f64) -> (Similarity, Projection) {
        (
            teleport.compose(&self.transform.at(t)),
            self.projection.scaled(teleport.scale),
        )
    }
}
