//! Coherent noise around a closed curve, with a continuous level of detail.
//!
//! A strand's material angle `u` samples Perlin noise (the `noise` crate) on a circle in noise
//! space, so every channel is periodic in `u` and the curve closes. Octave `a` has
//! `frequency · 2^a` features around the ring. For a level of detail `L` (fractional octaves),
//! the field sums the octaves `a = k .. k+octaves` with `k = floor(L)`, octave `a` weighted by
//! `roughness^(a−L)`, the lowest faded out by `1 − frac(L)` and the highest faded in by `frac(L)`.
//! Every weight is continuous in `L`, and each absolute octave keeps its pattern, so detail grows
//! and shrinks without popping or swimming. The sum is divided by the sum of weights and each
//! octave is clamped to [−1, 1], so the field stays within [−1, 1].

use noise::{NoiseFn, Perlin};
use std::f64::consts::TAU;

/// Most octaves a look may ask for (plus one for the cross-fade).
pub const MAX_OCTAVES: usize = 13;

/// A seeded noise source shared by every strand of a ring.
#[derive(Clone, Debug)]
pub struct NoiseField {
    perlin: Perlin,
    frequency: f64,
    octaves: u32,
    roughness: f64,
}

/// The octaves and weights for one level of detail, computed once per strand and time.
#[derive(Clone, Copy, Debug)]
pub struct Octaves {
    count: usize,
    /// Radius of the sampling circle in noise space for each octave.
    radius: [f64; MAX_OCTAVES],
    /// Normalised weights (sum 1).
    weight: [f64; MAX_OCTAVES],
    /// Offset so that octaves are independent patterns.
    shift: [f64; MAX_OCTAVES],
}

impl Octaves {
    /// Σ weight·(features around the ring)²: used to estimate the curvature the noise adds.
    pub fn mean_square_features(&self) -> f64 {
        (0..self.count)
            .map(|j| self.weight[j] * (TAU * self.radius[j]).powi(2))
            .sum()
    }
}

impl NoiseField {
    /// `frequency` features around the ring at level of detail 0.
    pub fn new(seed: u32, frequency: f64, octaves: u32, roughness: f64) -> Self {
        Self {
            perlin: Perlin::new(seed),
            frequency,
            octaves,
            roughness,
        }
    }

    /// Octave set for level of detail `lod`.
    pub fn octaves(&self, lod: f64) -> Octaves {
        let k = lod.floor();
        let fade = lod - k;
        let mut o = Octaves {
            count: 0,
            radius: [0.0; MAX_OCTAVES],
            weight: [0.0; MAX_OCTAVES],
            shift: [0.0; MAX_OCTAVES],
        };
        let top = self.octaves as usize;
        let mut total = 0.0;
        for j in 0..=top {
            let mut w = self.roughness.powf(k + j as f64 - lod);
            if j == 0 {
                w *= 1.0 - fade;
            }
            if j == top {
                w *= fade;
            }
            if w <= 0.0 {
                continue;
            }
            let octave = k as i64 + j as i64;
            let i = o.count;
            o.radius[i] = self.frequency * 2f64.powi(octave as i32) / TAU;
            o.weight[i] = w;
            o.shift[i] = 31.7 * octave as f64;
            o.count += 1;
            total += w;
        }
        for w in &mut o.weight[..o.count] {
            *w /= total;
        }
        o
    }

    /// The field at material angle (cos u, sin u), evolution coordinate `tau`, for a channel
    /// placed at `offset` in noise space. In [−1, 1].
    #[inline]
    pub fn sample(
        &self,
        octaves: &Octaves,
        cos_u: f64,
        sin_u: f64,
        tau: f64,
        offset: [f64; 3],
    ) -> f64 {
        let mut sum = 0.0;
        for j in 0..octaves.count {
            let r = octaves.radius[j];
            let s = octaves.shift[j];
            let p = [
                r * cos_u + offset[0] + s,
                r * sin_u + offset[1] - s,
                tau + offset[2] + s,
            ];
            sum += octaves.weight[j] * self.perlin.get(p).clamp(-1.0, 1.0);
        }
        sum
    }

    /// A 1-D signal over time in [−1, 1] (flicker).
    pub fn signal(&self, x: f64, offset: [f64; 3]) -> f64 {
        self.perlin
            .get([x + offset[0], offset[1], offset[2]])
            .clamp(-1.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_are_continuous_across_octave_boundaries() {
        let field = NoiseField::new(3, 6.0, 3, 0.5);
        let (c, s) = (0.3f64.cos(), 0.3f64.sin());
        for boundary in [-2.0, -1.0, 0.0, 1.0, 2.0] {
            let below = field.sample(&field.octaves(boundary - 1e-9), c, s, 0.7, [1.0, 2.0, 3.0]);
            let at = field.sample(&field.octaves(boundary), c, s, 0.7, [1.0, 2.0, 3.0]);
            assert!(
                (below - at).abs() < 1e-6,
                "jump at L = {boundary}: {below} vs {at}"
            );
        }
    }

    #[test]
    fn stays_within_unit_range() {
        let field = NoiseField::new(11, 9.0, 4, 0.8);
        for i in 0..2000 {
            let u = i as f64 * 0.0137;
            let lod = (i % 17) as f64 * 0.37 - 3.0;
            let v = field.sample(
                &field.octaves(lod),
                u.cos(),
                u.sin(),
                u * 0.1,
                [5.0, 6.0, 7.0],
            );
            assert!((-1.0..=1.0).contains(&v));
        }
    }
}
