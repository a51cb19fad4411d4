//! The scene's ray queries over two levels: every static triangle, already in world space, in one
//! BVH; and each moving object in its own BVH under a top-level BVH of their bounds over the
//! rays' time interval. A static scene has no top level and pays nothing for motion.

use super::build::wide_bvh;
use super::instance::{MovingInstance, Placement};
use super::triangle::Triangle;
use super::triangle_bvh::{TriangleBvh, TriangleHit};
use super::wide_bvh::{BoxRay, Fixed, any_hit, closest_hit, node_bytes, worth_fetching_ahead};
use crate::geometry::ray::Ray;
use obvhs::BvhBuildParams;
use obvhs::cwbvh::CwBvh;
use rift_fx::rig::Similarity;

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
            wide_bvh(&bounds, BvhBuildParams::medium_build())
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

    /// Where moving instance `instance` is at `t`, exactly (for display and export; rays use
    /// [`Self::placement`]).
    pub fn instance_at(&self, instance: u32, t: f64) -> Similarity {
        self.instances[instance as usize].at(t)
    }

    /// Triangle `i` of moving instance `instance` in object space at time `t`, where that
    /// instance deforms (`None` otherwise: the scene's stored triangle is its shape).
    #[inline]
    pub fn deformed_triangle(&self, instance: u32, i: u32, t: f64) -> Option<Triangle> {
        self.instances
            .get(instance as usize)?
            .deformed_triangle(i, t)
    }

    /// The shading normal of triangle `i` of moving instance `instance` at time `t` and
    /// barycentrics `b1`, `b2`, in object space, where that instance deforms with normals.
    #[inline]
    pub fn deformed_normal(
        &self,
        instance: u32,
        i: u32,
        t: f64,
        (b1, b2): (f32, f32),
    ) -> Option<glam::Vec3> {
        self.instances
            .get(instance as usize)?
            .deformed_normal(i, t, b1, b2)
    }

    /// Triangle `i` in object space at time `t`, found among the deforming instances (a slow
    /// search, for tools that do not know the triangle's instance); `None` when no deforming
    /// instance holds it.
    pub fn find_deformed(&self, i: u32, t: f64) -> Option<Triangle> {
        self.instances.iter().find_map(|m| m.holds_deformed(i, t))
    }

    /// Bytes the deformations of the instances hold, each shared one counted once.
    pub fn deformation_bytes(&self) -> usize {
        super::deforming::shared_bytes(
            self.instances
                .iter()
                .filter_map(MovingInstance::deformation),
        )
    }

    /// True when some instance changes shape with time.
    pub fn has_deformation(&self) -> bool {
        self.instances.iter().any(MovingInstance::deforms)
    }

    /// Closest hit along `ray` (which starts at its origin: t in (0, t_max)) among the
    /// triangles `accept(triangle, t)` admits ([`every_triangle`] for all).
    pub fn intersect(&self, ray: &Ray, accept: &impl Fn(u32, f32) -> bool) -> Option<Hit> {
        debug_assert!(ray.t_min == 0.0);
        // The static triangles' hit goes straight out where nothing moves: kept in a variable
        // that the moving instances' test also writes, it lived on the stack, and its copy
        // out read the fields' separate stores with wider loads, which had to wait for them.
        match &self.top {
            None => self.static_hit(ray, accept),
            Some(top) => self.intersect_moving(top, ray, accept),
        }
    }

    /// The closest hit along `ray` among the static triangles.
    #[inline(always)]
    fn static_hit(&self, ray: &Ray, accept: &impl Fn(u32, f32) -> bool) -> Option<Hit> {
        self.statics
            .intersect(ray.origin, ray.dir, ray.t_max, accept)
            .map(|h| lift(h, STATIC))
    }

    /// The closest hit along `ray` among the static triangles and the moving instances of
    /// `top`.
    #[inline(never)]
    fn intersect_moving(
        &self,
        top: &CwBvh,
        ray: &Ray,
        accept: &impl Fn(u32, f32) -> bool,
    ) -> Option<Hit> {
        let mut best = self.static_hit(ray, accept);
        let nearest = best.map_or(ray.t_max, |h| h.t);
        closest_hit(
            &top.nodes,
            &Fixed,
            &BoxRay::new(ray.origin, ray.dir),
            nearest,
            NOTHING_TO_FETCH,
            worth_fetching_ahead(node_bytes(top)),
            |slot, range| {
                let i = top.primitive_indices[slot];
                let bounded = Ray {
                    t_max: range,
                    ..*ray
                };
                let h = self.instances[i as usize].intersect(&bounded, accept)?;
                best = Some(lift(h, i));
                Some(h.t)
            },
        );
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
        any_hit(
            &top.nodes,
            &Fixed,
            &BoxRay::new(ray.origin, ray.dir),
            ray.t_max,
            NOTHING_TO_FETCH,
            worth_fetching_ahead(node_bytes(top)),
            |slot| self.instances[top.primitive_indices[slot] as usize].occluded(ray, accept),
        )
    }
}

/// The top level's leaf test reads instances through `primitive_indices`, not by slot, so
/// there is nothing to fetch ahead by slot.
const NOTHING_TO_FETCH: &[MovingInstance] = &[];

fn lift(h: TriangleHit, instance: u32) -> Hit {
    Hit {
        t: h.t,
        triangle: h.triangle,
        instance,
        b1: h.b1,
        b2: h.b2,
    }
}
