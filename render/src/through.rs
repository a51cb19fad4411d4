//! Light sampling through openings: where next-event estimation looks for light.
//!
//! A ray that teleports through openings a, b, … continues on the straight line that the
//! composed teleport S = S_b ∘ S_a (each S = P_T · P_H⁻¹ at the ray's times) makes of it. So
//! the light that a shading point p receives through that chain is the light that the virtual
//! point S(p) receives in the space beyond it, restricted to the directions that pass every
//! opening's mask. Similarities keep solid angles, so a light sample drawn for S(p) has the same
//! solid-angle pdf at p, and its direction maps back to p by S's rotation.
//!
//! At each shading point [`Strategies::update`] lists the ways to sample light: ordinary light
//! sampling, and one *virtual space* per chain of up to [`CHAIN_DEPTH`] openings (never past
//! `max_portal_depth`) whose front the point faces, whose aperture is above its surface and,
//! for a second opening, which can be seen through the first. Each gets a probability in
//! proportion to an estimate of what it brings:
//!
//! - ordinary: the light tree's unoccluded estimate at p (plus the environment's);
//! - a chain: the product of its openings' opacity × tint, times the aperture bound
//!   Ω · E_exit / π, where Ω is the smallest projected solid angle of the chain's openings seen
//!   along the way (capped at 2π) and E_exit the tree's estimate at the centre of the last
//!   exit, facing out ([`exit_light`], once per scene at mid-shutter).
//!
//! Openings behind the point, facing away, below its surface or hidden behind the previous
//! opening get no strategy at all, and a scene without openings has only the ordinary one: it
//! pays nothing. Openings with an index of refraction other than 1 bend light in a way that has
//! no closed-form inverse, so no chain passes them: light through them is found by BSDF
//! sampling alone, with full weight, as before.
//!
//! The probabilities enter the light-sampling density (q · pdf), so the MIS weight of emission
//! that BSDF sampling finds after the same chain of teleports uses [`Strategies::find`] at the
//! previous vertex, with the BSDF density times the chain's coin probabilities (opacity per
//! teleport, 1 − opacity per opening passed). Estimates may be poor without bias: every path is
//! still counted once.

use crate::lights::{Lights, Receiver};
use crate::portal::Portals;
use crate::scene::Scene;
use glam::{DQuat, DVec3, Vec3};
use smallvec::SmallVec;
use std::f64::consts::PI;

/// The most openings in a row that light sampling looks through. Longer chains (a corridor of
/// mirrors) are still lit, by BSDF sampling.
pub const CHAIN_DEPTH: usize = 2;
/// The most virtual spaces kept at one shading point (the most promising).
const MAX_SPACES: usize = 6;

/// The openings a path teleported through since its last scattering event, in order.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Chain {
    /// The first [`CHAIN_DEPTH`] openings (no strategy samples a longer chain).
    openings: [u16; CHAIN_DEPTH],
    /// Teleports in all, however many.
    teleports: u32,
}

impl Chain {
    /// Appends opening `i`.
    pub fn push(&mut self, i: usize) {
        if (self.teleports as usize) < CHAIN_DEPTH {
            self.openings[self.teleports as usize] = i as u16;
        }
        self.teleports += 1;
    }

    /// How many teleports the chain holds.
    pub fn teleports(&self) -> u32 {
        self.teleports
    }

    /// The openings, in the order a ray meets them (the first [`CHAIN_DEPTH`] of them).
    pub fn openings(&self) -> impl Iterator<Item = usize> + '_ {
        self.openings[..(self.teleports as usize).min(CHAIN_DEPTH)]
            .iter()
            .map(|&i| i as usize)
    }
}

/// The space beyond a chain of openings, as a shading point's light sampling sees it.
#[derive(Clone, Copy, Debug)]
pub struct Space {
    pub chain: Chain,
    /// The rotation of the composed teleport (directions at p to directions beyond).
    rotation: DQuat,
    /// The shading point mapped beyond the chain, with the last exit's outward normal (light
    /// can only come from that side) and the time after the chain's offsets.
    pub receiver: Receiver,
}

impl Space {
    /// A direction beyond the chain brought back to the shading point.
    pub fn direction_back(&self, d: Vec3) -> Vec3 {
        (self.rotation.inverse() * d.as_dvec3())
            .normalize()
            .as_vec3()
    }
}

/// The ways light sampling can go at one shading point, with their probabilities.
#[derive(Clone, Copy, Debug)]
pub struct Strategies {
    /// Probability of ordinary light sampling.
    direct: f32,
    spaces: [Option<(Space, f32)>; MAX_SPACES],
}

