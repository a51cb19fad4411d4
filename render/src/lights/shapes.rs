//! Lights a lighter places (`[[light]]`): a sphere (a point when its radius is 0), a disk or a
//! rectangle, each optionally shaped into a spot by a cone, with UsdLux's units: radiance
//! `color × intensity × 2^exposure`, divided by the world-space area when `normalize` asks for
//! it, so that changing the light's size keeps its power. Disks and rectangles emit from their
//! local −Z side, as UsdLux's do; a sphere emits outwards.
//!
//! They are transparent emitters: they block no ray. Light sampling draws points on them (a
//! sphere by the cone of directions it fills, a disk or rectangle by area), and rays that
//! scatter find them along their way, so both strategies weigh each other by MIS; a point is
//! found by light sampling alone.
//!
//! A cone (UsdLux's ShapingAPI) limits emission to within `cone_angle` of the light's −Z axis,
//! fading over the last `softness` share of that angle:
//! L · (1 − smoothstep((1 − softness)·θ_cone, θ_cone, θ)).

use crate::geometry::Ray;
use crate::lights::tree::{LightBounds, Path};
use crate::portals::Flags;
use crate::sampling::{Frame, concentric_disk};
use glam::{DVec3, Vec2, Vec3};
use rift_fx::rig::{AnimatedTransform, Similarity};
use std::f32::consts::PI;

/// The shape of a light, in its own frame (sizes before the transform's scale).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// A sphere around the origin; radius 0 is a point.
    Sphere { radius: f32 },
    /// A disk in the XY plane, emitting towards −Z.
    Disk { radius: f32 },
    /// A rectangle in the XY plane (`width` along X), emitting towards −Z.
    Rect { width: f32, height: f32 },
}

/// A spot's cone around the light's −Z axis, as angles from it (radians).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cone {
    /// Beyond this, nothing is emitted.
    pub cutoff: f32,
    /// From here to the cutoff, emission fades.
    pub smooth_start: f32,
}

impl Cone {
    /// The cone of half-angle `degrees`, fading over its last `softness` share.
    pub fn new(degrees: f32, softness: f32) -> Self {
        let cutoff = degrees.to_radians();
        Self {
            cutoff,
            smooth_start: (1.0 - softness) * cutoff,
        }
    }

    /// The share of emission sent at angle `theta` from the axis.
    pub fn factor(&self, theta: f32) -> f32 {
        if theta > self.cutoff {
            return 0.0;
        }
        let width = self.cutoff - self.smooth_start;
        if width <= 0.0 {
            return 1.0;
        }
        let t = ((theta - self.smooth_start) / width).clamp(0.0, 1.0);
        1.0 - t * t * (3.0 - 2.0 * t)
    }
}

/// A `[[light]]` of the shot other than a distant one.
#[derive(Clone, Debug)]
pub struct ShapeLight {
    pub name: String,
    pub shape: Shape,
    /// color × intensity × 2^exposure.
    pub base: Vec3,
    /// Divide by the world-space area (a point is always taken as normalised).
    pub normalize: bool,
    pub cone: Option<Cone>,
    /// Its frame over time.
    pub placement: LightFrame,
    /// Which rays see it; shadow rays never do.
    pub flags: Flags,
    pub group: u8,
}

/// A light's frame over time, with the frame itself kept when it never moves: it is asked for
/// by every ray that scatters and could find the light, and making it from the transform (three
/// rotations in double precision) was a tenth of `textured_set`'s render.
#[derive(Clone, Debug)]
pub struct LightFrame {
    transform: AnimatedTransform,
    still: Option<Placed>,
}

impl From<AnimatedTransform> for LightFrame {
    fn from(transform: AnimatedTransform) -> Self {
        let still = transform
            .is_static()
            .then(|| Placed::new(&transform.at(0.0)));
        Self { transform, still }
    }
}

impl LightFrame {
    /// The frame at `time`.
    #[inline]
    pub fn at(&self, time: f64) -> Placed {
        match self.still {
            Some(placed) => placed,
            None => Placed::new(&self.transform.at(time)),
        }
    }

