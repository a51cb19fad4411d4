//! Light from infinitely far away: the environment (a dome) and distant lights (suns), sampled
//! together as one emitter, each part chosen in proportion to what it sends a surface open to
//! the whole sky. A distant light shines along its local −Z from a disk of directions of
//! angular diameter `angle` (UsdLux's DistantLight); its radiance is `color × intensity ×
//! 2^exposure`, or with `normalize` that value is the illuminance it gives a surface facing it.
//! A light of angle 0 is a single direction, found by light sampling alone.

use crate::color::luminance;
use crate::lights::environment::Environment;
use crate::portals::{Flags, RayClass};
use crate::sampling::Frame;
use glam::{DVec3, Vec2, Vec3};
use rift_fx::rig::AnimatedTransform;
use std::f32::consts::PI;

/// A distant light.
#[derive(Clone, Debug)]
pub struct Sun {
    pub name: String,
    /// Its frame over time: it shines along the frame's −Z.
    placement: AnimatedTransform,
    /// Cosine of the half of its angular diameter (1 for a single direction).
    cos_half: f32,
    /// Radiance within its disk; for a single direction, the illuminance it gives.
    radiance: Vec3,
    pub flags: Flags,
    pub group: u8,
}

impl Sun {
    /// A distant light of angular diameter `angle_degrees` placed by `placement`, whose base
    /// (color × intensity × 2^exposure) is radiance, or illuminance when `normalize` (always,
    /// for angle 0).
    pub fn new(
        name: String,
        angle_degrees: f32,
        base: Vec3,
        normalize: bool,
        placement: AnimatedTransform,
        flags: Flags,
        group: u8,
    ) -> Self {
        let half = 0.5 * angle_degrees.to_radians();
        let cos_half = half.cos();
        let sin2 = half.sin() * half.sin();
        let radiance = if angle_degrees > 0.0 && normalize {
            base / (PI * sin2)
        } else {
            base
        };
        Self {
            name,
            placement,
            cos_half: if angle_degrees > 0.0 { cos_half } else { 1.0 },
            radiance,
            flags,
            group,
        }
    }

    /// True for a single direction.
    pub fn is_delta(&self) -> bool {
        self.cos_half >= 1.0
    }

    /// The unit direction towards the light at `time`.
    pub fn towards(&self, time: f64) -> Vec3 {
        let frame = self.placement.at(time);
        frame.transform_direction(DVec3::Z).normalize().as_vec3()
    }

    /// Solid angle of its disk.
    fn solid_angle(&self) -> f32 {
        2.0 * PI * (1.0 - self.cos_half)
    }

    /// What it sends a surface facing it (illuminance, as luminance).
    fn importance(&self) -> f32 {
        let lum = luminance(self.radiance);
        if self.is_delta() {
            lum
        } else {
            // π sin² of the half-angle: the disk's projected solid angle.
            lum * PI * (1.0 - self.cos_half * self.cos_half)
        }
    }

    /// Radiance from direction `dir` at `time` (0 outside its disk, and from a single
    /// direction, which no ray meets).
    fn radiance(&self, dir: Vec3, time: f64) -> Vec3 {
        if !self.is_delta() && dir.dot(self.towards(time)) >= self.cos_half {
            self.radiance
        } else {
            Vec3::ZERO
        }
    }
}

/// What lies infinitely far away: the dome and the distant lights.
#[derive(Clone, Debug)]
pub struct Sky {
    pub dome: Option<Environment>,
    pub suns: Vec<Sun>,
    /// Probability of each part: the dome's first (0 without one), then each sun's.
    shares: Vec<f32>,
    /// What the whole sky sends a surface open to all of it (luminance).
    importance: f32,
}

/// Which part of the sky a direction was drawn from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SkyPart {
    Dome,
    Sun(u32),
}

/// A direction drawn on the sky.
#[derive(Clone, Copy, Debug)]
pub struct SkySample {
    pub direction: Vec3,
    pub radiance: Vec3,
    /// Solid-angle density over the whole sky; for a single direction, the probability of
    /// drawing it.
    pub pdf: f32,
    pub part: SkyPart,
    /// A single direction: no ray can find it.
    pub delta: bool,
}

