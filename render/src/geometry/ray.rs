//! A ray as the scene's queries take it: where it starts, where it goes, which stretch of it
//! counts and when it is cast. Time travels with the ray because everything that moves (objects,
//! openings, strands, cull volumes) is evaluated at the ray's own time.

use glam::Vec3;

/// `origin + t·dir` for t in (`t_min`, `t_max`) at time `time` (seconds).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    /// Unit direction (ray parameters are distances); a shadow ray to a point may instead
    /// span the segment to it, over t in (0, 1) (see `integrator::segment`).
    pub dir: Vec3,
    pub t_min: f32,
    pub t_max: f32,
    pub time: f64,
}

impl Ray {
    /// The ray over (0, `t_max`).
    #[inline]
    pub fn new(origin: Vec3, dir: Vec3, t_max: f32, time: f64) -> Self {
        Self {
            origin,
            dir,
            t_min: 0.0,
            t_max,
            time,
        }
    }

    /// The same ray with parameters in (`t_min`, `t_max`).
    #[inline]
    pub fn between(self, t_min: f32, t_max: f32) -> Self {
        Self {
            t_min,
            t_max,
            ..self
        }
    }

    /// The point at parameter `t`.
    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }
}
