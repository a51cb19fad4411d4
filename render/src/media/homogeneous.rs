//! Participating media: a homogeneous medium filling the scene (haze, fog), with absorption,
//! scattering, a Henyey–Greenstein phase function and emission, all per metre.
//!
//! Along a ray in the medium, radiance obeys
//! L(0) = ∫₀ᵈ T(s) [ε + σ_s ∫ p L_i] ds + T(d) L(d), with T(s) = e^(−σ_t s) per channel.
//! A path estimates it with one free-flight distance s drawn with density
//! pdf(s) = mean over channels of σ_t,c e^(−σ_t,c s) (a channel picked uniformly, then
//! exponential in its σ_t: one-sample MIS over the channels, so a colourful medium never
//! divides by a tiny density): when s falls before the surface the path gathers
//! T(s) ε / pdf(s) and scatters there with weight T(s) σ_s / pdf(s); otherwise it goes on to
//! the surface with weight T(d) / P(d), P(d) = mean of e^(−σ_t,c d). Both weights are exactly 1
//! per channel for a grey medium. A medium that only absorbs draws no collisions (they could
//! add nothing): paths pass with weight T(d). Shadow rays multiply by T of their length.
//!
//! Light sampling at a point in the medium uses the phase function as its "BSDF"
//! ([`crate::material::bsdf::Bsdf::Phase`]), so it shares next-event estimation, MIS and light
//! sampling through openings with surfaces. The MIS weights use the directional densities only;
//! both estimators carry the same transmittance, so the weights still sum to one.
//!
//! Openings: the medium fills both sides of every opening, so a teleport continues in it and
//! a shadow ray through a chain is attenuated by its whole length.

use glam::Vec3;
use std::f32::consts::PI;

/// A homogeneous medium, in units per metre.
#[derive(Clone, Debug, PartialEq)]
pub struct Medium {
    pub name: String,
    /// Extinction σ_t = σ_a + σ_s per channel.
    pub extinction: Vec3,
    /// Scattering σ_s per channel.
    pub scattering: Vec3,
    /// Henyey–Greenstein asymmetry g in (−1, 1): > 0 forward, < 0 backward scattering.
    pub anisotropy: f32,
    /// Emitted radiance per metre of path.
    pub emission: Vec3,
}

/// Where a path's free flight ends.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Flight {
    /// A collision at this distance, before the surface.
    Collision(f32),
    /// No collision before the surface (or ever, for an escaping ray).
    Through,
}

impl Medium {
    /// True when it does anything at all (some channel extinguishes or it emits).
    pub fn matters(&self) -> bool {
        self.extinction.max_element() > 0.0 || self.emission.max_element() > 0.0
    }

    /// True when a collision can add anything (the medium scatters or emits). A medium that
    /// only absorbs draws no collisions: paths pass with weight T(d) instead of dying with
    /// probability 1 − T(d), which removes the medium's own noise entirely.
    fn collisions_matter(&self) -> bool {
        self.scattering.max_element() > 0.0 || self.emission.max_element() > 0.0
    }

    /// A free-flight distance from `u_channel` (which channel's extinction draws it) and
    /// `u_distance`, against the distance `d` to the surface (∞ for an escaping ray).
    pub fn sample_flight(&self, u_channel: f32, u_distance: f32, d: f32) -> Flight {
        if !self.collisions_matter() {
            return Flight::Through;
        }
        let channel = ((u_channel * 3.0) as usize).min(2);
        let sigma = self.extinction[channel];
        if sigma <= 0.0 {
            return Flight::Through;
        }
        // 1 − u lies in (0, 1], so the logarithm is finite.
        let s = -(1.0 - u_distance).ln() / sigma;
        if s < d {
            Flight::Collision(s)
        } else {
            Flight::Through
        }
    }

    /// Transmittance over distance `d` per channel (0 for ∞ where the medium extinguishes).
    pub fn transmittance(&self, d: f32) -> Vec3 {
        Vec3::from_array(self.extinction.to_array().map(|sigma| {
            if sigma <= 0.0 {
                1.0
            } else if d.is_finite() {
                (-sigma * d).exp()
            } else {
                0.0
            }
        }))
    }

    /// The weight of a collision at `s`: the light it emits there and the throughput the path
    /// scatters with, both over the density of drawing `s`.
    pub fn collision(&self, s: f32) -> (Vec3, Vec3) {
        let t = self.transmittance(s);
        let pdf = (self.extinction * t).element_sum() / 3.0;
        if pdf <= 0.0 {
            return (Vec3::ZERO, Vec3::ZERO);
        }
        (t * self.emission / pdf, t * self.scattering / pdf)
    }

    /// The weight of passing distance `d` without a collision: T(d) over its probability.
    pub fn passage(&self, d: f32) -> Vec3 {
        let t = self.transmittance(d);
        if !self.collisions_matter() {
            return t;
        }
        let p = t.element_sum() / 3.0;
        if p <= 0.0 { Vec3::ZERO } else { t / p }
    }

    /// The single-scattering albedo σ_s / σ_t (for the albedo AOV).
    pub fn albedo(&self) -> Vec3 {
        Vec3::from_array(std::array::from_fn(|c| {
            let sigma = self.extinction[c];
            if sigma > 0.0 {
                self.scattering[c] / sigma
            } else {
                0.0
            }
        }))
    }
}

