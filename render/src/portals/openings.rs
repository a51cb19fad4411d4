//! Portal openings as the integrator sees them: a ray that meets the front of a *here* opening
//! inside its teleport region continues from the *there* side, with the frames evaluated at the
//! ray's own time, so moving portals blur correctly and depth of field and motion blur work
//! through them.
//!
//! The teleport is T = P_T · P_H⁻¹ (DESIGN.md, Portals), applied in f64 from the hit point in the
//! here frame's own coordinates, with the local depth snapped to exactly zero: the exit point
//! then lies on the there plane whatever the distance from the world origin, and a hall of
//! mirrors does not drift.
//!
//! Shading signals of an opening ([`OpeningLook`]):
//! - `tint` scales what is seen through it;
//! - `opacity` is the probability of teleporting (the rest passes through untouched), which is
//!   the blend of teleport and pass-through in expectation;
//! - `ior` bends the teleported direction at the exit as refraction into a medium of that index
//!   would (rays that would be totally reflected end there, black);
//! - `distortion` perturbs the exit normal with animated Perlin noise, which only bends light
//!   when `ior` is not 1 (a heat-haze look);
//! - `time_offset` shifts the time of rays that pass: they see the there side that much later
//!   (earlier when negative), and everything they meet after is evaluated at the shifted time.
//!   Shifted times are kept within the window the scene's motion was built for
//!   ([`Portals::times`]); only a path that crosses delaying openings more often than the
//!   portal depth limit allows in a row can reach its edge, and it then sees the scene as it is
//!   at the edge.

use crate::geometry::offset_origin;
use crate::geometry::ray::Ray;
pub use crate::portals::masks::Mask;
use crate::portals::tree::{OpeningTree, disk_box};
use glam::{DAffine3, DVec2, DVec3, Vec3};
use noise::{NoiseFn, Perlin};
use rift_fx::rig::{Rig, Similarity};

/// Noise that tilts the exit normal.
#[derive(Clone, Debug)]
pub struct Distortion {
    /// Largest tilt of the normal, as a slope.
    pub amplitude: f64,
    /// Features per local unit.
    pub frequency: f64,
    /// Noise units per second: how fast the pattern changes.
    pub evolution: f64,
    perlin: [Perlin; 2],
}

impl Distortion {
    pub fn new(amplitude: f64, frequency: f64, evolution: f64, seed: u32) -> Self {
        Self {
            amplitude,
            frequency,
            evolution,
            perlin: [Perlin::new(seed), Perlin::new(seed ^ 0x5bd1_e995)],
        }
    }

    /// The perturbed unit normal (+Z unperturbed) at local point `p` and time `time`.
    fn normal(&self, p: DVec2, time: f64) -> DVec3 {
        let q = [
            p.x * self.frequency,
            p.y * self.frequency,
            time * self.evolution,
        ];
        let slope = DVec2::new(self.perlin[0].get(q), self.perlin[1].get(q)) * self.amplitude;
        DVec3::new(-slope.x, -slope.y, 1.0).normalize()
    }
}

/// How an opening shades what passes it.
#[derive(Clone, Debug)]
pub struct OpeningLook {
    pub tint: Vec3,
    /// Probability of teleporting, in [0, 1].
    pub opacity: f32,
    /// Index of refraction at the exit (1: straight through).
    pub ior: f64,
    pub distortion: Option<Distortion>,
    /// Seconds added to the time of rays that teleport.
    pub time_offset: f64,
}

impl Default for OpeningLook {
    fn default() -> Self {
        Self {
            tint: Vec3::ONE,
            opacity: 1.0,
            ior: 1.0,
            distortion: None,
            time_offset: 0.0,
        }
    }
}

