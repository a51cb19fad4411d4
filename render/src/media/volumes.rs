//! Where the media are: an ambient medium filling the scene (optional) and media inside closed
//! meshes, which must stand still and not overlap. A closed mesh's triangles are its medium's
//! boundary: paths cross them without scattering (entering against the outward normal, leaving
//! with it), and shadow rays pass them, attenuated by the optical depth of each stretch they
//! spend in each medium.
//!
//! Which medium holds a point is read off the first boundary a ray from it meets: leaving a
//! medium's mesh means the point was inside it. This needs no parity count, so a ray grazing
//! an edge shared by two triangles (met twice at one distance) cannot confuse it.

use crate::geometry::{Triangle, TriangleBvh};
use crate::media::grid::{GridMedia, Rng};
use crate::media::homogeneous::Medium;
use glam::Vec3;

/// The medium at a point.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Inside {
    /// Outside every bounded medium: in the ambient medium, or in vacuum without one.
    #[default]
    Ambient,
    /// Inside bounded medium `i`.
    Bounded(u32),
}

/// A medium inside a closed mesh.
pub struct Bounded {
    pub medium: Medium,
    /// The mesh in world space, outward normals (counter-clockwise seen from outside).
    triangles: Vec<Triangle>,
    bvh: TriangleBvh,
    lower: Vec3,
    upper: Vec3,
}

impl Bounded {
    /// The medium `medium` inside the closed mesh `triangles` (world space).
    pub fn new(medium: Medium, triangles: Vec<Triangle>) -> Self {
        let corners = triangles.iter().flat_map(|t| t.v);
        let lower = corners.clone().fold(Vec3::INFINITY, Vec3::min);
        let upper = corners.fold(Vec3::NEG_INFINITY, Vec3::max);
        Self {
            medium,
            bvh: TriangleBvh::build(&triangles, 0),
            triangles,
            lower,
            upper,
        }
    }

    /// True when the bounding boxes of the two meshes overlap.
    pub fn overlaps(&self, other: &Bounded) -> bool {
        self.lower.cmple(other.upper).all() && other.lower.cmple(self.upper).all()
    }

    /// The boundary crossings along `origin + t·dir` past `after`: (distance, entering).
    fn next_crossing(&self, origin: Vec3, dir: Vec3, after: f32) -> Option<(f32, bool)> {
        let past = |_: u32, t: f32| t > after;
        let hit = self.bvh.intersect(origin, dir, f32::INFINITY, &past)?;
        let normal = self.triangles[hit.triangle as usize].normal();
        Some((hit.t, normal.dot(dir) < 0.0))
    }

    /// True when `p` lies inside (its first boundary along a fixed direction is left).
    fn contains(&self, p: Vec3) -> bool {
        if p.cmplt(self.lower).any() || p.cmpgt(self.upper).any() {
            return false;
        }
        // Not along an axis, so axis-aligned meshes are not met edge-on.
        let dir = Vec3::new(0.5773, 0.5774, 0.5775).normalize();
        matches!(self.next_crossing(p, dir, 0.0), Some((_, false)))
    }

    /// The length of `origin + t·dir`, t in [0, `length`], that lies inside.
    fn length_inside(&self, origin: Vec3, dir: Vec3, length: f32) -> f32 {
        let end = origin + dir * length.min(1e30);
        let (lo, hi) = (origin.min(end), origin.max(end));
        if hi.cmplt(self.lower).any() || lo.cmpgt(self.upper).any() {
            return 0.0;
        }
        let mut inside_from: Option<f32> = None;
        let mut total = 0.0;
        let mut after = 0.0;
        let mut first = true;
        while let Some((t, entering)) = self.next_crossing(origin, dir, after) {
            if first && !entering {
                // The first crossing leaves: the segment starts inside.
                inside_from = Some(0.0);
            }
            first = false;
            if t >= length {
                break;
            }
            if entering {
                inside_from.get_or_insert(t);
            } else if let Some(from) = inside_from.take() {
                total += t - from;
            }
            after = t;
        }
        if let Some(from) = inside_from {
            total += length - from;
        }
        total
    }
}

/// Every medium of a scene and where it is.
#[derive(Default)]
pub struct Volumes {
    /// The medium outside every bounded one, if any.
    pub ambient: Option<Medium>,
    pub bounded: Vec<Bounded>,
    /// Density grids, anywhere (they add to the medium they are in).
    pub grids: GridMedia,
    /// Per scene triangle: the bounded medium it bounds, or [`NO_MEDIUM`] (empty when no
    /// medium is bounded).
    triangle_boundary: Vec<u32>,
}

/// A triangle that bounds no medium.
pub const NO_MEDIUM: u32 = u32::MAX;

impl Volumes {
    /// `ambient` around the `bounded` media, whose boundaries are the scene triangles that
    /// `triangle_boundary` maps to them (the rest to [`NO_MEDIUM`]).
    pub fn new(
        ambient: Option<Medium>,
        bounded: Vec<Bounded>,
        triangle_boundary: Vec<u32>,
        grids: GridMedia,
    ) -> Self {
        let triangle_boundary = if bounded.is_empty() {
            Vec::new()
        } else {
            triangle_boundary
        };
        Self {
            ambient,
            bounded,
            grids,
            triangle_boundary,
        }
    }

    /// True when there is no medium at all (paths never look).
    pub fn is_empty(&self) -> bool {
        self.ambient.is_none() && self.bounded.is_empty() && self.grids.is_empty()
    }

    /// The medium at `inside` (`None`: vacuum).
    #[inline]
    pub fn medium(&self, inside: Inside) -> Option<&Medium> {
        match inside {
            Inside::Ambient => self.ambient.as_ref(),
            Inside::Bounded(i) => Some(&self.bounded[i as usize].medium),
        }
    }