    /// True when the light never moves.
    pub fn is_static(&self) -> bool {
        self.still.is_some()
    }
}

/// A light's frame at one time.
#[derive(Clone, Copy, Debug)]
pub struct Placed {
    pub centre: Vec3,
    /// Unit axes of the light's frame in world space.
    pub x: Vec3,
    pub y: Vec3,
    pub z: Vec3,
    /// Uniform scale.
    pub scale: f32,
}

impl Placed {
    fn new(s: &Similarity) -> Self {
        let axis = |v: DVec3| s.transform_direction(v).normalize().as_vec3();
        Self {
            centre: s.translation.as_vec3(),
            x: axis(DVec3::X),
            y: axis(DVec3::Y),
            z: axis(DVec3::Z),
            scale: s.scale as f32,
        }
    }
}

/// A point on a light as light sampling draws it, or as a ray finds it.
#[derive(Clone, Copy, Debug)]
pub struct ShapePoint {
    pub point: Vec3,
    /// Unit normal on the emitting side.
    pub normal: Vec3,
    /// Radiance towards the receiver (for a point light, its intensity that way).
    pub radiance: Vec3,
    /// Area-measure density of drawing it (a point light: 1).
    pub pdf: f32,
}

impl ShapeLight {
    /// True for a point: found by light sampling alone.
    pub fn is_point(&self) -> bool {
        self.shape == Shape::Sphere { radius: 0.0 }
    }

    /// The light's frame at `time`.
    #[inline]
    pub fn placed(&self, time: f64) -> Placed {
        self.placement.at(time)
    }

    /// The emitting area in world units at `placed`.
    fn area(&self, placed: &Placed) -> f32 {
        let s2 = placed.scale * placed.scale;
        match self.shape {
            Shape::Sphere { radius } => 4.0 * PI * radius * radius * s2,
            Shape::Disk { radius } => PI * radius * radius * s2,
            Shape::Rect { width, height } => width * height * s2,
        }
    }

    /// Radiance leaving the light's surface in direction `out` (unit, world) at `placed`; a
    /// point's intensity (what a normalised sphere of any radius sends that way: a quarter of
    /// its base, whose power is π × base).
    pub fn radiance(&self, placed: &Placed, out: Vec3) -> Vec3 {
        let shaped = match &self.cone {
            Some(cone) => {
                let theta = out.dot(-placed.z).clamp(-1.0, 1.0).acos();
                self.base * cone.factor(theta)
            }
            None => self.base,
        };
        if self.is_point() {
            shaped * 0.25
        } else if self.normalize {
            shaped / self.area(placed)
        } else {
            shaped
        }
    }

    /// A point on the light for the receiver at `p` (at `time`), drawn with `u`; `None` where
    /// the light sends it nothing.
    pub fn sample(&self, p: Vec3, time: f64, u: Vec2) -> Option<ShapePoint> {
        let placed = self.placed(time);
        let (point, normal, pdf) = match self.shape {
            Shape::Sphere { radius: 0.0 } => {
                let to = p - placed.centre;
                let out = to.normalize_or_zero();
                (placed.centre, out, 1.0)
            }
            Shape::Sphere { radius } => sample_sphere(&placed, radius * placed.scale, p, u)?,
            Shape::Disk { radius } => {
                let d = concentric_disk(u) * radius * placed.scale;
                let point = placed.centre + placed.x * d.x + placed.y * d.y;
                (point, -placed.z, 1.0 / self.area(&placed))
            }
            Shape::Rect { width, height } => {
                let (w, h) = (width * placed.scale, height * placed.scale);
                let point =
                    placed.centre + placed.x * ((u.x - 0.5) * w) + placed.y * ((u.y - 0.5) * h);
                (point, -placed.z, 1.0 / self.area(&placed))
            }
        };
        let out = (p - point).normalize_or_zero();
        if !self.is_point() && out.dot(normal) <= 0.0 {
            return None;
        }
        let radiance = self.radiance(&placed, out);
        (radiance != Vec3::ZERO && pdf > 0.0).then_some(ShapePoint {
            point,
            normal,
            radiance,
            pdf,
        })
    }

