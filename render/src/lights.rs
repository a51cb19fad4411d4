//! Emitters and how next-event estimation picks them: every emissive triangle, chosen in
//! proportion to its power with an alias table (O(1) per sample whatever the count), then a
//! uniform point on it.

use crate::geometry::Triangle;
use crate::sampling::{AliasTable, uniform_triangle};
use glam::{Vec2, Vec3};

/// One emissive triangle.
#[derive(Clone, Copy, Debug)]
pub struct Emitter {
    pub triangle: u32,
    pub radiance: Vec3,
    pub two_sided: bool,
    pub area: f32,
}

/// A sampled point on an emitter.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    pub point: Vec3,
    /// Unit geometric normal (front side).
    pub normal: Vec3,
    pub radiance: Vec3,
    pub two_sided: bool,
    /// Area-measure pdf of having picked this point.
    pub pdf_area: f32,
}

/// All emitters of a scene.
#[derive(Clone, Debug, Default)]
pub struct Lights {
    pub emitters: Vec<Emitter>,
    table: AliasTable,
    /// Emitter index per scene triangle (u32::MAX: not an emitter).
    by_triangle: Vec<u32>,
}

fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

impl Lights {
    /// Collects emitters; `triangle_count` is the scene's triangle count.
    pub fn new(emitters: Vec<Emitter>, triangle_count: usize) -> Self {
        let weights: Vec<f64> = emitters
            .iter()
            .map(|e| {
                (luminance(e.radiance).max(1e-6) * e.area * if e.two_sided { 2.0 } else { 1.0 })
                    as f64
            })
            .collect();
        let table = if weights.is_empty() {
            AliasTable::default()
        } else {
            AliasTable::new(&weights)
        };
        let mut by_triangle = vec![u32::MAX; triangle_count];
        for (i, e) in emitters.iter().enumerate() {
            by_triangle[e.triangle as usize] = i as u32;
        }
        Self {
            emitters,
            table,
            by_triangle,
        }
    }

    /// True when there is nothing to sample.
    pub fn is_empty(&self) -> bool {
        self.emitters.is_empty()
    }

    /// Picks an emitter and a point on it.
    pub fn sample(
        &self,
        triangles: &[Triangle],
        u_pick: f32,
        u_point: Vec2,
    ) -> Option<LightSample> {
        if self.is_empty() {
            return None;
        }
        let i = self.table.sample(u_pick);
        let e = &self.emitters[i];
        let tri = &triangles[e.triangle as usize];
        let (b1, b2) = uniform_triangle(u_point);
        Some(LightSample {
            point: tri.point(b1, b2),
            normal: tri.normal().normalize(),
            radiance: e.radiance,
            two_sided: e.two_sided,
            pdf_area: self.table.pmf(i) / e.area,
        })
    }

    /// Area-measure pdf with which [`Lights::sample`] picks a point on `triangle`.
    pub fn pdf_area(&self, triangle: u32) -> f32 {
        match self.by_triangle.get(triangle as usize) {
            Some(&i) if i != u32::MAX => {
                self.table.pmf(i as usize) / self.emitters[i as usize].area
            }
            _ => 0.0,
        }
    }
}