/// The frames of one opening at one time.
#[derive(Clone, Copy, Debug)]
struct Frames {
    /// P_H: here-local to world.
    here: Similarity,
    /// P_H⁻¹: world to here-local.
    here_inverse: Similarity,
    /// P_H⁻¹ as a matrix and offset, which maps in fewer operations than the quaternion:
    /// every ray near the opening is taken into its frame (5% of the test on the showcase).
    here_inverse_affine: DAffine3,
    /// P_T: there-local to world.
    there: Similarity,
    /// A world-space sphere (centre, radius) holding the teleport region: rays that miss it
    /// skip the exact test in double precision.
    bound: (Vec3, f32),
}

impl Frames {
    /// A box holding the teleport region: the bound's disk in the opening's plane, as thick
    /// as the bound's slack for rounding.
    fn bounding_box(&self) -> obvhs::aabb::Aabb {
        let (centre, radius) = self.bound;
        let facing = (self.here.rotation * DVec3::Z).as_vec3();
        disk_box(centre, facing, radius, rounding_slack(centre))
    }

    /// True when the line of `ray` (whose direction's `scale` is formed) passes outside the
    /// bound (or the bound lies wholly outside the ray's range), so the opening cannot be hit.
    #[inline]
    fn misses_bound(&self, ray: &Ray, scale: &DirectionScale) -> bool {
        let (centre, radius) = self.bound;
        let to_centre = centre - ray.origin;
        let along = to_centre.dot(ray.dir) * scale.inverse_square;
        let away = (to_centre - ray.dir * along).length_squared();
        let reach = radius * scale.inverse;
        away > radius * radius || along + reach < ray.t_min || along - reach > ray.t_max
    }
}

/// How far an opening's bounds reach beyond its region: enough for single-precision rounding
/// at the magnitude of its centre.
fn rounding_slack(centre: Vec3) -> f32 {
    1e-5 * (1.0 + centre.abs().max_element())
}

/// 1/|d|² and 1/|d| of a ray's direction d, which the bounding-sphere test of every opening
/// needs: formed once a ray rather than once an opening (their divisions and square root were
/// most of a missed opening's test, tens of times a path on the showcase).
struct DirectionScale {
    inverse_square: f32,
    inverse: f32,
}

impl DirectionScale {
    fn of(ray: &Ray) -> Self {
        let d2 = ray.dir.length_squared();
        Self {
            inverse_square: 1.0 / d2,
            inverse: 1.0 / d2.sqrt(),
        }
    }
}

/// A ray meeting the front of an opening inside its teleport region.
#[derive(Clone, Copy, Debug)]
pub struct PortalHit {
    /// Ray parameter, in units of the ray direction's length.
    pub t: f32,
    pub opening: usize,
    /// Hit point in the here frame's local coordinates (on its plane).
    local: DVec2,
    /// P_H⁻¹ at the ray's time.
    here_inverse: Similarity,
}

/// Where a teleported ray continues.
#[derive(Clone, Copy, Debug)]
pub struct Teleported {
    pub origin: Vec3,
    /// Unit direction.
    pub direction: Vec3,
}

/// All openings of a scene.
#[derive(Clone, Debug, Default)]
pub struct Portals {
    rig: Rig,
    masks: Vec<Mask>,
    looks: Vec<OpeningLook>,
    /// Each opening's frames, where neither its here nor its there frame moves at any time a
    /// ray can have (a moving rig evaluates the others at each ray's time).
    fixed: Vec<Option<Frames>>,
    /// The times rays can have: the shutter, widened by the time offsets.
    times: [f64; 2],
    /// How a ray's tests visit the openings.
    tree: OpeningTree,
}