    /// The area-measure density with which [`Self::sample`], for a receiver at `p`, draws
    /// `point` (with unit `normal`) at `time`.
    pub fn pdf(&self, p: Vec3, point: Vec3, normal: Vec3, time: f64) -> f32 {
        let placed = self.placed(time);
        match self.shape {
            Shape::Sphere { radius: 0.0 } => 0.0,
            Shape::Sphere { radius } => {
                let r = radius * placed.scale;
                let Some(cone) = VisibleCap::new(placed.centre, r, p) else {
                    return 0.0;
                };
                let to = point - p;
                let d2 = to.length_squared();
                cone.pdf_solid_angle() * normal.dot(-to).abs() / (d2 * d2.sqrt())
            }
            Shape::Disk { .. } | Shape::Rect { .. } => 1.0 / self.area(&placed),
        }
    }

    /// Where `ray` meets the light's emitting side first within its range, as found by a ray
    /// that scattered; a point is never met.
    pub fn intersect(&self, ray: &Ray) -> Option<(f32, ShapePoint)> {
        if self.is_point() {
            return None;
        }
        let placed = self.placed(ray.time);
        let (t, normal) = match self.shape {
            Shape::Sphere { radius } => intersect_sphere(&placed, radius * placed.scale, ray)?,
            Shape::Disk { radius } => {
                let (t, local) = intersect_plane(&placed, ray)?;
                let r = radius * placed.scale;
                (local.length_squared() <= r * r).then_some((t, -placed.z))?
            }
            Shape::Rect { width, height } => {
                let (t, local) = intersect_plane(&placed, ray)?;
                let half = 0.5 * Vec2::new(width, height) * placed.scale;
                (local.abs().cmple(half).all()).then_some((t, -placed.z))?
            }
        };
        let point = ray.at(t);
        let radiance = self.radiance(&placed, -ray.dir);
        Some((
            t,
            ShapePoint {
                point,
                normal,
                radiance,
                pdf: 0.0,
            },
        ))
    }

    /// The light's bounds for the light tree over `times`: its box, its centre's path, and
    /// π times the most it sends one way; a moving one counts as facing every way.
    pub fn bounds(&self, times: [f64; 2]) -> LightBounds {
        let at = |tau: f32| self.placed(times[0] + (times[1] - times[0]) * tau as f64);
        let extent = |p: &Placed| match self.shape {
            Shape::Sphere { radius } | Shape::Disk { radius } => radius * p.scale,
            Shape::Rect { width, height } => 0.5 * Vec2::new(width, height).length() * p.scale,
        };
        let still = self.placement.is_static();
        let steps = if still { 1 } else { 9 };
        let placements: Vec<Placed> = (0..steps)
            .map(|k| at(k as f32 / (steps - 1).max(1) as f32))
            .collect();
        let (min, max) = placements
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p.centre - extent(p)), hi.max(p.centre + extent(p)))
            });
        let first = placements[0];
        let power = PI * crate::color::luminance(self.peak_intensity(&first)).max(1e-6);
        let (axis, cos_spread) = match (self.shape, still) {
            (Shape::Disk { .. } | Shape::Rect { .. }, true) => (-first.z, 1.0),
            (_, true) if self.cone.is_some_and(|c| c.cutoff <= 0.5 * PI) => (-first.z, 1.0),
            _ => (Vec3::Z, -1.0),
        };
        let centre = Path::through([0.0, 0.5, 1.0].map(|tau| at(tau).centre));
        let reach = placements
            .iter()
            .enumerate()
            .map(|(k, p)| {
                let tau = k as f32 / (steps - 1).max(1) as f32;
                p.centre.distance(centre.at(tau)) + extent(p)
            })
            .fold(0.0f32, f32::max);
        LightBounds {
            min,
            max,
            centre,
            reach,
            power,
            axis,
            cos_spread,
        }
    }

    /// The most light the light sends in one direction (radiance times the area it shows
    /// that way), at `placed`.
    fn peak_intensity(&self, placed: &Placed) -> Vec3 {
        let r = |radius: f32| radius * placed.scale;
        let shown = match self.shape {
            Shape::Sphere { radius: 0.0 } => 1.0,
            Shape::Sphere { radius } => PI * r(radius) * r(radius),
            Shape::Disk { radius } => PI * r(radius) * r(radius),
            Shape::Rect { width, height } => width * height * placed.scale * placed.scale,
        };
        self.radiance(placed, -placed.z) * shown
    }
}

