//! A moving or instanced object: its triangles in object space under their own BVH, placed in
//! the world by a keyframed similarity that is evaluated at each ray's time. Rays are taken into
//! object space rather than the triangles into world space, so motion blur costs one transform
//! per visit. The instances of one prototype share its BVH (and its triangles in the scene), so
//! a hundred thousand of them cost their placements and little more; one that stands still
//! keeps its placement ready rather than evaluating keys per ray.
//! A deforming object's triangles also change shape with time ([`Deformation`], shared by its
//! copies); each copy reads the shape at its own time (a copy through an opening that delays
//! rays sees the object as it was that much earlier).

use super::deforming::Deformation;
use super::motion::ObjectMotion;
use super::triangle::Triangle;
use super::triangle_bvh::{TriangleBvh, TriangleHit};
use crate::geometry::ray::Ray;
use glam::{Affine3A, Vec3, Vec3A};
use obvhs::aabb::Aabb;
use rift_fx::rig::Similarity;
use std::sync::Arc;

/// Times at which the world bounds are sampled across the time interval rays may have.
const BOUND_STEPS: usize = 64;

/// An object with a time-varying placement.
pub struct MovingInstance {
    transform: ObjectMotion,
    /// The placement at every time, where it does not change over the rays' times.
    fixed: Option<Placement>,
    shape: Shape,
    /// World bounds over every time a ray can have.
    pub bounds: Aabb,
}

/// An instance's triangles in object space.
enum Shape {
    /// Shared by every instance of one prototype.
    Rigid(Arc<TriangleBvh>),
    /// Scene-wide indices of its triangles start at `first_id`.
    Deforming {
        mesh: Arc<Deformation>,
        first_id: u32,
    },
}

/// The placement of an instance at one time, in f32 for the hot path.
#[derive(Clone, Copy, Debug)]
pub struct Placement {
    pub to_world: Affine3A,
    pub to_object: Affine3A,
    /// Uniform scale (areas scale by its square).
    pub scale: f32,
}

impl Placement {
    fn new(s: &Similarity) -> Self {
        let affine = |s: &Similarity| Affine3A::from_mat4(s.to_mat4().as_mat4());
        Self {
            to_world: affine(s),
            to_object: affine(&s.inverse()),
            scale: s.scale as f32,
        }
    }
}

impl MovingInstance {
    /// `triangles` in object space with scene-wide indices from `first_id`; `times` is the
    /// interval rays may have (the shutter, widened by any time offsets).
    pub fn new(
        triangles: &[Triangle],
        first_id: u32,
        transform: ObjectMotion,
        times: [f64; 2],
    ) -> Self {
        let shape = TriangleBvh::build(triangles, first_id);
        Self::sharing(
            &Arc::new(shape),
            &object_corners(triangles),
            transform,
            times,
        )
    }

    /// An instance of the prototype under `bvh`, whose object-space box has the `corners`,
    /// placed by `transform`; `times` as for [`Self::new`].
    pub fn sharing(
        bvh: &Arc<TriangleBvh>,
        corners: &[Vec3; 8],
        transform: ObjectMotion,
        times: [f64; 2],
    ) -> Self {
        Self::placed(Shape::Rigid(bvh.clone()), corners, transform, times)
    }

    /// A deforming object's copy at `transform`, its triangles (scene-wide indices from
    /// `first_id`) read from `mesh` at the copy's own time; `times` as for [`Self::new`].
    pub fn deforming(
        mesh: Arc<Deformation>,
        first_id: u32,
        transform: ObjectMotion,
        times: [f64; 2],
    ) -> Self {
        let corners = box_corners(mesh.bounds.min.into(), mesh.bounds.max.into());
        Self::placed(
            Shape::Deforming { mesh, first_id },
            &corners,
            transform,
            times,
        )
    }

    /// `shape`, whose object-space box has the `corners`, placed by `transform`, with its
    /// world bounds over `times`.
    fn placed(shape: Shape, corners: &[Vec3; 8], transform: ObjectMotion, times: [f64; 2]) -> Self {
        let fixed = (!transform.moves_during(times)).then(|| transform.at(times[0]));
        let bounds = match &fixed {
            Some(s) => swept_bounds(corners, |_| *s, &[], times, 1),
            None => swept_bounds(
                corners,
                |t| transform.at(t),
                &transform.key_times(),
                times,
                BOUND_STEPS,
            ),
        };
        Self {
            fixed: fixed.as_ref().map(Placement::new),
            transform,
            shape,
            bounds,
        }
    }

    /// True when the instance's triangles change shape with time.
    pub fn deforms(&self) -> bool {
        self.deformation().is_some()
    }

    /// Triangle `i` (scene-wide) in object space at time `t`, where this instance deforms and
    /// holds it (`None` otherwise).
    pub fn holds_deformed(&self, i: u32, t: f64) -> Option<Triangle> {
        match &self.shape {
            Shape::Deforming { mesh, first_id }
                if i >= *first_id && ((i - first_id) as usize) < mesh.triangle_count() =>
            {
                self.deformed_triangle(i, t)
            }
            _ => None,
        }
    }