impl Strategies {
    /// Sets `slot` to the strategies at `at` (world space, at its time); `None` when there is
    /// only ordinary light sampling: the scene turns light through openings off, has no
    /// opening or no light, allows no teleport, or no opening can bring light to the point.
    ///
    /// It fills the caller's slot rather than returning the table because the compiler copies
    /// a returned table (half a kilobyte) even when it is `None`: 10% of the Cornell box's
    /// render time.
    #[inline]
    pub fn update(slot: &mut Option<Self>, scene: &Scene, at: &Receiver) {
        let max_depth = scene.settings.max_portal_depth;
        if !scene.settings.light_through_openings
            || scene.portals.is_empty()
            || scene.lights.is_empty()
            || max_depth == 0
        {
            *slot = None;
        } else {
            *slot = Self::search(scene, at, max_depth);
        }
    }

    /// The strategies at `at` in a scene where openings may bring light.
    fn search(scene: &Scene, at: &Receiver, max_depth: u32) -> Option<Self> {
        let (portals, lights) = (&scene.portals, &scene.lights);
        let mut found: SmallVec<[(Space, f32); 16]> = SmallVec::new();
        let mut frontier: SmallVec<[Reach; 8]> = smallvec::smallvec![Reach::start(at)];
        for _ in 0..CHAIN_DEPTH.min(max_depth as usize) {
            let mut next = SmallVec::new();
            for from in &frontier {
                for i in 0..portals.len() {
                    let Some(reach) = from.through(portals, i) else {
                        continue;
                    };
                    let estimate = reach.factor * reach.solid_angle * scene.exit_light[i]
                        / std::f32::consts::PI;
                    if estimate > 0.0 && estimate.is_finite() {
                        found.push((reach.space(), estimate));
                    }
                    next.push(reach);
                }
            }
            frontier = next;
        }
        // The most promising first; ties keep the enumeration order, so the choice is the
        // same wherever it is made.
        found.sort_by(|a, b| b.1.total_cmp(&a.1));
        found.truncate(MAX_SPACES);
        let direct = lights.importance(at);
        let total = direct + found.iter().map(|f| f.1).sum::<f32>();
        if !(total > 0.0 && total.is_finite()) || found.is_empty() {
            return None;
        }
        let mut spaces = [None; MAX_SPACES];
        for (slot, (space, estimate)) in spaces.iter_mut().zip(found) {
            *slot = Some((space, estimate / total));
        }
        Some(Self {
            direct: direct / total,
            spaces,
        })
    }

    /// The probability of ordinary light sampling.
    pub fn direct(&self) -> f32 {
        self.direct
    }

    /// The virtual spaces with their probabilities, the most promising first.
    pub fn spaces(&self) -> impl Iterator<Item = (&Space, f32)> {
        self.spaces.iter().flatten().map(|(space, q)| (space, *q))
    }

    /// Picks a strategy with `u` in [0, 1): `None` is ordinary light sampling. Returns its
    /// probability too.
    pub fn pick(&self, u: f32) -> (Option<&Space>, f32) {
        let mut below = self.direct;
        if u < below || self.spaces[0].is_none() {
            return (None, self.direct);
        }
        let mut last = (None, self.direct);
        for (space, q) in self.spaces.iter().flatten() {
            below += q;
            last = (Some(space), *q);
            if u < below {
                break;
            }
        }
        last
    }

    /// The probability of the strategy that samples light through `chain` (ordinary light
    /// sampling for an empty chain), with its space; 0 when no strategy does.
    pub fn find(&self, chain: &Chain) -> (f32, Option<&Space>) {
        if *chain == Chain::default() {
            return (self.direct, None);
        }
        self.spaces
            .iter()
            .flatten()
            .find(|(space, _)| space.chain == *chain)
            .map_or((0.0, None), |(space, q)| (*q, Some(space)))
    }
}

/// A chain being extended while strategies are enumerated: where the shading point is in the
/// space reached so far, and what the chain has cost.
struct Reach {
    chain: Chain,
    /// Rotation of the composed teleport so far.
    rotation: DQuat,
    /// The shading point in the space reached, its normal there (the last exit's for a
    /// virtual point), and its time.
    point: DVec3,
    normal: Option<DVec3>,
    time: f64,
    /// Product of opacity × luminance of tint over the chain.
    factor: f32,
    /// The smallest projected solid angle of the chain's openings seen along the way.
    solid_angle: f32,
    /// The last exit.
    exit: Option<Exit>,
}