/// The cap of a sphere that a point outside it sees, as a cone of directions.
struct VisibleCap {
    axis: Vec3,
    distance: f32,
    /// 1 − cos of the cone's half-angle, kept accurate for small spheres far away.
    one_minus_cos: f32,
}

impl VisibleCap {
    /// The cap of the sphere at `centre` of radius `r` seen from `p`; `None` from inside it.
    fn new(centre: Vec3, r: f32, p: Vec3) -> Option<Self> {
        let to = centre - p;
        let d2 = to.length_squared();
        if d2 <= r * r {
            return None;
        }
        let distance = d2.sqrt();
        let sin2 = r * r / d2;
        let cos = (1.0 - sin2).max(0.0).sqrt();
        Some(Self {
            axis: to / distance,
            distance,
            one_minus_cos: sin2 / (1.0 + cos),
        })
    }

    fn pdf_solid_angle(&self) -> f32 {
        1.0 / (2.0 * PI * self.one_minus_cos)
    }
}

/// A point on the cap of the sphere (centre and radius `r` at `placed`) that `p` sees,
/// uniform in solid angle: the point, its outward normal and its area-measure density.
fn sample_sphere(placed: &Placed, r: f32, p: Vec3, u: Vec2) -> Option<(Vec3, Vec3, f32)> {
    let cap = VisibleCap::new(placed.centre, r, p)?;
    let one_minus_cos = u.x * cap.one_minus_cos;
    let cos = 1.0 - one_minus_cos;
    let sin2 = (one_minus_cos * (2.0 - one_minus_cos)).max(0.0);
    let sin = sin2.sqrt();
    let phi = 2.0 * PI * u.y;
    let dir = Frame::new(cap.axis).to_world(Vec3::new(sin * phi.cos(), sin * phi.sin(), cos));
    // Distance along `dir` to the near side of the sphere.
    let d = cap.distance;
    let along = d * cos - (r * r - d * d * sin2).max(0.0).sqrt();
    let point = p + dir * along;
    let normal = (point - placed.centre).normalize_or_zero();
    let pdf = cap.pdf_solid_angle() * normal.dot(-dir).abs() / (along * along);
    (pdf.is_finite() && pdf > 0.0).then_some((point, normal, pdf))
}

/// Where `ray` enters the sphere of radius `r` at `placed` within its range, with the outward
/// normal there; `None` from inside it (its inside sends nothing).
fn intersect_sphere(placed: &Placed, r: f32, ray: &Ray) -> Option<(f32, Vec3)> {
    let oc = ray.origin - placed.centre;
    let a = ray.dir.length_squared();
    let half_b = oc.dot(ray.dir);
    let c = oc.length_squared() - r * r;
    if c <= 0.0 {
        return None;
    }
    let disc = half_b * half_b - a * c;
    if disc < 0.0 {
        return None;
    }
    let t = (-half_b - disc.sqrt()) / a;
    (t > ray.t_min && t < ray.t_max).then(|| (t, (ray.at(t) - placed.centre) / r))
}