impl Portals {
    /// `masks` and `looks` follow the rig's openings; `times` is the interval ray times stay
    /// in. The frames of each opening that `moving` says stands still are evaluated once.
    pub fn new(
        rig: Rig,
        masks: Vec<Mask>,
        looks: Vec<OpeningLook>,
        times: [f64; 2],
        moving: &[bool],
    ) -> Self {
        let fixed_time = times[0];
        let fixed = moving
            .iter()
            .enumerate()
            .map(|(i, &moves)| {
                (!moves).then(|| {
                    let here = rig.here_at(i, fixed_time);
                    let there = rig.there_at(i, fixed_time);
                    let centre = here.translation.as_vec3();
                    let radius = (masks[i].bounding_radius() * here.scale) as f32 * (1.0 + 1e-3)
                        + rounding_slack(centre);
                    let here_inverse = here.inverse();
                    Frames {
                        here,
                        here_inverse,
                        here_inverse_affine: here_inverse.to_affine(),
                        there,
                        bound: (centre, radius),
                    }
                })
            })
            .collect::<Vec<_>>();
        let bounds: Vec<_> = fixed
            .iter()
            .map(|f| f.as_ref().map(Frames::bounding_box))
            .collect();
        Self {
            rig,
            masks,
            looks,
            fixed,
            times,
            tree: OpeningTree::new(&bounds),
        }
    }

    /// Number of openings.
    pub fn len(&self) -> usize {
        self.masks.len()
    }

    /// True when the scene has no opening (the integrator then skips every portal test).
    pub fn is_empty(&self) -> bool {
        self.masks.is_empty()
    }

    /// The look of opening `i`.
    pub fn look(&self, i: usize) -> &OpeningLook {
        &self.looks[i]
    }

    /// True when some opening's frames change over [`Self::times`].
    pub fn moving(&self) -> bool {
        self.fixed.iter().any(Option::is_none)
    }

    /// True when opening `i`'s here or there frame changes over [`Self::times`].
    pub fn opening_moves(&self, i: usize) -> bool {
        self.fixed[i].is_none()
    }

    /// The interval ray times stay in: the shutter, widened by what the time offsets can add.
    pub fn times(&self) -> [f64; 2] {
        self.times
    }

    /// The largest time offset of any opening, seconds (how far a copy's own time can be
    /// from a ray's).
    pub fn largest_time_offset(&self) -> f64 {
        self.looks
            .iter()
            .map(|l| l.time_offset.abs())
            .fold(0.0, f64::max)
    }

    /// The time of a ray at `time` after it teleports through opening `i`.
    #[inline]
    pub fn exit_time(&self, i: usize, time: f64) -> f64 {
        let offset = self.looks[i].time_offset;
        if offset == 0.0 {
            time
        } else {
            (time + offset).clamp(self.times[0], self.times[1])
        }
    }

    /// P_H⁻¹ of opening `i` at `time`. A moving rig evaluates only this for every opening a
    /// ray is tested against; the there frame waits for a teleport.
    #[inline]
    pub fn here_inverse(&self, i: usize, time: f64) -> Similarity {
        match &self.fixed[i] {
            Some(f) => f.here_inverse,
            None => self.rig.here_at(i, time).inverse(),
        }
    }

    /// P_H of opening `i` at `time`: its here frame, local to world.
    #[inline]
    pub fn here(&self, i: usize, time: f64) -> Similarity {
        match &self.fixed[i] {
            Some(f) => f.here,
            None => self.rig.here_at(i, time),
        }
    }

    /// The teleport region of opening `i`.
    pub fn mask(&self, i: usize) -> &Mask {
        &self.masks[i]
    }

    /// P_T of opening `i` at `time`.
    #[inline]
    pub fn there(&self, i: usize, time: f64) -> Similarity {
        match &self.fixed[i] {
            Some(f) => f.there,
            None => self.rig.there_at(i, time),
        }
    }

    /// The nearest opening whose front `ray` meets inside its teleport region.
    pub fn intersect(&self, ray: &Ray) -> Option<PortalHit> {
        let scale = DirectionScale::of(ray);
        self.tree.nearest(self.len(), ray, |i, limit| {
            let hit = self.meets(i, &ray.between(ray.t_min, limit), &scale)?;
            Some((hit.t, hit))
        })
    }

    /// Where `ray` meets the front of opening `i` inside its teleport region, if it does.
    pub fn intersect_one(&self, i: usize, ray: &Ray) -> Option<PortalHit> {
        self.meets(i, ray, &DirectionScale::of(ray))
    }

