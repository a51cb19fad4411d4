//! Light from infinitely far away where rays escape: a constant radiance, or a lat-long
//! (equirectangular) image, filtered bilinearly between texel centres (wrapping round in
//! longitude), and sampled in proportion to its brightness: each texel weighs as the brightest
//! of itself and its eight neighbours, the texels the filter blends into it, so every direction
//! that sends light can be drawn.
//!
//! Lat-long convention: +Y up; the image's top row looks straight up, its middle column looks
//! down −Z (the default camera direction), and columns run towards +X as u grows, so the map
//! wraps around the viewer the way the image reads left to right. `rotation_degrees` turns it
//! about +Y.

use crate::color::luminance;
use glam::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};

/// An environment light.
#[derive(Clone, Debug)]
pub enum Environment {
    Constant(Vec3),
    LatLong(LatLong),
}

/// A direction sampled on the environment.
#[derive(Clone, Copy, Debug)]
pub struct EnvironmentSample {
    pub direction: Vec3,
    pub radiance: Vec3,
    /// Solid-angle pdf.
    pub pdf: f32,
}

impl Environment {
    /// Radiance arriving from direction `dir` (unit, pointing away from the scene).
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        match self {
            Environment::Constant(c) => *c,
            Environment::LatLong(map) => map.radiance(dir),
        }
    }

    /// Samples a direction.
    pub fn sample(&self, u: Vec2) -> EnvironmentSample {
        match self {
            Environment::Constant(c) => {
                let z = 1.0 - 2.0 * u.x;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let phi = TAU * u.y;
                EnvironmentSample {
                    direction: Vec3::new(r * phi.cos(), r * phi.sin(), z),
                    radiance: *c,
                    pdf: 1.0 / (4.0 * PI),
                }
            }
            Environment::LatLong(map) => map.sample(u),
        }
    }

    /// Solid-angle pdf with which [`Environment::sample`] returns `dir`.
    pub fn pdf(&self, dir: Vec3) -> f32 {
        match self {
            Environment::Constant(_) => 1.0 / (4.0 * PI),
            Environment::LatLong(map) => map.pdf(dir),
        }
    }

    /// Mean luminance over the sphere of directions.
    pub fn mean_luminance(&self) -> f32 {
        match self {
            Environment::Constant(c) => luminance(*c),
            // `total` sums luminance · sin θ over texels of solid angle (2π/w)(π/h) sin θ.
            Environment::LatLong(map) => {
                map.total * PI * PI * 2.0 / (map.width * map.height) as f32 / (4.0 * PI)
            }
        }
    }

    /// True when it sends no light at all.
    pub fn is_black(&self) -> bool {
        match self {
            Environment::Constant(c) => c.max_element() <= 0.0,
            Environment::LatLong(map) => map.total <= 0.0,
        }
    }
}

/// A lat-long radiance image with a piecewise-constant sampling distribution over its texels,
/// weighted by luminance times the solid angle each row covers.
#[derive(Clone, Debug)]
pub struct LatLong {
    width: usize,
    height: usize,
    /// Row-major, top row first, already scaled by the intensity.
    texels: Vec<Vec3>,
    /// Rotation about +Y in radians.
    rotation: f32,
    /// Cumulative row weights (length height + 1, last = total).
    rows: Vec<f32>,
    /// Cumulative weights within each row (height × (width + 1)).
    columns: Vec<f32>,
    total: f32,
}

impl LatLong {
    /// From texels (row-major, top first), a radiance scale and a rotation about +Y.
    pub fn new(
        width: usize,
        height: usize,
        texels: Vec<Vec3>,
        intensity: f32,
        degrees: f32,
    ) -> Self {
        let texels: Vec<Vec3> = texels.into_iter().map(|c| c * intensity).collect();
        let brightest = neighbourhood_maxima(width, height, &texels);
        let mut rows = Vec::with_capacity(height + 1);
        let mut columns = Vec::with_capacity(height * (width + 1));
        rows.push(0.0);
        for y in 0..height {
            let sin_theta = ((y as f32 + 0.5) / height as f32 * PI).sin();
            let start = columns.len();
            columns.push(0.0);
            for x in 0..width {
                let w = brightest[y * width + x] * sin_theta;
                columns.push(columns[start + x] + w);
            }
            rows.push(rows[y] + columns[start + width]);
        }
        Self {
            width,
            height,
            total: rows[height],
            texels,
            rotation: degrees.to_radians(),
            rows,
            columns,
        }
    }

    /// Image coordinates in [0, 1)² of direction `dir`.
    fn uv(&self, dir: Vec3) -> Vec2 {
        let phi = dir.x.atan2(-dir.z) - self.rotation;
        let u = (0.5 + phi / TAU).rem_euclid(1.0);
        // atan2 rather than acos keeps precision near the poles.
        let v = (dir.x * dir.x + dir.z * dir.z).sqrt().atan2(dir.y) / PI;
        Vec2::new(u, v)
    }

