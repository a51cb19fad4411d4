//! The scene's ray queries over two levels: every static triangle, already in world space, in one
//! BVH; and each moving object in its own BVH under a top-level BVH of their bounds over the
//! rays' time interval. A static scene has no top level and pays nothing for motion.

use super::box_ray::{box_ray, from_box_t, to_box_t};
use super::instance::{MovingInstance, Placement};
use super::triangle::Triangle;
use super::triangle_bvh::{TriangleBvh, TriangleHit};
use crate::ray::Ray;
use obvhs::BvhBuildParams;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::builder::build_cwbvh;
use obvhs::ray::RayHit;

/// Marks a hit on static geometry.
pub const STATIC: u32 = u32::MAX;

/// The filter that admits every triangle.
#[inline(always)]
pub fn every_triangle(_triangle: u32, _t: f32) -> bool {
    true
}

/// A closest hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the (unit) world-space ray direction.
    pub t: f32,
    /// Scene-wide triangle index.
    pub triangle: u32,
    /// Moving instance that was hit, or [`STATIC`].
    pub instance: u32,
    /// Barycentrics: p = (1 − b1 − b2)·v0 + b1·v1 + b2·v2.
    pub b1: f32,
    pub b2: f32,
}

/// Static world-space triangles plus moving instances.
pub struct Accel {
    statics: TriangleBvh,
    instances: Vec<MovingInstance>,
    top: Option<CwBvh>,
}

impl Accel {
    /// `statics` are world-space triangles with scene-wide indices from 0.
    pub fn build(statics: &[Triangle], instances: Vec<MovingInstance>) -> Self {
        let top = (!instances.is_empty()).then(|| {
            let bounds: Vec<_> = instances.iter().map(|i| i.bounds).collect();
            build_cwbvh(
                &bounds,
                BvhBuildParams::medium_build(),
                &mut Default::default(),
            )
        });
        Self {
            statics: TriangleBvh::build(statics, 0),
            instances,
            top,
        }
    }

    /// True when some geometry moves.
    pub fn has_motion(&self) -> bool {
        !self.instances.is_empty()
    }

    /// Placement of moving instance `i` at time `t`.
    pub fn placement(&self, instance: u32, t: f64) -> Placement {
        self.instances[instance as usize].placement(t)
    }

    /// Closest hit along `ray` (which starts at its origin: t in (0, t_max)) among the
    /// triangles `accept(triangle, t)` admits ([`every_triangle`] for all).
    pub fn intersect(&self, ray: &Ray, accept: &impl Fn(u32, f32) -> bool) -> Option<Hit> {
        debug_assert!(ray.t_min == 0.0);
        let mut best = self
            .statics
            .intersect(ray.origin, ray.dir, ray.t_max, accept)
            .map(|h| lift(h, STATIC));
        if let Some(top) = &self.top {
            let nearest = best.map_or(ray.t_max, |h| h.t);
            let box_ray = top_ray(ray, nearest);
            let mut top_hit = RayHit::none();
            top.ray_traverse(box_ray, &mut top_hit, |r, leaf| {
                let i = top.primitive_indices[leaf];
                let bounded = Ray {
                    t_max: from_box_t(r.tmax),
                    ..*ray
                };
                match self.instances[i as usize].intersect(&bounded, accept) {
                    Some(h) => {
                        best = Some(lift(h, i));
                        to_box_t(h.t)
                    }
                    None => f32::INFINITY,
                }
            });
        }
        best
    }

    /// True when an admitted triangle lies along `ray` (t in (0, t_max)).
    pub fn occluded(&self, ray: &Ray, accept: &impl Fn(u32, f32) -> bool) -> bool {
        debug_assert!(ray.t_min == 0.0);
        if self
            .statics
            .occluded(ray.origin, ray.dir, ray.t_max, accept)
        {
            return true;
        }
        let Some(top) = &self.top else {
            return false;
        };
        !top.ray_traverse_miss(top_ray(ray, ray.t_max), |_, leaf| {
            let i = top.primitive_indices[leaf] as usize;
            if self.instances[i].occluded(ray, accept) {
                0.0
            } else {
                f32::INFINITY
            }
        })
    }
}

/// `ray` as obvhs traverses the top level, up to `t_max`.
fn top_ray(ray: &Ray, t_max: f32) -> obvhs::ray::Ray {
    box_ray(ray.origin, ray.dir, t_max)
}

fn lift(h: TriangleHit, instance: u32) -> Hit {
    Hit {
        t: h.t,
        triangle: h.triangle,
        instance,
        b1: h.b1,
        b2: h.b2,
    }
}