/// The Henyey–Greenstein phase function for directions `wo` (towards where the path came
/// from) and `wi` (towards the light), both unit: it peaks, for g > 0, when light keeps going
/// the way it went (wi = −wo). Normalised over the sphere.
pub fn henyey_greenstein(g: f32, wo: Vec3, wi: Vec3) -> f32 {
    let cos = wo.dot(wi);
    let denom = 1.0 + g * g + 2.0 * g * cos;
    (1.0 - g * g) / (4.0 * PI * denom * denom.max(1e-12).sqrt())
}

/// Samples `wi` from [`henyey_greenstein`] exactly (so the weight is 1), in any frame.
pub fn sample_henyey_greenstein(g: f32, wo: Vec3, u: glam::Vec2) -> Vec3 {
    // μ, the cosine between the light's direction before (−wi) and after (wo) scattering,
    // by inverting its distribution; the cosine between wo and wi is −μ.
    let cos = if g.abs() < 1e-3 {
        1.0 - 2.0 * u.x
    } else {
        let k = (1.0 - g * g) / (1.0 + g - 2.0 * g * u.x);
        -(1.0 + g * g - k * k) / (2.0 * g)
    }
    .clamp(-1.0, 1.0);
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    let frame = crate::sampling::Frame::new(wo);
    frame.to_world(Vec3::new(sin * phi.cos(), sin * phi.sin(), cos))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec2;

    fn grey(sigma_a: f32, sigma_s: f32) -> Medium {
        Medium {
            name: "m".into(),
            extinction: Vec3::splat(sigma_a + sigma_s),
            scattering: Vec3::splat(sigma_s),
            anisotropy: 0.0,
            emission: Vec3::ZERO,
        }
    }

    #[test]
    fn phase_function_integrates_to_one_and_sampling_follows_it() {
        for g in [-0.9f32, -0.3, 0.0, 0.5, 0.95] {
            let wo = Vec3::new(0.3, -0.4, 0.866).normalize();
            // ∫ p dω = 2π ∫ p(cos) dcos about wo, by a fine midpoint rule (the lobe is sharp).
            let frame = crate::sampling::Frame::new(wo);
            let n = 200_000;
            let mut total = 0.0f64;
            for i in 0..n {
                let cos = -1.0 + (i as f32 + 0.5) * 2.0 / n as f32;
                let wi = frame.to_world(Vec3::new((1.0 - cos * cos).sqrt(), 0.0, cos));
                total += henyey_greenstein(g, wo, wi) as f64
                    * (2.0 / n as f64)
                    * (2.0 * std::f64::consts::PI);
            }
            assert!((total - 1.0).abs() < 2e-3, "g {g}: ∫p = {total}");
            // Sampled mean cosine between wo and wi is −g.
            let m = 20000;
            let mean: f64 = (0..m)
                .map(|k| {
                    let u = Vec2::new((k as f32 + 0.5) / m as f32, (k as f32 * 0.618).fract());
                    sample_henyey_greenstein(g, wo, u).dot(wo) as f64
                })
                .sum::<f64>()
                / m as f64;
            assert!((mean + g as f64).abs() < 5e-3, "g {g}: mean cos {mean}");
        }
    }

    #[test]
    fn free_flights_weigh_to_the_transmittance() {
        // For a colourful medium, per channel: E[passage weight; no collision before d] = T(d)
        // and E[scattering weight; collision] = ∫₀ᵈ T(s) σ_s ds.
        let m = Medium {
            extinction: Vec3::new(0.2, 1.0, 3.0),
            scattering: Vec3::new(0.1, 0.5, 1.5),
            ..grey(0.0, 0.0)
        };
        let d = 1.3;
        let n = 400_000;
        let random = |k: u32| crate::sampling::hash32(k) as f32 / (u32::MAX as f32 + 1.0);
        // Per channel: sums of the passage and the scattering estimates, and of their squares.
        let (mut passed, mut passed2) = (Vec3::ZERO, Vec3::ZERO);
        let (mut scattered, mut scattered2) = (Vec3::ZERO, Vec3::ZERO);
        for k in 0..n {
            match m.sample_flight(random(2 * k), random(2 * k + 1), d) {
                Flight::Through => {
                    let w = m.passage(d);
                    passed += w;
                    passed2 += w * w;
                }
                Flight::Collision(s) => {
                    let w = m.collision(s).1;
                    scattered += w;
                    scattered2 += w * w;
                }
            }
        }
        let n = n as f32;
        // Within four standard errors of the closed forms: T(d), and ∫₀ᵈ T(s) σ_s ds =
        // σ_s / σ_t (1 − T(d)).
        let t = m.transmittance(d);
        let expected = m.scattering / m.extinction * (Vec3::ONE - t);
        for (sum, sum2, want, what) in [
            (passed, passed2, t, "passage"),
            (scattered, scattered2, expected, "scattering"),
        ] {
            let mean = sum / n;
            let error = ((sum2 / n - mean * mean) / n).max(Vec3::ZERO).sqrt();
            assert!(
                ((mean - want).abs() - 4.0 * error).max_element() <= 1e-6,
                "{what}: {mean} ± {error} against {want}"
            );
        }
    }

    #[test]
    fn transmittance_is_exponential_and_zero_at_infinity() {
        let m = grey(0.5, 0.5);
        assert!((m.transmittance(2.0).x - (-2.0f32).exp()).abs() < 1e-6);
        assert_eq!(m.transmittance(f32::INFINITY), Vec3::ZERO);
        assert_eq!(grey(0.0, 0.0).transmittance(f32::INFINITY), Vec3::ONE);
        assert!((m.passage(0.7) - Vec3::ONE).abs().max_element() < 1e-6);
    }
}
