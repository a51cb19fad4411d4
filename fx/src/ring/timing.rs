//! Perceptual speed: how fast a ring turns and how fine its noise is, over time.
//!
//! Artists set how fast the ring should *look*. With
//!
//! - `S(t) = R·s / (2·d·tan(fov_y/2))`: the ring radius as a fraction of the image height, for
//!   ring radius `R`, opening scale `s` and camera distance `d`;
//! - `F(t)`: foreshortening, the perimeter of the ring's on-screen ellipse over that of a circle
//!   (Ramanujan's approximation, minor/major axis `b = max(|cos θ|, 0.05)` for the angle θ between
//!   the opening's normal and the direction to the camera), so an oblique ring, whose rim moves
//!   less on screen, is compensated;
//! - `S_eff = S·F` and `ratio = clamp(reference_size / S_eff, 1/16, 16)`;
//! - `T_screen`: seconds of the shot during which the ring is in frame (the whole shot if never);
//!
//! the angular velocity is
//!
//! ```text
//! ω(t) = 2π · turns_per_second · ratio^speed.size_compensation
//! |ω|  ≥ 2π · min_visible_turn / T_screen
//! ```
//!
//! so with compensation 1 the rim crosses the screen at the same speed whatever the distance and
//! angle, and a ring that is on screen only briefly still visibly turns. The rotation angle
//! Θ(t) = ∫ω dt is integrated on a fixed grid (8 steps per frame, Simpson's rule) anchored at the
//! shot's first frame, so speed changes never make the phase jump and a frame generated alone is
//! bit-identical to the same frame generated within a range. Between grid points Θ is a cubic
//! Hermite curve whose slopes are ω, so Θ and its derivative are continuous.
//!
//! The noise level of detail follows apparent size the same way:
//! `L(t) = noise.size_compensation · log2(S_eff / reference_size)`, clamped to ±4 octaves; the
//! noise field cross-fades octaves continuously in L (see [`super::noise_field`]), so detail
//! appears and fades without popping. A frame holds its own L across its shutter
//! ([`super::strand::RingModel::instant`]): motion blur shows how the ring moves, not how the
//! camera's approach changes its detail.

use crate::rig::keyframes::hermite;
use crate::rig::{Camera, Rig};
use crate::ring::RingLook;
use crate::shot::Shot;
use std::f64::consts::TAU;

/// Grid steps per frame for integrating ω.
const STEPS_PER_FRAME: f64 = 8.0;
/// Bounds of the speed ratio and of the noise level of detail.
const MAX_RATIO: f64 = 16.0;
const MAX_LOD: f64 = 4.0;

/// Θ(t), ω(t) and L(t) of one opening's ring, tabulated over the times a job needs.
#[derive(Clone, Debug)]
pub struct RingTiming {
    /// Time of grid index 0: the shot's first frame.
    anchor: f64,
    dt: f64,
    /// Grid index of element 0 of the tables (≤ 0: the anchor may be inside).
    first_index: i64,
    theta: Vec<f64>,
    omega: Vec<f64>,
    lod: Vec<f64>,
    /// Seconds the ring is on screen during the shot.
    pub screen_time: f64,
}

/// What [`RingTiming`] needs to evaluate speed and detail at one time.
struct SpeedModel<'a> {
    camera: &'a Camera,
    rig: &'a Rig,
    opening: usize,
    look: &'a RingLook,
    min_omega: f64,
}

impl SpeedModel<'_> {
    /// Effective apparent size S_eff at time `t`.
    fn apparent_size(&self, t: f64) -> f64 {
        let here = self.rig.here_at(self.opening, t);
        let to_camera = self.camera.position(t) - here.translation;
        let d = to_camera.length().max(1e-9);
        let size = self.look.radius * here.scale
            / (2.0 * d * self.camera.projection_at(t).tan_half_fov_y());
        let normal = here.transform_direction(glam::DVec3::Z);
        let b = (normal.dot(to_camera) / d).abs().max(0.05);
        let perimeter =
            std::f64::consts::PI * (3.0 * (1.0 + b) - ((3.0 + b) * (1.0 + 3.0 * b)).sqrt());
        size * perimeter / TAU
    }

    /// ω(t) and L(t).
    fn eval(&self, t: f64) -> (f64, f64) {
        let speed = &self.look.speed;
        let s_eff = self.apparent_size(t);
        let ratio = (speed.reference_size / s_eff).clamp(1.0 / MAX_RATIO, MAX_RATIO);
        let mut omega = TAU * speed.turns_per_second * ratio.powf(speed.size_compensation);
        if omega.abs() < self.min_omega {
            omega = self.min_omega.copysign(if speed.turns_per_second < 0.0 {
                -1.0
            } else {
                1.0
            });
        }
        let lod = (self.look.noise.size_compensation * (s_eff / speed.reference_size).log2())
            .clamp(-MAX_LOD, MAX_LOD);
        (omega, lod)
    }
}

