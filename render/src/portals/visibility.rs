//! Which surfaces a ray may hit: per-object visibility flags by the kind of ray looking, and
//! cull volumes behind portal openings that hide linked objects where they poke out the back.
//!
//! An object passing through an opening is modelled as two objects: the original on the here
//! side and its there-side copy placed by the constraint solver. The part of the original that
//! has gone through pokes out behind the here opening, and the part of the copy that has not
//! come out yet sits behind the exit; a cull volume on each side hides exactly those parts, for
//! every kind of ray (so they cast no shadows either).
//!
//! Filtering happens inside BVH traversal: a hidden surface is looked through, and the search
//! goes on behind it. A scene that hides nothing never calls the filter.

use glam::{Affine3A, DVec3, Vec3};
use rift_fx::rig::{Rig, Similarity};
use std::sync::Arc;

/// The kind of ray looking, for the per-object flags. Every ray is exactly one of them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayClass {
    /// A camera ray that has not passed an opening.
    Camera,
    /// A camera ray that has passed one or more openings (before any scattering).
    ThroughPortal,
    /// A ray leaving a scattering event, through openings or not.
    Indirect,
    /// A shadow ray of light sampling.
    Shadow,
}

/// Which kinds of ray see an object.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Flags(u8);

impl Flags {
    /// Seen by every ray.
    pub const ALL: Self = Self(0b1111);

    pub fn new(camera: bool, through_portal: bool, indirect: bool, shadow: bool) -> Self {
        Self(
            camera as u8
                | (through_portal as u8) << 1
                | (indirect as u8) << 2
                | (shadow as u8) << 3,
        )
    }

    /// True when rays of `class` see the object.
    #[inline]
    pub fn sees(self, class: RayClass) -> bool {
        self.0 & (1 << class as u8) != 0
    }

    /// These flags with rays of `class` no longer seeing the object.
    pub fn without(self, class: RayClass) -> Self {
        Self(self.0 & !(1 << class as u8))
    }
}

/// Which side of an opening a cull volume lies behind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// Behind the here opening: its local −Z.
    Here,
    /// Behind the exit: the there frame's local +Z (rays leave towards its −Z).
    There,
}

/// A cylinder behind one side of an opening, in the opening's local units: points at most
/// `depth` behind its plane (strictly behind) and within `radius` of its axis. Either may be
/// infinite.
#[derive(Clone, Debug, PartialEq)]
pub struct CullVolume {
    pub opening: usize,
    pub side: Side,
    pub depth: f64,
    pub radius: f64,
    /// Indices of the objects it hides.
    pub objects: Vec<u32>,
}

impl CullVolume {
    /// True when the opening-local point `q` lies inside.
    fn contains_local(&self, q: DVec3) -> bool {
        let behind = match self.side {
            Side::Here => -q.z,
            Side::There => q.z,
        };
        behind > 0.0 && behind <= self.depth && q.x * q.x + q.y * q.y <= self.radius * self.radius
    }

    /// The volume's frame at time `t` (local to world).
    fn frame(&self, rig: &Rig, t: f64) -> Similarity {
        match self.side {
            Side::Here => rig.here_at(self.opening, t),
            Side::There => rig.there_at(self.opening, t),
        }
    }
}

/// The visibility rules of a scene.
#[derive(Clone, Debug, Default)]
pub struct Visibility {
    /// Object index per scene triangle, shared with the scene (empty when nothing is
    /// hidden).
    triangle_object: Arc<[u32]>,
    /// Flags per object.
    flags: Vec<Flags>,
    /// Indices into `volumes` per object.
    culls: Vec<Vec<u32>>,
    volumes: Vec<CullVolume>,
    /// World to each volume's local frame, when no opening moves.
    fixed: Option<Vec<Affine3A>>,
    rig: Arc<Rig>,
}

impl Visibility {
    /// Rules for objects with `flags` (one per object), whose triangles belong to the objects
    /// in `triangle_object`, and the cull `volumes` of `rig`'s openings. `fixed_time` evaluates
    /// the frames once when `moving` is false.
    pub fn new(
        triangle_object: Arc<[u32]>,
        flags: Vec<Flags>,
        volumes: Vec<CullVolume>,
        rig: Arc<Rig>,
        moving: bool,
        fixed_time: f64,
    ) -> Self {
        if volumes.is_empty() && flags.iter().all(|&f| f == Flags::ALL) {
            return Self::default();
        }
        let mut culls = vec![Vec::new(); flags.len()];
        for (v, volume) in volumes.iter().enumerate() {
            for &o in &volume.objects {
                culls[o as usize].push(v as u32);
            }
        }
        let fixed = (!moving).then(|| {
            volumes
                .iter()
                .map(|v| {
                    let to_local = v.frame(&rig, fixed_time).inverse();
                    Affine3A::from_mat4(to_local.to_mat4().as_mat4())
                })
                .collect()
        });
        Self {
            triangle_object,
            flags,
            culls,
            volumes,
            fixed,
            rig,
        }
    }

    /// True when some object is hidden from some ray: only then does traversal filter.
    #[inline]
    pub fn hides_anything(&self) -> bool {
        !self.triangle_object.is_empty()
    }

    /// True when rays of `class` see `triangle`'s object at all.
    #[inline]
    pub fn sees(&self, triangle: u32, class: RayClass) -> bool {
        self.seen(self.object(triangle), class)
    }

    /// True when rays of `class` see object `object` at all.
    pub fn object_seen(&self, object: u32, class: RayClass) -> bool {
        self.seen(object as usize, class)
    }