impl Sky {
    /// The sky of `dome` (when it sends any light) and `suns`; `None` when both send nothing.
    pub fn new(dome: Option<Environment>, suns: Vec<Sun>) -> Option<Self> {
        let dome = dome.filter(|d| !d.is_black());
        let dome_importance = dome.as_ref().map_or(0.0, |d| PI * d.mean_luminance());
        let parts: Vec<f32> = std::iter::once(dome_importance)
            .chain(suns.iter().map(Sun::importance))
            .collect();
        let importance: f32 = parts.iter().sum();
        if !(importance > 0.0 && importance.is_finite()) {
            return None;
        }
        Some(Self {
            dome,
            suns,
            shares: parts.iter().map(|p| p / importance).collect(),
            importance,
        })
    }

    /// What the whole sky sends a surface open to all of it: π times the dome's mean
    /// radiance, plus each sun's illuminance (luminance).
    pub fn importance(&self) -> f32 {
        self.importance
    }

    /// Draws a direction with `u`, for a receiver at `time`.
    pub fn sample(&self, u: Vec2, time: f64) -> Option<SkySample> {
        let (part, u) = self.pick(u);
        match part {
            SkyPart::Dome => {
                // The dome's own density and radiance as its sampling gives them, with the
                // suns' added where they cover the direction.
                let s = self.dome.as_ref()?.sample(u);
                let pdf = self.shares[0] * s.pdf + self.suns_pdf(s.direction, time);
                (pdf > 0.0).then_some(SkySample {
                    direction: s.direction,
                    radiance: s.radiance + self.suns_radiance(s.direction, time),
                    pdf,
                    part,
                    delta: false,
                })
            }
            SkyPart::Sun(i) => {
                let sun = &self.suns[i as usize];
                let towards = sun.towards(time);
                if sun.is_delta() {
                    return Some(SkySample {
                        direction: towards,
                        radiance: sun.radiance,
                        pdf: self.shares[1 + i as usize],
                        part,
                        delta: true,
                    });
                }
                let cos = 1.0 - u.x * (1.0 - sun.cos_half);
                let sin = (1.0 - cos * cos).max(0.0).sqrt();
                let phi = 2.0 * PI * u.y;
                let local = Vec3::new(sin * phi.cos(), sin * phi.sin(), cos);
                let direction = Frame::new(towards).to_world(local).normalize();
                let pdf = self.pdf(direction, time);
                (pdf > 0.0).then_some(SkySample {
                    direction,
                    radiance: self.radiance(direction, time),
                    pdf,
                    part,
                    delta: false,
                })
            }
        }
    }

    /// The part `u.x` picks, and `u` rescaled within it.
    fn pick(&self, u: Vec2) -> (SkyPart, Vec2) {
        let mut below = 0.0;
        for (k, &share) in self.shares.iter().enumerate() {
            if share > 0.0 && (u.x < below + share || k + 1 == self.shares.len()) {
                let x = ((u.x - below) / share).clamp(0.0, 1.0 - f32::EPSILON);
                let part = match k {
                    0 => SkyPart::Dome,
                    k => SkyPart::Sun(k as u32 - 1),
                };
                return (part, Vec2::new(x, u.y));
            }
            below += share;
        }
        (SkyPart::Dome, u)
    }

    /// Solid-angle density with which [`Self::sample`] draws `dir` at `time` (single
    /// directions aside).
    pub fn pdf(&self, dir: Vec3, time: f64) -> f32 {
        let dome = match &self.dome {
            Some(d) => self.shares[0] * d.pdf(dir),
            None => 0.0,
        };
        dome + self.suns_pdf(dir, time)
    }

    /// The suns' part of [`Self::pdf`].
    fn suns_pdf(&self, dir: Vec3, time: f64) -> f32 {
        (self.suns.iter().zip(&self.shares[1..]))
            .filter(|(sun, _)| !sun.is_delta() && dir.dot(sun.towards(time)) >= sun.cos_half)
            .map(|(sun, share)| share / sun.solid_angle())
            .sum()
    }