    /// [`Self::intersect_one`] with the ray's direction scale formed.
    #[inline]
    fn meets(&self, i: usize, ray: &Ray, scale: &DirectionScale) -> Option<PortalHit> {
        if let Some(frames) = &self.fixed[i]
            && frames.misses_bound(ray, scale)
        {
            return None;
        }
        let (t_min, t_max, time) = (ray.t_min, ray.t_max, ray.time);
        let (origin, dir) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
        let here_inverse = self.here_inverse(i, time);
        let (o, d) = match &self.fixed[i] {
            Some(f) => (
                f.here_inverse_affine.transform_point3(origin),
                f.here_inverse_affine.transform_vector3(dir),
            ),
            None => (
                here_inverse.transform_point(origin),
                here_inverse.transform_vector(dir),
            ),
        };
        // Only rays going into the front (towards local −Z) teleport.
        if d.z >= 0.0 || o.z <= 0.0 {
            return None;
        }
        let t = -o.z / d.z;
        let t32 = t as f32;
        if !(t32 > t_min && t32 < t_max) {
            return None;
        }
        let local = DVec2::new(o.x + t * d.x, o.y + t * d.y);
        self.masks[i].contains(local, time).then_some(PortalHit {
            t: t32,
            opening: i,
            local,
            here_inverse,
        })
    }

    /// The fraction of light that passes straight through the openings along `ray`: a shadow
    /// ray cannot follow a teleport, so a teleport region blocks it in proportion to its
    /// opacity.
    #[inline]
    pub fn transmittance(&self, ray: &Ray) -> f32 {
        // Every shadow ray of a shot without openings asks: answered inline, as the direction's
        // scale is a division and a square root (3% of the Cornell box's render).
        if self.is_empty() {
            return 1.0;
        }
        self.transmittance_through_openings(ray)
    }

    fn transmittance_through_openings(&self, ray: &Ray) -> f32 {
        let mut through = 1.0;
        let scale = DirectionScale::of(ray);
        self.tree.each(self.len(), ray, |i| {
            if self.meets(i, ray, &scale).is_some() {
                through *= 1.0 - self.looks[i].opacity;
            }
            through == 0.0
        });
        through
    }

    /// Continues the ray of `hit` (direction `dir`) from the there side as it is at `time` (the
    /// exit time), or `None` when the exit refraction reflects it totally.
    pub fn teleport(&self, hit: &PortalHit, dir: Vec3, time: f64) -> Option<Teleported> {
        let look = &self.looks[hit.opening];
        let there = self.there(hit.opening, time);
        // The local frame is shared by here and there: T maps here-local to there-local as the
        // identity, so the direction only needs rotating out and back in.
        let mut d = hit
            .here_inverse
            .transform_direction(dir.as_dvec3())
            .normalize();
        if look.ior != 1.0 {
            let n = look
                .distortion
                .as_ref()
                .map_or(DVec3::Z, |dist| dist.normal(hit.local, time));
            d = refract(d, n, 1.0 / look.ior)?;
        }
        let point = there.transform_point(DVec3::new(hit.local.x, hit.local.y, 0.0));
        let direction = there.transform_direction(d).normalize();
        // The ray leaves towards the there frame's local −Z. It starts off the plane by the
        // usual magnitude-scaled offset, moved along its own direction rather than the normal so
        // the ray stays on its exact line: a normal offset would shift every hop of a hall of
        // mirrors sideways by the same amount, and 64 hops would add it up.
        let exit_side = there.transform_direction(-DVec3::Z);
        let lifted = offset_origin(point.as_vec3(), exit_side.as_vec3()).as_dvec3();
        let clearance = (lifted - point).dot(exit_side);
        let along = clearance / direction.dot(exit_side).max(1e-6);
        Some(Teleported {
            origin: (point + direction * along).as_vec3(),
            direction: direction.as_vec3(),
        })
    }
}