    /// The medium holding `p`.
    pub fn at_point(&self, p: Vec3) -> Inside {
        self.bounded
            .iter()
            .position(|b| b.contains(p))
            .map_or(Inside::Ambient, |i| Inside::Bounded(i as u32))
    }

    /// The bounded medium that scene triangle `triangle` bounds, if any.
    #[inline]
    pub fn boundary(&self, triangle: u32) -> Option<u32> {
        match self.triangle_boundary.get(triangle as usize) {
            Some(&m) if m != NO_MEDIUM => Some(m),
            _ => None,
        }
    }

    /// Where a path is after crossing the boundary of medium `medium` along `dir` through a
    /// triangle with normal `normal` (outward).
    pub fn crossed(&self, medium: u32, dir: Vec3, normal: Vec3) -> Inside {
        if normal.dot(dir) < 0.0 {
            Inside::Bounded(medium)
        } else {
            Inside::Ambient
        }
    }

    /// Transmittance along the straight stretch `origin + t·dir`, t in [0, `length`] (∞ allowed),
    /// at `time`, through every medium it passes (the grids' by ratio tracking, seeded by the
    /// ray).
    pub fn transmittance(&self, origin: Vec3, dir: Vec3, length: f32, time: f64) -> Vec3 {
        let mut t = self.homogeneous_transmittance(origin, dir, length);
        if !self.grids.is_empty() && t != Vec3::ZERO {
            let mut rng = Rng::from_ray(origin, dir);
            t *= self
                .grids
                .transmittance(origin, dir, time, 0.0, length, &mut rng);
        }
        t
    }

    /// Transmittance through the homogeneous media alone.
    fn homogeneous_transmittance(&self, origin: Vec3, dir: Vec3, length: f32) -> Vec3 {
        let mut depth = Vec3::ZERO;
        let mut inside_any = 0.0;
        for b in &self.bounded {
            let inside = b.length_inside(origin, dir, length);
            if inside > 0.0 {
                depth += b.medium.extinction * inside;
                inside_any += inside;
            }
        }
        let mut t = (-depth).exp();
        if let Some(ambient) = &self.ambient {
            let outside = if length.is_finite() {
                (length - inside_any).max(0.0)
            } else {
                f32::INFINITY
            };
            t *= ambient.transmittance(outside);
        }
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube(lo: f32, hi: f32) -> Vec<Triangle> {
        let c = |i: usize| {
            Vec3::new(
                if i & 1 == 0 { lo } else { hi },
                if i & 2 == 0 { lo } else { hi },
                if i & 4 == 0 { lo } else { hi },
            )
        };
        // Quads wound counter-clockwise seen from outside.
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        quads
            .iter()
            .flat_map(|q| {
                [
                    Triangle {
                        v: [c(q[0]), c(q[1]), c(q[2])],
                    },
                    Triangle {
                        v: [c(q[0]), c(q[2]), c(q[3])],
                    },
                ]
            })
            .collect()
    }

    fn ink(sigma: f32) -> Medium {
        Medium {
            name: "ink".into(),
            extinction: Vec3::splat(sigma),
            scattering: Vec3::ZERO,
            anisotropy: 0.0,
            emission: Vec3::ZERO,
        }
    }

    #[test]
    fn the_cube_winds_outwards() {
        for t in cube(-1.0, 1.0) {
            let centre = (t.v[0] + t.v[1] + t.v[2]) / 3.0;
            assert!(t.normal().dot(centre) > 0.0);
        }
    }

    #[test]
    fn containment_and_lengths_inside_a_cube() {
        let v = Volumes::new(
            Some(ink(0.1)),
            vec![Bounded::new(ink(1.0), cube(-1.0, 1.0))],
            vec![0; 12],
            GridMedia::default(),
        );
        assert_eq!(v.at_point(Vec3::ZERO), Inside::Bounded(0));
        assert_eq!(v.at_point(Vec3::new(0.3, -0.9, 0.99)), Inside::Bounded(0));
        assert_eq!(v.at_point(Vec3::new(1.01, 0.0, 0.0)), Inside::Ambient);
        assert_eq!(v.at_point(Vec3::new(5.0, 5.0, 5.0)), Inside::Ambient);
        let b = &v.bounded[0];
        // Through the whole cube, from outside; from inside; stopping inside; missing it; and
        // exactly along a face's diagonal edge.
        let x = Vec3::X;
        assert!((b.length_inside(Vec3::new(-3.0, 0.2, 0.1), x, 10.0) - 2.0).abs() < 1e-5);
        assert!((b.length_inside(Vec3::new(0.5, 0.2, 0.1), x, 10.0) - 0.5).abs() < 1e-5);
        assert!((b.length_inside(Vec3::new(-3.0, 0.2, 0.1), x, 2.5) - 0.5).abs() < 1e-5);
        assert_eq!(b.length_inside(Vec3::new(-3.0, 2.0, 0.1), x, 10.0), 0.0);
        let diagonal = Vec3::new(1.0, 1.0, 0.0).normalize();
        let l = b.length_inside(Vec3::new(-2.0, -2.0, 0.3), diagonal, 10.0);
        assert!((l - 2.0 * 2f32.sqrt()).abs() < 1e-4, "{l}");
        // Transmittance: 2 m in the cube (σ 1) and 8 m outside (σ 0.1).
        let t = v.transmittance(Vec3::new(-5.0, 0.2, 0.1), x, 10.0, 0.0);
        assert!((t.x - (-2.0f32 - 0.8).exp()).abs() < 1e-5, "{t}");
        assert_eq!(
            v.transmittance(Vec3::ZERO, x, f32::INFINITY, 0.0),
            Vec3::ZERO
        );
    }
}