    /// The radiance arriving from `dir` at `time`, every part together.
    pub fn radiance(&self, dir: Vec3, time: f64) -> Vec3 {
        let dome = self.dome.as_ref().map_or(Vec3::ZERO, |d| d.radiance(dir));
        dome + self.suns_radiance(dir, time)
    }

    /// The suns' part of [`Self::radiance`].
    fn suns_radiance(&self, dir: Vec3, time: f64) -> Vec3 {
        (self.suns.iter()).fold(Vec3::ZERO, |sum, sun| sum + sun.radiance(dir, time))
    }

    /// Calls `gather` with the radiance each part sends from `dir` at `time` that rays of
    /// `class` see, and the part (the dome is seen by every ray).
    pub fn each_part(
        &self,
        dir: Vec3,
        time: f64,
        class: RayClass,
        mut gather: impl FnMut(Vec3, SkyPart),
    ) {
        if let Some(d) = &self.dome {
            gather(d.radiance(dir), SkyPart::Dome);
        }
        for (i, sun) in self.suns.iter().enumerate() {
            if sun.flags.sees(class) {
                let l = sun.radiance(dir, time);
                if l != Vec3::ZERO {
                    gather(l, SkyPart::Sun(i as u32));
                }
            }
        }
    }

    /// True when it holds no distant light (the dome alone).
    pub fn dome_only(&self) -> bool {
        self.suns.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rift_fx::rig::Similarity;

    fn sun(angle: f32, normalize: bool, rotation_y: f64) -> Sun {
        let turn = glam::DQuat::from_rotation_y(rotation_y.to_radians());
        let frame = Similarity::new(turn, DVec3::ZERO, 1.0);
        Sun::new(
            String::new(),
            angle,
            Vec3::splat(2.0),
            normalize,
            AnimatedTransform::constant(frame),
            Flags::ALL,
            0,
        )
    }

    /// Sampled densities match evaluated ones, and Σ L/pdf over the samples integrates the
    /// sky's radiance: 4π times the dome's, plus each disk's L·Ω; a single direction comes
    /// with its probability and its illuminance.
    #[test]
    fn sampling_matches_its_pdf_and_integrates_the_radiance() {
        let suns = vec![
            sun(8.0, false, 0.0),
            sun(3.0, true, 90.0),
            sun(0.0, true, 200.0),
        ];
        let sky = Sky::new(Some(Environment::Constant(Vec3::splat(0.1))), suns).unwrap();
        let (n, mut integral, mut deltas) = (200_000u32, 0.0f64, 0u32);
        for k in 0..n {
            let u = Vec2::new(
                (k as f32 + 0.5) / n as f32,
                k.reverse_bits() as f32 / 2f32.powi(32),
            );
            let Some(s) = sky.sample(u, 0.0) else {
                continue;
            };
            if s.delta {
                deltas += 1;
                assert_eq!(s.radiance, Vec3::splat(2.0));
                continue;
            }
            let evaluated = sky.pdf(s.direction, 0.0);
            assert!(
                (s.pdf - evaluated).abs() <= 1e-4 * evaluated,
                "{} {evaluated}",
                s.pdf
            );
            integral += (s.radiance.x / s.pdf) as f64;
        }
        let solid = |deg: f32| 2.0 * PI * (1.0 - (0.5 * deg.to_radians()).cos());
        let normalised = 2.0 / (PI * (1.5f32.to_radians().sin().powi(2)));
        let want = 4.0 * PI * 0.1 + 2.0 * solid(8.0) + normalised * solid(3.0);
        let got = integral / n as f64;
        assert!(
            (got - want as f64).abs() < 0.01 * want as f64,
            "{got} against {want}"
        );
        let expected_deltas = sky.shares[3] * n as f32;
        assert!((deltas as f32 - expected_deltas).abs() <= 2.0, "{deltas}");
    }

    /// A normalised sun gives its value as illuminance on a surface facing it.
    #[test]
    fn a_normalised_sun_gives_its_value_as_illuminance() {
        let s = sun(10.0, true, 0.0);
        let half = 5f32.to_radians();
        let e = s.radiance.x * PI * half.sin().powi(2);
        assert!((e - 2.0).abs() < 1e-5, "{e}");
        assert!(Sky::new(None, Vec::new()).is_none());
    }
}