impl Reach {
    fn start(at: &Receiver) -> Self {
        Self {
            chain: Chain::default(),
            rotation: DQuat::IDENTITY,
            point: at.p.as_dvec3(),
            normal: at.n.map(Vec3::as_dvec3),
            time: at.time,
            factor: 1.0,
            solid_angle: f32::INFINITY,
            exit: None,
        }
    }

    /// The chain extended through opening `i`, when light can come through it at all.
    fn through(&self, portals: &Portals, i: usize) -> Option<Self> {
        let look = portals.look(i);
        if look.ior != 1.0 || look.opacity <= 0.0 || look.tint == Vec3::ZERO {
            return None;
        }
        let here = portals.here(i, self.time);
        let to_centre = here.translation - self.point;
        // The point's height above the opening's plane (its local z, in world units).
        let height = -to_centre.dot(here.transform_direction(DVec3::Z));
        if height <= 0.0 {
            return None; // behind the opening
        }
        let scale = here.scale;
        let mask = portals.mask(i);
        let radius = mask.bounding_radius() * scale;
        let distance = to_centre.length();
        // Above the point's surface: some of the aperture's sphere is in front of it.
        let cos_receiver = match self.normal {
            Some(n) => ((to_centre.dot(n) + radius) / distance).min(1.0),
            None => 1.0,
        };
        if cos_receiver <= 0.0 {
            return None;
        }
        if let Some(exit) = &self.exit
            && !exit.shows(self.point, self.point + to_centre, radius)
        {
            return None;
        }
        let cos_aperture = height / distance;
        let area = mask.area() * scale * scale;
        let solid_angle =
            ((area * cos_aperture / (distance * distance)).min(2.0 * PI) * cos_receiver) as f32;
        let (teleport, time) = portals.teleport_map(i, self.time);
        let there = portals.there(i, time);
        let leaving = there.transform_direction(-DVec3::Z);
        let mut chain = self.chain;
        chain.push(i);
        Some(Self {
            chain,
            rotation: teleport.rotation * self.rotation,
            point: teleport.transform_point(self.point),
            normal: Some(leaving),
            time,
            factor: self.factor * look.opacity * luminance(look.tint),
            solid_angle: self.solid_angle.min(solid_angle),
            exit: Some(Exit {
                centre: there.translation,
                radius: mask.bounding_radius() * there.scale,
                leaving,
            }),
        })
    }

    fn space(&self) -> Space {
        Space {
            chain: self.chain,
            rotation: self.rotation,
            receiver: Receiver {
                p: self.point.as_vec3(),
                n: self.normal.map(DVec3::as_vec3),
                time: self.time,
            },
        }
    }
}

/// Where rays leave the last opening of a chain.
struct Exit {
    centre: DVec3,
    /// Bounding radius of its mask.
    radius: f64,
    /// Unit direction rays leave in.
    leaving: DVec3,
}

impl Exit {
    /// True when a sphere around `centre` of `radius` can be seen from `point` through the
    /// exit's sphere: it reaches the far side of the exit, and the cones from the point around
    /// the two spheres overlap.
    fn shows(&self, point: DVec3, centre: DVec3, radius: f64) -> bool {
        if (centre - self.centre).dot(self.leaving) < -radius {
            return false;
        }
        let (to_exit, to_target) = (self.centre - point, centre - point);
        let (d_exit, d_target) = (to_exit.length(), to_target.length());
        if d_exit <= self.radius || d_target <= radius {
            return true;
        }
        // angle ≤ a + b ⇔ cos(angle) ≥ cos a cos b − sin a sin b (a, b within [0, π/2]).
        let (sin_a, sin_b) = (self.radius / d_exit, radius / d_target);
        let (cos_a, cos_b) = ((1.0 - sin_a * sin_a).sqrt(), (1.0 - sin_b * sin_b).sqrt());
        to_exit.dot(to_target) / (d_exit * d_target) >= cos_a * cos_b - sin_a * sin_b
    }
}

/// What each opening's exit can pass on: the light tree's unoccluded estimate at the centre
/// of its there side, facing the way rays leave, at the middle of the ray times.
pub fn exit_light(portals: &Portals, lights: &Lights) -> Vec<f32> {
    let times = portals.times();
    let time = 0.5 * (times[0] + times[1]);
    (0..portals.len())
        .map(|i| {
            let there = portals.there(i, time);
            lights.importance(&Receiver {
                p: there.translation.as_vec3(),
                n: Some(there.transform_direction(-DVec3::Z).as_vec3()),
                time,
            })
        })
        .collect()
}

fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}