/// Refraction of unit `d` through a surface with unit normal `n` facing against it, with
/// `eta` = index before / index after; `None` on total internal reflection.
fn refract(d: DVec3, n: DVec3, eta: f64) -> Option<DVec3> {
    let cos_i = -d.dot(n);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t >= 1.0 {
        return None;
    }
    Some((d * eta + n * (eta * cos_i - (1.0 - sin2_t).sqrt())).normalize())
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DQuat;
    use rift_fx::rig::AnimatedTransform;

    /// Two openings facing each other across `gap` meters: A at the origin facing +Z, B at
    /// z = `gap` facing −Z, tilted by `tilt` radians about X and scaled by `scale`.
    fn facing_pair(gap: f64, tilt: f64, scale: f64, offset: DVec3) -> Portals {
        let a = Similarity::new(DQuat::IDENTITY, offset, 1.0);
        let b = Similarity::new(
            DQuat::from_rotation_y(std::f64::consts::PI) * DQuat::from_rotation_x(tilt),
            offset + DVec3::new(0.0, 0.0, gap),
            scale,
        );
        Portals::new(
            Rig::still_pair(a, b),
            vec![Mask::Disk { radius: 1e3 }; 2],
            vec![OpeningLook::default(); 2],
            [0.0, 0.0],
            &[false; 2],
        )
    }

    /// Follows a ray through `count` teleports; returns where it then meets an opening again.
    fn bounce(portals: &Portals, mut o: Vec3, mut d: Vec3, count: usize) -> DVec3 {
        for k in 0..=count {
            let hit = portals
                .intersect(&Ray::new(o, d, f32::INFINITY, 0.0))
                .unwrap_or_else(|| panic!("teleport {k} missed"));
            if k == count {
                return o.as_dvec3() + d.as_dvec3() * hit.t as f64;
            }
            let out = portals.teleport(&hit, d, 0.0).unwrap();
            (o, d) = (out.origin, out.direction);
        }
        unreachable!()
    }

    /// The same in f64, from the rig's similarities directly: the exact-arithmetic reference.
    fn bounce_f64(portals: &Portals, mut o: DVec3, mut d: DVec3, count: usize) -> DVec3 {
        for k in 0..=count {
            let (i, t) = (0..2)
                .filter_map(|i| {
                    let inv = portals.rig.here_at(i, 0.0).inverse();
                    let (lo, ld) = (inv.transform_point(o), inv.transform_vector(d));
                    (ld.z < 0.0 && lo.z > 0.0).then(|| (i, -lo.z / ld.z))
                })
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap();
            if k == count {
                return o + d * t;
            }
            let teleport = portals.rig.teleport_at(i, 0.0);
            o = teleport.transform_point(o + d * t);
            d = teleport.transform_direction(d);
        }
        unreachable!()
    }

    /// A number in [0, 1) from a counter.
    fn hashed(i: u32) -> f64 {
        crate::sampling::hash32(i) as f64 / 4_294_967_296.0
    }

    /// `count` openings scattered through a 10 m box, turned every way, disks and rectangles,
    /// with every fifth one moving across the shutter [0, 1], and opacities below one.
    fn scattered(count: usize) -> Portals {
        let frame = |k: u32| {
            let h = |j: u32| hashed(97 * k + j);
            Similarity::new(
                DQuat::from_euler(glam::EulerRot::XYZ, 7.0 * h(0), 7.0 * h(1), 7.0 * h(2)),
                DVec3::new(h(3), h(4), h(5)) * 10.0 - 5.0,
                0.5 + 1.5 * h(6),
            )
        };
        let mut moving = Vec::new();
        let openings = (0..count as u32)
            .map(|k| {
                let moves = k % 5 == 3;
                moving.push(moves);
                let here = if moves {
                    let key = |time, value| rift_fx::rig::TransformKey { time, value };
                    AnimatedTransform::new(
                        vec![key(0.0, frame(k)), key(1.0, frame(k + 1000))],
                        rift_fx::rig::Interpolation::Linear,
                    )
                } else {
                    AnimatedTransform::constant(frame(k))
                };
                rift_fx::rig::Opening {
                    name: format!("o{k}"),
                    here,
                    there: rift_fx::rig::ThereFrame::Explicit(AnimatedTransform::constant(frame(
                        k + 2000,
                    ))),
                }
            })
            .collect();
        let masks = (0..count as u32)
            .map(|k| match k % 2 {
                0 => Mask::Disk {
                    radius: 0.3 + 0.7 * hashed(5000 + k),
                },
                _ => Mask::Rectangle {
                    half: DVec2::new(0.2 + hashed(6000 + k), 0.2 + hashed(7000 + k)),
                },
            })
            .collect();
        let looks = (0..count as u32)
            .map(|k| OpeningLook {
                opacity: 0.3 + 0.6 * hashed(8000 + k) as f32,
                ..OpeningLook::default()
            })
            .collect();
        Portals::new(Rig { openings }, masks, looks, [0.0, 1.0], &moving)
    }

    #[test]
    fn the_opening_tree_finds_what_testing_every_opening_finds() {
        let portals = scattered(40);
        assert!(matches!(portals.tree, OpeningTree::Tree { .. }));
        let (mut hits, mut shadowed) = (0, 0);
        for r in 0..4000u32 {
            let h = |j: u32| hashed(1_000_000 + 7 * r + j) as f32;
            let origin = Vec3::new(h(0), h(1), h(2)) * 12.0 - 6.0;
            let dir = Vec3::new(h(3), h(4), h(5)) * 2.0 - 1.0;
            let t_max = if r % 3 == 0 { 4.0 } else { f32::INFINITY };
            let ray = Ray::new(origin, dir, t_max, hashed(r))
                .between(if r % 4 == 0 { 1.0 } else { 0.0 }, t_max);
            let every = (0..portals.len())
                .filter_map(|i| portals.intersect_one(i, &ray))
                .collect::<Vec<_>>();
            let nearest = every.iter().min_by(|a, b| a.t.total_cmp(&b.t));
            let found = portals.intersect(&ray);
            assert_eq!(
                found.map(|h| (h.opening, h.t.to_bits())),
                nearest.map(|h| (h.opening, h.t.to_bits())),
                "ray {r}"
            );
            let through: f32 = every
                .iter()
                .map(|h| 1.0 - portals.look(h.opening).opacity)
                .product();
            let measured = portals.transmittance(&ray);
            assert!(
                (measured - through).abs() <= 1e-6,
                "ray {r}: {measured} against {through}"
            );
            hits += found.is_some() as u32;
            shadowed += (every.len() > 1) as u32;
        }
        assert!(
            hits > 200 && shadowed > 20,
            "{hits} hits, {shadowed} through two or more"
        );
    }

    #[test]
    fn sixty_four_teleports_stay_within_1e5_relative() {
        for (offset, tilt, scale) in [
            (DVec3::ZERO, 0.0, 1.0),
            (DVec3::ZERO, 0.005, 1.0),
            (DVec3::new(1e4, 30.0, -1e4), 0.0, 1.0),
        ] {
            let portals = facing_pair(4.0, tilt, scale, offset);
            let o = offset + DVec3::new(0.1, 0.2, 2.0);
            let d = DVec3::new(0.01, -0.005, -1.0).normalize();
            let got = bounce(&portals, o.as_vec3(), d.as_vec3(), 64);
            let exact = bounce_f64(&portals, o, d, 64);
            let error = (got - exact).length() / exact.length().max(1.0);
            assert!(
                error < 1e-5,
                "offset {offset} tilt {tilt}: {got} vs {exact} ({error:e})"
            );
        }
    }

    #[test]
    fn openings_are_met_whatever_the_length_of_the_direction() {
        // A unit disk at the origin facing +Z, and the same rays with directions of several
        // lengths: the bounding-sphere test must scale its distances with them.
        let pair = facing_pair(4.0, 0.0, 1.0, DVec3::ZERO);
        let portals = Portals::new(
            pair.rig.clone(),
            vec![Mask::Disk { radius: 1.0 }; 2],
            vec![OpeningLook::default(); 2],
            [0.0, 0.0],
            &[false; 2],
        );
        for length in [0.05f32, 0.25, 1.0, 7.0, 300.0] {
            for (x, inside) in [(0.0, true), (0.98, true), (1.02, false), (1.5, false)] {
                let (origin, dir) = (Vec3::new(x, 0.0, 2.0), Vec3::new(0.0, 0.0, -length));
                // The plane lies at t = 2 / length.
                let plane = 2.0 / length;
                let reaching = Ray::new(origin, dir, plane * 1.01, 0.0);
                let short = Ray::new(origin, dir, plane * 0.99, 0.0);
                let hit = portals.intersect(&reaching);
                assert_eq!(hit.is_some(), inside, "length {length}, x {x}");
                if let Some(hit) = hit {
                    assert!((hit.t - plane).abs() <= 1e-5 * plane, "length {length}");
                }
                assert!(
                    portals.intersect(&short).is_none(),
                    "length {length}, x {x}"
                );
                assert_eq!(portals.transmittance(&reaching) == 0.0, inside);
                assert_eq!(portals.transmittance(&short), 1.0);
                assert_eq!(portals.intersect_one(0, &reaching).is_some(), inside);
            }
            // Slanting in over the far rim to meet the disk near the rim on this side: the
            // sphere's centre lies well past the hit, so only a reach scaled with the
            // direction keeps the sphere within a range that ends just past the hit.
            let origin = Vec3::new(3.0, 0.0, 0.5);
            let towards = Vec3::new(0.9, 0.0, 0.0) - origin;
            let dir = towards.normalize() * length;
            let at = towards.length() / length;
            let hit = portals.intersect(&Ray::new(origin, dir, at * 1.01, 0.0));
            assert!(
                hit.is_some_and(|h| (h.t - at).abs() <= 1e-5 * at),
                "length {length}"
            );
        }
    }

    #[test]
    fn teleport_leaves_the_there_front_and_keeps_the_point() {
        let portals = facing_pair(4.0, 0.0, 2.0, DVec3::ZERO);
        let hit = portals
            .intersect(&Ray::new(Vec3::new(0.3, 0.1, 1.0), -Vec3::Z, 10.0, 0.0))
            .unwrap();
        assert_eq!(hit.opening, 0);
        assert!((hit.t - 1.0).abs() < 1e-6);
        let out = portals.teleport(&hit, -Vec3::Z, 0.0).unwrap();
        // A's there frame is B's here frame turned half a turn: the ray comes out of B's front
        // (world −Z) at the mirrored point, scaled by 2.
        assert!((out.direction - -Vec3::Z).length() < 1e-6);
        assert!((out.origin - Vec3::new(0.6, 0.2, 4.0)).length() < 1e-4);
        // From behind, or going away, nothing teleports.
        assert!(
            portals
                .intersect(&Ray::new(Vec3::new(0.3, 0.1, -1.0), -Vec3::Z, 10.0, 0.0))
                .is_none()
        );
        assert!(
            portals
                .intersect(&Ray::new(Vec3::new(0.3, 0.1, 1.0), Vec3::Z, 2.0, 0.0))
                .is_none()
        );
    }

    #[test]
    fn refraction_follows_snell_and_reflects_totally_past_the_critical_angle() {
        let d = DVec3::new(0.6, 0.0, -0.8);
        let t = refract(d, DVec3::Z, 1.0 / 1.5).unwrap();
        assert!((t.x - 0.6 / 1.5).abs() < 1e-12 && t.z < 0.0);
        assert!(refract(d, DVec3::Z, 2.0).is_none());
        assert!((refract(d, DVec3::Z, 1.0).unwrap() - d).length() < 1e-12);
    }
}