impl RingTiming {
    /// Tabulates opening `opening`'s ring over `[start, end]` seconds (plus a margin).
    pub fn new(shot: &Shot, opening: usize, look: &RingLook, start: f64, end: f64) -> Self {
        let screen_time = screen_time(shot, opening, look);
        let model = SpeedModel {
            camera: &shot.camera,
            rig: &shot.rig,
            opening,
            look,
            min_omega: TAU * look.speed.min_visible_turn / screen_time,
        };
        let anchor = shot.time_of(shot.frames.first as f64);
        let dt = 1.0 / (shot.fps * STEPS_PER_FRAME);
        let lo = ((start.min(anchor) - anchor) / dt).floor() as i64 - 2;
        let hi = ((end.max(anchor) - anchor) / dt).ceil() as i64 + 2;
        let n = (hi - lo + 1) as usize;
        let time = |k: i64| anchor + k as f64 * dt;
        let mut omega = Vec::with_capacity(n);
        let mut lod = Vec::with_capacity(n);
        for k in lo..=hi {
            let (w, l) = model.eval(time(k));
            omega.push(w);
            lod.push(l);
        }
        // Integrate outwards from the anchor (index -lo), so each value depends only on the grid
        // between it and the anchor, not on how far the table reaches.
        let zero = (-lo) as usize;
        let mut theta = vec![0.0; n];
        let step = |k: usize, sign: f64| {
            // Simpson over [k, k+sign].
            let a = omega[k];
            let b = if sign > 0.0 {
                omega[k + 1]
            } else {
                omega[k - 1]
            };
            let t_mid = time(lo + k as i64) + 0.5 * sign * dt;
            sign * dt / 6.0 * (a + 4.0 * model.eval(t_mid).0 + b)
        };
        for k in zero..n - 1 {
            theta[k + 1] = theta[k] + step(k, 1.0);
        }
        for k in (1..=zero).rev() {
            theta[k - 1] = theta[k] + step(k, -1.0);
        }
        Self {
            anchor,
            dt,
            first_index: lo,
            theta,
            omega,
            lod,
            screen_time,
        }
    }

    /// Grid segment holding `t` and the position within it; clamps to the table. The fraction is
    /// taken relative to the anchor, not to the table start, so it does not depend on the table's
    /// extent (bit-identical frames whatever range a job covers).
    fn locate(&self, t: f64) -> (usize, f64) {
        let g = (t - self.anchor) / self.dt;
        let whole = g.floor();
        let last = (self.theta.len() - 2) as i64;
        let k = whole as i64 - self.first_index;
        if k < 0 {
            (0, 0.0)
        } else if k > last {
            (last as usize, 1.0)
        } else {
            (k as usize, g - whole)
        }
    }

    /// Rotation angle Θ(t) in radians (before per-strand direction and speed factor).
    pub fn angle(&self, t: f64) -> f64 {
        let (k, w) = self.locate(t);
        let (m0, m1) = (self.omega[k] * self.dt, self.omega[k + 1] * self.dt);
        hermite(self.theta[k], m0, self.theta[k + 1], m1, w)
    }

    /// Angular velocity ω(t), rad/s.
    pub fn angular_velocity(&self, t: f64) -> f64 {
        let (k, w) = self.locate(t);
        self.omega[k] + (self.omega[k + 1] - self.omega[k]) * w
    }

    /// Noise level of detail L(t), in octaves.
    pub fn lod(&self, t: f64) -> f64 {
        let (k, w) = self.locate(t);
        // Catmull-Rom through the grid keeps L smooth (C1), so the noise never changes abruptly.
        let at = |i: i64| self.lod[i.clamp(0, self.lod.len() as i64 - 1) as usize];
        let k = k as i64;
        let (p0, p1, p2, p3) = (at(k - 1), at(k), at(k + 1), at(k + 2));
        let (w2, w3) = (w * w, w * w * w);
        0.5 * (2.0 * p1
            + (p2 - p0) * w
            + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * w2
            + (3.0 * p1 - p0 - 3.0 * p2 + p3) * w3)
    }
}

/// Seconds of the shot during which any of the ring's centre or rim is in frame.
fn screen_time(shot: &Shot, opening: usize, look: &RingLook) -> f64 {
    let visible = shot
        .frames
        .iter()
        .filter(|&f| {
            let t = shot.time_of(f as f64);
            let here = shot.rig.here_at(opening, t);
            (0..=8).any(|i| {
                let local = if i == 0 {
                    glam::DVec3::ZERO
                } else {
                    let a = TAU * i as f64 / 8.0;
                    glam::DVec3::new(a.cos(), a.sin(), 0.0) * look.radius
                };
                shot.camera.sees(here.transform_point(local), t, 0.0)
            })
        })
        .count();
    let frames = if visible == 0 {
        shot.frames.len()
    } else {
        visible
    };
    frames as f64 / shot.fps
}