    /// The shape over time of a deforming instance (shared with its copies).
    pub fn deformation(&self) -> Option<&Arc<Deformation>> {
        match &self.shape {
            Shape::Rigid(_) => None,
            Shape::Deforming { mesh, .. } => Some(mesh),
        }
    }

    /// Triangle `i` (scene-wide) in object space at time `t`, where the instance deforms;
    /// `None` for a rigid instance (its triangles are the scene's).
    #[inline]
    pub fn deformed_triangle(&self, i: u32, t: f64) -> Option<Triangle> {
        match &self.shape {
            Shape::Rigid(_) => None,
            Shape::Deforming { mesh, first_id } => {
                Some(mesh.triangle(i - first_id, self.transform.source_time(t)))
            }
        }
    }

    /// The shading normal of triangle `i` at time `t` and barycentrics `b1`, `b2` in object
    /// space (not unit length), where the instance deforms with normals (`None` otherwise).
    pub fn deformed_normal(&self, i: u32, t: f64, b1: f32, b2: f32) -> Option<Vec3> {
        match &self.shape {
            Shape::Rigid(_) => None,
            Shape::Deforming { mesh, first_id } => {
                mesh.normal(i - first_id, self.transform.source_time(t), b1, b2)
            }
        }
    }

    /// The placement at time `t`.
    #[inline]
    /// Where the instance is at `t`.
    pub fn at(&self, t: f64) -> Similarity {
        self.transform.at(t)
    }

    pub fn placement(&self, t: f64) -> Placement {
        match self.fixed {
            Some(p) => p,
            None => Placement::new(&self.transform.at(t)),
        }
    }

    /// A world-space ray's origin and direction in object space at its time (direction not
    /// renormalised, so ray parameters stay in world units).
    fn object_ray(&self, ray: &Ray) -> (Vec3, Vec3) {
        let to_object = self.placement(ray.time).to_object;
        (
            to_object.transform_point3(ray.origin),
            to_object.transform_vector3(ray.dir),
        )
    }

    /// Closest hit of the world-space `ray` (t in (0, t_max)) among the triangles
    /// `accept(triangle, t)` admits; t is in world units because the object-space direction is
    /// not renormalised.
    pub fn intersect(&self, ray: &Ray, accept: &impl Fn(u32, f32) -> bool) -> Option<TriangleHit> {
        let (o, d) = self.object_ray(ray);
        match &self.shape {
            Shape::Rigid(bvh) => bvh.intersect(o, d, ray.t_max, accept),
            Shape::Deforming { mesh, first_id } => {
                let time = self.transform.source_time(ray.time);
                mesh.intersect((o, d), ray.t_max, time, *first_id, accept)
            }
        }
    }

    /// True when an admitted triangle of the object blocks `ray` (t in (0, t_max)).
    pub fn occluded(&self, ray: &Ray, accept: &impl Fn(u32, f32) -> bool) -> bool {
        let (o, d) = self.object_ray(ray);
        match &self.shape {
            Shape::Rigid(bvh) => bvh.occluded(o, d, ray.t_max, accept),
            Shape::Deforming { mesh, first_id } => {
                let time = self.transform.source_time(ray.time);
                mesh.occluded((o, d), ray.t_max, time, *first_id, accept)
            }
        }
    }
}

/// World bounds of `points` (object space) placed by `at(t)` for every t in `times`: the
/// points at `steps + 1` sampled times and at the keys inside, padded by twice the largest step
/// a point makes between samples, so the curved motion between samples stays inside. Given the
/// corners of an object-space box, a similarity maps it to a box whose corners bound the
/// object, so the result bounds the object too.
pub(crate) fn swept_bounds(
    points: &[Vec3],
    at: impl Fn(f64) -> Similarity,
    key_times: &[f64],
    times: [f64; 2],
    steps: usize,
) -> Aabb {
    let placed = |t: f64| {
        let s = at(t);
        points
            .iter()
            .map(move |c| s.transform_point(c.as_dvec3()).as_vec3())
    };
    let mut bounds = Aabb::empty();
    let mut previous: Vec<Vec3> = placed(times[0]).collect();
    let mut pad = 0.0f32;
    for i in 0..=steps {
        let t = times[0] + (times[1] - times[0]) * i as f64 / steps as f64;
        for (a, b) in placed(t).zip(previous.iter_mut()) {
            bounds.extend(Vec3A::from(a));
            pad = pad.max(2.0 * a.distance(*b));
            *b = a;
        }
    }
    for &key in key_times {
        if key > times[0] && key < times[1] {
            for c in placed(key) {
                bounds.extend(Vec3A::from(c));
            }
        }
    }
    bounds.min -= Vec3A::splat(pad);
    bounds.max += Vec3A::splat(pad);
    bounds
}

/// The eight corners of the triangles' object-space box (a prototype's, for
/// [`MovingInstance::sharing`]).
pub(crate) fn object_corners(triangles: &[Triangle]) -> [Vec3; 8] {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for v in triangles.iter().flat_map(|t| t.v) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    box_corners(lo, hi)
}

/// The eight corners of the box [lo, hi].
pub(crate) fn box_corners(lo: Vec3, hi: Vec3) -> [Vec3; 8] {
    std::array::from_fn(|i| {
        Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    })
}