/// Where `ray` meets the plane of a disk or rectangle at `placed` from its emitting (−Z)
/// side, within its range: the distance and the point in the plane's own axes (world units).
fn intersect_plane(placed: &Placed, ray: &Ray) -> Option<(f32, Vec2)> {
    let facing = ray.dir.dot(placed.z);
    if facing <= 0.0 {
        return None;
    }
    let t = (placed.centre - ray.origin).dot(placed.z) / facing;
    if !(t > ray.t_min && t < ray.t_max) {
        return None;
    }
    let offset = ray.at(t) - placed.centre;
    Some((t, Vec2::new(offset.dot(placed.x), offset.dot(placed.y))))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn light(shape: Shape, normalize: bool, cone: Option<Cone>) -> ShapeLight {
        ShapeLight {
            name: String::new(),
            shape,
            base: Vec3::splat(4.0),
            normalize,
            cone,
            placement: AnimatedTransform::constant(Similarity::IDENTITY).into(),
            flags: Flags::ALL,
            group: 0,
        }
    }

    #[test]
    fn a_cone_is_whole_inside_its_soft_start_and_dark_beyond_its_angle() {
        let hard = Cone::new(30.0, 0.0);
        assert_eq!(hard.factor(29f32.to_radians()), 1.0);
        assert_eq!(hard.factor(31f32.to_radians()), 0.0);
        let soft = Cone::new(40.0, 0.5);
        assert_eq!(soft.factor(19f32.to_radians()), 1.0);
        assert!((soft.factor(30f32.to_radians()) - 0.5).abs() < 1e-5);
        assert_eq!(soft.factor(41f32.to_radians()), 0.0);
    }

    #[test]
    fn normalising_divides_by_the_world_area_and_a_point_sends_a_quarter() {
        let placed = Placed::new(&Similarity::new(glam::DQuat::IDENTITY, DVec3::ZERO, 2.0));
        let rect = light(
            Shape::Rect {
                width: 1.0,
                height: 0.5,
            },
            true,
            None,
        );
        assert_eq!(rect.radiance(&placed, -Vec3::Z), Vec3::splat(4.0 / 2.0));
        let plain = light(
            Shape::Rect {
                width: 1.0,
                height: 0.5,
            },
            false,
            None,
        );
        assert_eq!(plain.radiance(&placed, -Vec3::Z), Vec3::splat(4.0));
        let point = light(Shape::Sphere { radius: 0.0 }, true, None);
        assert_eq!(point.radiance(&placed, Vec3::X), Vec3::splat(1.0));
        // A spot sends nothing behind it.
        let spot = light(
            Shape::Sphere { radius: 0.0 },
            true,
            Some(Cone::new(45.0, 0.0)),
        );
        assert_eq!(spot.radiance(&placed, Vec3::Z), Vec3::ZERO);
    }

    #[test]
    fn a_sphere_sends_nothing_inside_itself_and_rays_meet_its_outside_only() {
        let sphere = light(Shape::Sphere { radius: 1.0 }, false, None);
        assert!(
            sphere
                .sample(Vec3::new(0.2, 0.0, 0.0), 0.0, Vec2::splat(0.5))
                .is_none()
        );
        let inside = Ray::new(Vec3::ZERO, Vec3::X, f32::INFINITY, 0.0);
        assert!(sphere.intersect(&inside).is_none());
        let outside = Ray::new(Vec3::new(-3.0, 0.0, 0.0), Vec3::X, f32::INFINITY, 0.0);
        let (t, p) = sphere.intersect(&outside).unwrap();
        assert!((t - 2.0).abs() < 1e-6 && (p.normal + Vec3::X).length() < 1e-6);
        // A disk is met from its emitting side only.
        let disk = light(Shape::Disk { radius: 1.0 }, false, None);
        let towards = Ray::new(Vec3::new(0.0, 0.0, -2.0), Vec3::Z, f32::INFINITY, 0.0);
        let behind = Ray::new(Vec3::new(0.0, 0.0, 2.0), -Vec3::Z, f32::INFINITY, 0.0);
        assert!(disk.intersect(&towards).is_some() && disk.intersect(&behind).is_none());
    }
}
