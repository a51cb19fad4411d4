//! Sampling directions through an opening by drawing points on it.
//!
//! Light sampling beyond an opening draws directions from what lies there (an emitter, the
//! sky) and then keeps those that pass the opening. Behind a small opening most of the sky's
//! directions miss it, so the sky through a window is better sampled the other way round: a
//! uniform point on the opening gives the direction, whatever lies beyond it. The points are
//! drawn from a simple region that covers the teleport region (the disk or rectangle itself,
//! the bounding box of a polygon, the widest circle of a ring); those outside the mask are
//! rejected by the shadow ray, so the density stays exact for every shape.

use crate::portals::masks::Mask;
use crate::portals::openings::Portals;
use glam::{DVec2, DVec3, Vec2, Vec3};
use std::f64::consts::TAU;

/// The region of an opening's plane that points are drawn from, in its local units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Region {
    Disk { radius: f64 },
    Box { lower: DVec2, upper: DVec2 },
}

impl Region {
    /// The smallest simple region around `mask`'s teleport region.
    pub fn covering(mask: &Mask) -> Self {
        match mask {
            Mask::Disk { radius } => Region::Disk { radius: *radius },
            Mask::Rectangle { half } => Region::Box {
                lower: -*half,
                upper: *half,
            },
            Mask::Polygon(polygon) => {
                let (lower, upper) = polygon.bounds();
                Region::Box { lower, upper }
            }
            Mask::Ring(_) => Region::Disk {
                radius: mask.bounding_radius(),
            },
        }
    }

    fn area(&self) -> f64 {
        match *self {
            Region::Disk { radius } => std::f64::consts::PI * radius * radius,
            Region::Box { lower, upper } => (upper - lower).element_product(),
        }
    }

    /// A uniform point of the region.
    fn sample(&self, u: Vec2) -> DVec2 {
        let u = u.as_dvec2();
        match *self {
            Region::Disk { radius } => {
                let (r, phi) = (radius * u.x.sqrt(), TAU * u.y);
                DVec2::new(r * phi.cos(), r * phi.sin())
            }
            Region::Box { lower, upper } => lower + (upper - lower) * u,
        }
    }

    fn contains(&self, p: DVec2) -> bool {
        match *self {
            Region::Disk { radius } => p.length_squared() <= radius * radius,
            Region::Box { lower, upper } => p.cmpge(lower).all() && p.cmple(upper).all(),
        }
    }
}

/// A unit direction from `from` towards a uniform point of opening `i`'s region at `time`,
/// with its solid-angle pdf; `None` when `from` is not in front of the opening.
pub fn sample(portals: &Portals, i: usize, time: f64, from: Vec3, u: Vec2) -> Option<(Vec3, f32)> {
    let here = portals.here(i, time);
    let region = Region::covering(portals.mask(i));
    let local = region.sample(u);
    let point = here.transform_point(DVec3::new(local.x, local.y, 0.0));
    let to = point - from.as_dvec3();
    let front = here.transform_direction(DVec3::Z);
    let height = -to.dot(front);
    let distance_squared = to.length_squared();
    if !(height > 0.0 && distance_squared > 0.0) {
        return None;
    }
    let distance = distance_squared.sqrt();
    let cos = height / distance;
    let area = region.area() * here.scale * here.scale;
    let pdf = (distance_squared / (cos * area)) as f32;
    (pdf.is_finite() && pdf > 0.0).then(|| ((to / distance).as_vec3(), pdf))
}

