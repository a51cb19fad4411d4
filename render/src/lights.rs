//! Emitters and how next-event estimation picks them: every emissive triangle, chosen in
//! proportion to its power with an alias table (O(1) per sample whatever the count), then a
//! uniform point on it; and the environment, sampled by its own distribution. When both
//! exist each is picked half the time.

use crate::environment::Environment;
use crate::geometry::{STATIC, Triangle};
use crate::sampling::{AliasTable, uniform_triangle};
use glam::{Vec2, Vec3};

/// One emissive triangle.
#[derive(Clone, Copy, Debug)]
pub struct Emitter {
    pub triangle: u32,
    /// Moving instance the triangle belongs to, or [`crate::geometry::STATIC`].
    pub instance: u32,
    pub radiance: Vec3,
    pub two_sided: bool,
    /// The triangle as stored (world space when static, else object space).
    pub vertices: Triangle,
    /// Unit normal of the stored triangle.
    pub normal: Vec3,
    /// Area as stored (object space for a moving object); sets the selection weight, while
    /// sampling uses the world area at the ray's time.
    pub area: f32,
}

/// Where a light sample lies.
#[derive(Clone, Copy, Debug)]
pub enum LightPlace {
    /// A point on an emissive triangle, with its unit geometric normal (front side).
    Point {
        point: Vec3,
        normal: Vec3,
        two_sided: bool,
        /// The scene triangle it lies on.
        triangle: u32,
    },
    /// A direction towards the environment, infinitely far.
    Direction(Vec3),
}

/// A sampled light.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    pub place: LightPlace,
    pub radiance: Vec3,
    /// Area-measure pdf for a point, solid-angle pdf for a direction.
    pub pdf: f32,
}

/// All emitters of a scene.
#[derive(Clone, Debug, Default)]
pub struct Lights {
    pub emitters: Vec<Emitter>,
    table: AliasTable,
    /// Emitter index per scene triangle (u32::MAX: not an emitter).
    by_triangle: Vec<u32>,
    /// Light from where rays escape, if any.
    pub environment: Option<Environment>,
    /// Probability of sampling the environment rather than a triangle.
    environment_probability: f32,
}

fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

impl Lights {
    /// Collects emitters; `triangle_count` is the scene's triangle count.
    pub fn new(
        emitters: Vec<Emitter>,
        triangle_count: usize,
        environment: Option<Environment>,
    ) -> Self {
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
        let environment = environment.filter(|e| !e.is_black());
        let environment_probability = match (environment.is_some(), emitters.is_empty()) {
            (false, _) => 0.0,
            (true, true) => 1.0,
            (true, false) => 0.5,
        };
        Self {
            emitters,
            table,
            by_triangle,
            environment,
            environment_probability,
        }
    }

    /// True when there is nothing to sample.
    pub fn is_empty(&self) -> bool {
        self.emitters.is_empty() && self.environment.is_none()
    }

    /// Picks a light and a point (or direction) on it from one stratified 2-D sample: `u.x`
    /// chooses the light and is then rescaled to be reused for the point, so the light samples
    /// of a pixel stay stratified across the emitters' surface. `moving` gives the world-space
    /// triangle of an emitter on a moving object at the ray's time.
    pub fn sample(&self, u: Vec2, moving: impl Fn(&Emitter) -> Triangle) -> Option<LightSample> {
        let p_env = self.environment_probability;
        let on_environment = u.x < p_env;
        let u_point = if on_environment {
            Vec2::new(u.x / p_env, u.y)
        } else {
            Vec2::new((u.x - p_env) / (1.0 - p_env), u.y)
        };
        if let Some(env) = self.environment.as_ref().filter(|_| on_environment) {
            let s = env.sample(u_point);
            return (s.pdf > 0.0).then_some(LightSample {
                place: LightPlace::Direction(s.direction),
                radiance: s.radiance,
                pdf: p_env * s.pdf,
            });
        }
        if self.emitters.is_empty() {
            return None;
        }
        let (i, u_rest) = self.table.sample(u_point.x.clamp(0.0, 1.0 - f32::EPSILON));
        let u_point = Vec2::new(u_rest, u_point.y);
        let e = &self.emitters[i];
        let (tri, normal, area) = if e.instance == STATIC {
            (e.vertices, e.normal, e.area)
        } else {
            let tri = moving(e);
            let n = tri.normal();
            let area = 0.5 * n.length();
            (tri, n / (2.0 * area), area)
        };
        let (b1, b2) = uniform_triangle(u_point);
        (area > 0.0).then(|| LightSample {
            place: LightPlace::Point {
                point: tri.point(b1, b2),
                normal,
                two_sided: e.two_sided,
                triangle: e.triangle,
            },
            radiance: e.radiance,
            pdf: (1.0 - p_env) * self.table.pmf(i) / area,
        })
    }

    /// Solid-angle pdf with which [`Lights::sample`] picks environment direction `dir`.
    pub fn pdf_environment(&self, dir: Vec3) -> f32 {
        self.environment
            .as_ref()
            .map_or(0.0, |env| self.environment_probability * env.pdf(dir))
    }

    /// Area-measure pdf with which [`Lights::sample`] picks a point on `triangle`, whose world
    /// area is `area_scale` times its stored area.
    pub fn pdf_area(&self, triangle: u32, area_scale: f32) -> f32 {
        match self.by_triangle.get(triangle as usize) {
            Some(&i) if i != u32::MAX => {
                let e = &self.emitters[i as usize];
                (1.0 - self.environment_probability) * self.table.pmf(i as usize)
                    / (e.area * area_scale)
            }
            _ => 0.0,
        }
    }
}