    #[inline]
    fn seen(&self, object: usize, class: RayClass) -> bool {
        self.flags.get(object).is_none_or(|f| f.sees(class))
    }

    /// True when a ray of `class` at time `time` may hit `triangle` at world point `p`.
    #[inline]
    pub fn admits(&self, triangle: u32, class: RayClass, p: Vec3, time: f64) -> bool {
        self.sees(triangle, class) && !self.culled(triangle, p, time)
    }

    /// True when `triangle`'s surface at world point `p` lies in one of its object's cull
    /// volumes at time `time`. Scenes without cull volumes answer inline, per light sample.
    #[inline(always)]
    pub fn culled(&self, triangle: u32, p: Vec3, time: f64) -> bool {
        !self.volumes.is_empty() && self.in_cull_volume(triangle, p, time)
    }

    fn in_cull_volume(&self, triangle: u32, p: Vec3, time: f64) -> bool {
        let Some(culls) = self.culls.get(self.object(triangle)) else {
            return false;
        };
        culls.iter().any(|&v| {
            let volume = &self.volumes[v as usize];
            let local = match &self.fixed {
                Some(f) => f[v as usize].transform_point3(p).as_dvec3(),
                None => volume
                    .frame(&self.rig, time)
                    .inverse()
                    .transform_point(p.as_dvec3()),
            };
            volume.contains_local(local)
        })
    }

    /// The cull volumes that hide object `object`, at `time`: each volume's frame (local to
    /// world; the here or there frame of the opening it belongs to), that opening, which side
    /// of it is behind (1 for the here side's −Z, −1 for the there side's +Z), its depth and
    /// its radius (for previews that clip as the renderer does).
    pub fn culls_of(&self, object: u32, time: f64) -> Vec<(Similarity, usize, f64, f64, f64)> {
        let Some(culls) = self.culls.get(object as usize) else {
            return Vec::new();
        };
        culls
            .iter()
            .map(|&v| {
                let volume = &self.volumes[v as usize];
                let sign = match volume.side {
                    Side::Here => 1.0,
                    Side::There => -1.0,
                };
                (
                    volume.frame(&self.rig, time),
                    volume.opening,
                    sign,
                    volume.depth,
                    volume.radius,
                )
            })
            .collect()
    }

    fn object(&self, triangle: u32) -> usize {
        self.triangle_object
            .get(triangle as usize)
            .map_or(usize::MAX, |&o| o as usize)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rift_fx::rig::{AnimatedTransform, Opening, ThereFrame};

    fn rig() -> Arc<Rig> {
        let here = Similarity::from_translation(DVec3::new(0.0, 0.0, -3.0));
        let there = Similarity::from_translation(DVec3::new(40.0, 0.0, 0.0));
        Arc::new(Rig {
            openings: vec![Opening {
                name: "door".into(),
                here: AnimatedTransform::constant(here),
                there: ThereFrame::Explicit(AnimatedTransform::constant(there)),
            }],
        })
    }

    #[test]
    fn flags_pick_ray_classes() {
        let f = Flags::new(false, true, true, false);
        assert!(!f.sees(RayClass::Camera));
        assert!(f.sees(RayClass::ThroughPortal));
        assert!(f.sees(RayClass::Indirect));
        assert!(!f.sees(RayClass::Shadow));
        assert!(
            [
                RayClass::Camera,
                RayClass::ThroughPortal,
                RayClass::Indirect,
                RayClass::Shadow
            ]
            .iter()
            .all(|&c| Flags::ALL.sees(c))
        );
    }

    #[test]
    fn cull_volumes_hide_only_linked_objects_behind_their_side() {
        let volume = |side, depth, radius| CullVolume {
            opening: 0,
            side,
            depth,
            radius,
            objects: vec![1],
        };
        for moving in [false, true] {
            let vis = Visibility::new(
                vec![0, 1].into(),
                vec![Flags::ALL; 2],
                vec![
                    volume(Side::Here, 1.0, 2.0),
                    volume(Side::There, f64::INFINITY, f64::INFINITY),
                ],
                rig(),
                moving,
                0.0,
            );
            assert!(vis.hides_anything());
            let behind_here = Vec3::new(0.5, 0.0, -3.5);
            // Object 0 is not linked; object 1 is hidden behind the here opening only within
            // the cylinder's depth and radius, and not in front of it.
            assert!(!vis.culled(0, behind_here, 0.0));
            assert!(vis.culled(1, behind_here, 0.0));
            assert!(!vis.culled(1, Vec3::new(0.5, 0.0, -4.5), 0.0));
            assert!(!vis.culled(1, Vec3::new(2.5, 0.0, -3.5), 0.0));
            assert!(!vis.culled(1, Vec3::new(0.5, 0.0, -2.5), 0.0));
            // Behind the exit is the there frame's +Z, unbounded here.
            assert!(vis.culled(1, Vec3::new(45.0, 3.0, 100.0), 0.0));
            assert!(!vis.culled(1, Vec3::new(45.0, 3.0, -0.5), 0.0));
            assert!(!vis.admits(1, RayClass::Camera, behind_here, 0.0));
        }
        let nothing = Visibility::new(
            vec![0, 0].into(),
            vec![Flags::ALL],
            vec![],
            rig(),
            false,
            0.0,
        );
        assert!(!nothing.hides_anything());
        assert!(nothing.admits(1, RayClass::Shadow, Vec3::ZERO, 0.0));
    }
}