/// The solid-angle pdf with which [`sample`] gives unit direction `dir` from `from`.
pub fn pdf(portals: &Portals, i: usize, time: f64, from: Vec3, dir: Vec3) -> f32 {
    let inverse = portals.here_inverse(i, time);
    let o = inverse.transform_point(from.as_dvec3());
    // Local units: lengths and areas scale alike, so the ratio below is the world one.
    let d = inverse.transform_vector(dir.as_dvec3());
    if o.z <= 0.0 || d.z >= 0.0 {
        return 0.0;
    }
    let t = -o.z / d.z;
    let region = Region::covering(portals.mask(i));
    if !region.contains(DVec2::new(o.x + t * d.x, o.y + t * d.y)) {
        return 0.0;
    }
    let length = d.length();
    let (distance, cos) = (t * length, -d.z / length);
    (distance * distance / (cos * region.area())) as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::portals::openings::OpeningLook;
    use glam::DQuat;
    use rift_fx::rig::{Rig, Similarity};

    /// One opening (and its pair far away) at `centre`, facing +X, scaled by `scale`.
    fn opening(mask: Mask, centre: DVec3, scale: f64) -> Portals {
        let here = Similarity::new(
            DQuat::from_rotation_y(std::f64::consts::FRAC_PI_2),
            centre,
            scale,
        );
        let there = Similarity::from_translation(DVec3::new(100.0, 0.0, 0.0));
        Portals::new(
            Rig::still_pair(here, there),
            vec![mask.clone(), mask],
            vec![OpeningLook::default(); 2],
            [0.0, 0.0],
            &[false; 2],
        )
    }

    /// Σ 1/pdf over N samples estimates the solid angle the region covers from `from`; each
    /// sample's pdf is the one [`pdf`] gives its direction.
    fn estimated_solid_angle(portals: &Portals, from: Vec3) -> f64 {
        let n = 64 * 64;
        let mut sum = 0.0;
        for k in 0..n {
            let u = Vec2::new(
                ((k % 64) as f32 + 0.5) / 64.0,
                ((k / 64) as f32 + 0.5) / 64.0,
            );
            let (dir, p) = sample(portals, 0, 0.0, from, u).expect("in front");
            let again = pdf(portals, 0, 0.0, from, dir);
            assert!(
                (again - p).abs() <= 1e-3 * p,
                "sampled pdf {p}, evaluated {again}"
            );
            sum += 1.0 / p as f64;
        }
        sum / n as f64
    }

    #[test]
    fn a_disk_and_a_rectangle_cover_their_solid_angles() {
        let centre = DVec3::new(1.0, 2.0, -3.0);
        let (h, scale) = (1.5f64, 2.0f64);
        let from = (centre + DVec3::new(h, 0.0, 0.0)).as_vec3();
        // A disk of world radius r seen on its axis from h away: 2π(1 − h/√(h² + r²)).
        let r = 0.4 * scale;
        let disk = opening(Mask::Disk { radius: 0.4 }, centre, scale);
        let expected = TAU * (1.0 - h / (h * h + r * r).sqrt());
        let got = estimated_solid_angle(&disk, from);
        assert!(
            (got / expected - 1.0).abs() < 2e-3,
            "disk {got} vs {expected}"
        );
        // A rectangle of world half-sides a, b on its axis: 4 asin(ab / √((a² + h²)(b² + h²))).
        let half = DVec2::new(0.3, 0.7);
        let (a, b) = (half.x * scale, half.y * scale);
        let rectangle = opening(Mask::Rectangle { half }, centre, scale);
        let expected = 4.0 * (a * b / ((a * a + h * h) * (b * b + h * h)).sqrt()).asin();
        let got = estimated_solid_angle(&rectangle, from);
        assert!(
            (got / expected - 1.0).abs() < 2e-3,
            "rectangle {got} vs {expected}"
        );
    }

    #[test]
    fn directions_that_miss_the_region_or_come_from_behind_have_no_density() {
        let portals = opening(Mask::Disk { radius: 0.5 }, DVec3::ZERO, 1.0);
        let front = Vec3::new(2.0, 0.0, 0.0);
        assert!(pdf(&portals, 0, 0.0, front, -Vec3::X) > 0.0);
        assert_eq!(pdf(&portals, 0, 0.0, front, Vec3::X), 0.0);
        assert_eq!(
            pdf(
                &portals,
                0,
                0.0,
                front,
                Vec3::new(-1.0, 1.0, 0.0).normalize()
            ),
            0.0
        );
        let behind = Vec3::new(-2.0, 0.0, 0.0);
        assert_eq!(pdf(&portals, 0, 0.0, behind, Vec3::X), 0.0);
        assert!(sample(&portals, 0, 0.0, behind, Vec2::splat(0.5)).is_none());
    }

    #[test]
    fn a_polygon_draws_from_its_bounding_box() {
        let triangle = crate::portals::masks::Polygon::new(vec![
            DVec2::new(-1.0, -0.5),
            DVec2::new(2.0, -0.5),
            DVec2::new(0.0, 1.0),
        ])
        .unwrap();
        let region = Region::covering(&Mask::Polygon(triangle));
        assert_eq!(
            region,
            Region::Box {
                lower: DVec2::new(-1.0, -0.5),
                upper: DVec2::new(2.0, 1.0)
            }
        );
        assert_eq!(region.area(), 4.5);
    }
}