    /// Direction of image coordinates `uv`.
    fn direction(&self, uv: Vec2) -> Vec3 {
        let phi = (uv.x - 0.5) * TAU + self.rotation;
        let theta = uv.y * PI;
        let (sin_t, cos_t) = theta.sin_cos();
        Vec3::new(sin_t * phi.sin(), cos_t, -sin_t * phi.cos())
    }

    fn texel(&self, uv: Vec2) -> (usize, usize) {
        let x = ((uv.x * self.width as f32) as usize).min(self.width - 1);
        let y = ((uv.y * self.height as f32) as usize).min(self.height - 1);
        (x, y)
    }

    fn radiance(&self, dir: Vec3) -> Vec3 {
        self.filtered(self.uv(dir))
    }

    /// The map at `uv`, bilinear between the four nearest texel centres (wrapping round in
    /// longitude, clamped at the poles).
    fn filtered(&self, uv: Vec2) -> Vec3 {
        let (w, h) = (self.width, self.height);
        let px = uv.x * w as f32 - 0.5;
        let py = (uv.y * h as f32 - 0.5).clamp(0.0, (h - 1) as f32);
        let (fx, fy) = (px - px.floor(), py - py.floor());
        let x0 = (px.floor() as isize).rem_euclid(w as isize) as usize;
        let x1 = (x0 + 1) % w;
        let y0 = (py as usize).min(h - 1);
        let y1 = (y0 + 1).min(h - 1);
        let at = |x: usize, y: usize| self.texels[y * w + x];
        let top = at(x0, y0) * (1.0 - fx) + at(x1, y0) * fx;
        let bottom = at(x0, y1) * (1.0 - fx) + at(x1, y1) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    fn sample(&self, u: Vec2) -> EnvironmentSample {
        if self.total <= 0.0 {
            // A black map: any direction, no light.
            let constant = Environment::Constant(Vec3::ZERO).sample(u);
            return EnvironmentSample {
                radiance: Vec3::ZERO,
                ..constant
            };
        }
        let (y, fy) = pick(&self.rows, u.y * self.total);
        let row = &self.columns[y * (self.width + 1)..(y + 1) * (self.width + 1)];
        let (x, fx) = pick(row, u.x * row[self.width]);
        let uv = Vec2::new(
            (x as f32 + fx) / self.width as f32,
            (y as f32 + fy) / self.height as f32,
        );
        let direction = self.direction(uv);
        EnvironmentSample {
            direction,
            radiance: self.filtered(uv),
            pdf: self.pdf_texel(x, y, uv.y),
        }
    }

    fn pdf(&self, dir: Vec3) -> f32 {
        let uv = self.uv(dir);
        let (x, y) = self.texel(uv);
        self.pdf_texel(x, y, uv.y)
    }

    /// Solid-angle pdf inside texel (x, y) at image row coordinate v.
    fn pdf_texel(&self, x: usize, y: usize, v: f32) -> f32 {
        if self.total <= 0.0 {
            return 0.0;
        }
        let base = y * (self.width + 1);
        let weight = self.columns[base + x + 1] - self.columns[base + x];
        // Density over the unit square, then over solid angle (dω = 2π² sin θ du dv).
        let density = weight / self.total * (self.width * self.height) as f32;
        let sin_theta = (v * PI).sin();
        if sin_theta <= 0.0 {
            return 0.0;
        }
        density / (2.0 * PI * PI * sin_theta)
    }
}

/// Per texel, the largest luminance of it and its eight neighbours (wrapping round in
/// longitude, clamped at the poles), never below zero.
fn neighbourhood_maxima(width: usize, height: usize, texels: &[Vec3]) -> Vec<f32> {
    let lum: Vec<f32> = texels.iter().map(|&c| luminance(c).max(0.0)).collect();
    let across: Vec<f32> = (0..width * height)
        .map(|i| {
            let (x, y) = (i % width, i / width);
            let left = (x + width - 1) % width;
            let right = (x + 1) % width;
            lum[y * width + left]
                .max(lum[i])
                .max(lum[y * width + right])
        })
        .collect();
    (0..width * height)
        .map(|i| {
            let (x, y) = (i % width, i / width);
            let up = y.saturating_sub(1);
            let down = (y + 1).min(height - 1);
            across[up * width + x]
                .max(across[i])
                .max(across[down * width + x])
        })
        .collect()
}

/// Finds the cell of a cumulative table holding `target` and the fraction within it.
fn pick(cumulative: &[f32], target: f32) -> (usize, f32) {
    let cells = cumulative.len() - 1;
    // First cell whose end exceeds the target, skipping empty cells.
    let i = cumulative[1..]
        .partition_point(|&c| c <= target)
        .min(cells - 1);
    let (lo, hi) = (cumulative[i], cumulative[i + 1]);
    let f = if hi > lo {
        ((target - lo) / (hi - lo)).clamp(0.0, 1.0 - f32::EPSILON)
    } else {
        0.5
    };
    (i, f)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::hash32;

    fn uniform(i: u32, k: u32) -> f32 {
        (hash32(hash32(i) ^ k) >> 8) as f32 / (1u32 << 24) as f32
    }

    /// A map with a bright spot on a dim sky.
    fn spot_map() -> LatLong {
        let (w, h) = (64, 32);
        let mut texels = vec![Vec3::splat(0.1); w * h];
        for y in 8..11 {
            for x in 40..44 {
                texels[y * w + x] = Vec3::new(50.0, 40.0, 30.0);
            }
        }
        LatLong::new(w, h, texels, 1.0, 30.0)
    }

    #[test]
    fn the_map_is_bilinear_between_texel_centres_and_wraps_in_longitude() {
        let mut texels = vec![Vec3::ZERO; 8];
        texels[0] = Vec3::ONE; // top row, first column
        let map = LatLong::new(4, 2, texels, 1.0, 0.0);
        // At the texel's centre, its value; halfway to the next centre, half.
        assert!((map.filtered(Vec2::new(0.125, 0.25)).x - 1.0).abs() < 1e-6);
        assert!((map.filtered(Vec2::new(0.25, 0.25)).x - 0.5).abs() < 1e-6);
        // Across the seam: halfway between the last column's centre and the first's.
        assert!((map.filtered(Vec2::new(0.0, 0.25)).x - 0.5).abs() < 1e-6);
        // Every texel the filter blends the lit one into can be drawn: its neighbours too.
        let env = Environment::LatLong(map.clone());
        for x in [0.0, 0.2, 0.3, 0.9] {
            let d = map.direction(Vec2::new(x, 0.3));
            assert!(env.radiance(d).x == 0.0 || env.pdf(d) > 0.0, "{x}");
        }
    }

    #[test]
    fn directions_and_image_coordinates_round_trip() {
        let map = spot_map();
        for i in 0..1000 {
            let uv = Vec2::new(uniform(i, 1), 0.01 + 0.98 * uniform(i, 2));
            let back = map.uv(map.direction(uv));
            let du = (back.x - uv.x).abs();
            assert!(du.min(1.0 - du) < 1e-4 && (back.y - uv.y).abs() < 1e-4);
        }
        // The middle column looks down −Z; the top row up.
        let plain = LatLong::new(4, 2, vec![Vec3::ONE; 8], 1.0, 0.0);
        assert!((plain.direction(Vec2::new(0.5, 0.5)) - Vec3::NEG_Z).length() < 1e-6);
        assert!((plain.direction(Vec2::new(0.3, 0.0)) - Vec3::Y).length() < 1e-6);
    }

    #[test]
    fn sampling_matches_its_pdf_and_integrates_radiance() {
        let map = spot_map();
        let env = Environment::LatLong(map.clone());
        // ∫ L dω by uniform sphere sampling versus by importance sampling.
        let n = 400_000;
        let (mut uniform_sum, mut importance_sum, mut pdf_sum) = (Vec3::ZERO, Vec3::ZERO, 0.0);
        for i in 0..n {
            let z = 1.0 - 2.0 * uniform(i, 3);
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = TAU * uniform(i, 4);
            let d = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            uniform_sum += env.radiance(d) * (4.0 * PI);
            pdf_sum += env.pdf(d) * 4.0 * PI;
            let s = env.sample(Vec2::new(uniform(i, 5), uniform(i, 6)));
            assert!((s.direction.length() - 1.0).abs() < 1e-4);
            let pdf = env.pdf(s.direction);
            assert!(
                (pdf - s.pdf).abs() <= 1e-3 * s.pdf.max(1.0),
                "pdf {pdf} vs sampled {}",
                s.pdf
            );
            let looked_up = env.radiance(s.direction);
            assert!(
                (looked_up - s.radiance).abs().max_element()
                    <= 1e-3 * s.radiance.max_element().max(1.0)
            );
            importance_sum += s.radiance / s.pdf;
        }
        let (a, b) = (uniform_sum / n as f32, importance_sum / n as f32);
        assert!(((a - b) / b).abs().max_element() < 0.03, "{a} vs {b}");
        assert!(
            (pdf_sum / n as f32 - 1.0).abs() < 0.02,
            "pdf integrates to {}",
            pdf_sum / n as f32
        );
    }
}
