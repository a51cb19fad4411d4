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

/// The lens at one time of a shot whose lens changes (a zoom, a focus pull, an iris change).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LensKey {
    /// Shot time, seconds.
    pub time: f64,
    /// As [`Projection`]'s.
    pub fov_y: f64,
    pub aperture_radius: f64,
    pub focus_distance: f64,
}

/// A keyframed camera.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// Camera-to-world transform over time.
    pub transform: AnimatedTransform,
    /// The projection, or where `lens` has keys the first key's with the camera's resolution.
    pub projection: Projection,
    /// The lens over the shot by time, where it changes; empty when it is fixed.
    pub lens: Vec<LensKey>,
}

impl Camera {
    /// The projection at time `t`: between lens keys, the focal length (the reciprocal of the
    /// field of view's half tangent), aperture and focus distance each move linearly, as a
    /// USD camera's attributes interpolate; before the first key and after the last, held.
    pub fn projection_at(&self, t: f64) -> Projection {
        let keys = &self.lens;
        let (Some(first), Some(last)) = (keys.first(), keys.last()) else {
            return self.projection;
        };
        let at = |fov_y: f64, aperture_radius: f64, focus_distance: f64| Projection {
            fov_y,
            aperture_radius,
            focus_distance,
            ..self.projection
        };
        let next = keys.partition_point(|k| k.time <= t);
        if next == 0 || next == keys.len() {
            let k = if next == 0 { first } else { last };
            return at(k.fov_y, k.aperture_radius, k.focus_distance);
        }
        let (a, b) = (keys[next - 1], keys[next]);
        let s = (t - a.time) / (b.time - a.time);
        let mix = |x: f64, y: f64| x + (y - x) * s;
        let focal = mix(1.0 / (0.5 * a.fov_y).tan(), 1.0 / (0.5 * b.fov_y).tan());
        at(
            2.0 * (1.0 / focal).atan(),
            mix(a.aperture_radius, b.aperture_radius),
            mix(a.focus_distance, b.focus_distance),
        )
    }

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
        let scale = teleport.scale;
        Self {
            transform: self.transform.then(teleport),
            projection: self.projection.scaled(scale),
            lens: (self.lens.iter())
                .map(|k| LensKey {
                    aperture_radius: k.aperture_radius * scale,
                    focus_distance: k.focus_distance * scale,
                    ..*k
                })
                .collect(),
        }
    }

    /// The camera's frame and projection at time `t` after a teleport: the constraint solver's
    /// M_T = T·M_H, with projection lengths scaled by the teleport's scale so the image matches.
    pub fn frame_through(&self, teleport: &Similarity, t: f64) -> (Similarity, Projection) {
        (
            teleport.compose(&self.transform.at(t)),
            self.projection_at(t).scaled(teleport.scale),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn zoom() -> Camera {
        let key = |time: f64, focal: f64, focus: f64| LensKey {
            time,
            fov_y: 2.0 * (1.0 / focal).atan(),
            aperture_radius: 0.01 * focal,
            focus_distance: focus,
        };
        let projection = Projection {
            resolution: [64, 32],
            fov_y: 1.0,
            aperture_radius: 0.0,
            focus_distance: 1.0,
        };
        Camera {
            transform: AnimatedTransform::constant(Similarity::IDENTITY),
            projection,
            lens: vec![key(1.0, 2.0, 3.0), key(2.0, 4.0, 5.0)],
        }
    }

    #[test]
    fn a_lens_moves_linearly_in_focal_length_between_keys_and_holds_beyond_them() {
        let camera = zoom();
        let focal = |p: Projection| 1.0 / p.tan_half_fov_y();
        let halfway = camera.projection_at(1.5);
        assert!((focal(halfway) - 3.0).abs() < 1e-12);
        assert!((halfway.aperture_radius - 0.03).abs() < 1e-12);
        assert!((halfway.focus_distance - 4.0).abs() < 1e-12);
        assert_eq!(halfway.resolution, [64, 32]);
        assert!((focal(camera.projection_at(0.0)) - 2.0).abs() < 1e-12);
        assert!((focal(camera.projection_at(9.0)) - 4.0).abs() < 1e-12);
        // A fixed lens is the projection itself.
        let fixed = Camera {
            lens: Vec::new(),
            ..zoom()
        };
        assert_eq!(fixed.projection_at(1.5), fixed.projection);
    }

    #[test]
    fn a_teleport_scales_every_lens_key_as_it_scales_the_projection() {
        let teleport = Similarity {
            scale: 2.0,
            ..Similarity::IDENTITY
        };
        let (camera, through) = (zoom(), zoom().through(&teleport));
        for t in [0.5, 1.25, 1.75, 3.0] {
            assert_eq!(
                through.projection_at(t),
                camera.projection_at(t).scaled(2.0)
            );
            assert_eq!(
                camera.frame_through(&teleport, t).1,
                through.projection_at(t)
            );
        }
    }
}
