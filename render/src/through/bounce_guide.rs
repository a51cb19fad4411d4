//! Bounces aimed at openings: where light reaches a room through an opening after bouncing
//! beyond it (a sunlit room seen through a window, a corridor lit round a corner), no light
//! sample can aim at what lights the room, which is the lit surfaces beyond the opening; only a
//! bounce that happens to leave through the opening finds them, and the opening fills a small
//! part of each point's hemisphere.
//!
//! So, region by region of the scene ([`RegionTree`]), training paths learn what share of what
//! a bounce brings back came through each opening ([`crate::prepare::aiming`]). Where any light
//! came through, a bounce is aimed with about that probability ([`Aim::share`], between
//! [`LEAST_SHARE`] and [`MAX_SHARE`]) at a uniform point of one of the openings' apertures,
//! picked in proportion to what each brought ([`aperture_sampling`]), and otherwise drawn from
//! the BSDF. The bounce's density is the mixture of both ([`Aim::mixed`]): a one-sample
//! defensive mixture, unbiased whatever was learned (BSDF sampling keeps at least
//! 1 − [`MAX_SHARE`] of every bounce), and the density that MIS weighs light sampling against.
//!
//! Only opaque surfaces that are not mirrors aim: through glass and in media the BSDF's own
//! sampling is kept.

use super::aperture_sampling;
use crate::portals::Portals;
use crate::sampling::regions::RegionTree;
use glam::{Vec2, Vec3};

/// Openings a region aims at, at most.
pub const MAX_AIMED: usize = 4;
/// The largest share of a region's bounces aimed at openings: BSDF sampling keeps the rest, for
/// the light that does not come through them. An unaimed bounce's weight is divided by
/// 1 − share, and along a path that stays in the room those factors multiply: with 0.8 the
/// example's paths gathered fireflies (measured on `bounce_through`, at 64 spp over five seeds:
/// 0.8 was 0.75× as efficient as 0.5).
pub const MAX_SHARE: f32 = 0.5;
/// The least share of a region's bounces aimed at openings, wherever some of its light came
/// through them: a share learned too small (from a region's few hundred bounces, the rest's
/// estimate swollen by one bright path) leaves that light to bounces that leave through the
/// opening by chance, each a firefly; aiming at least this much bounds their weight (measured:
/// 1.6× as efficient as not aiming below 5%).
pub const LEAST_SHARE: f32 = 0.1;

/// What training learned in each region, and how bright the scene's brightest regions are.
#[derive(Clone, Debug, PartialEq)]
pub struct BounceGuide {
    regions: RegionTree<Guidance>,
    /// What a bounce brings back in the brightest regions (the 95th percentile over regions).
    brightest: f32,
}

impl BounceGuide {
    /// The guide over `regions`.
    pub fn new(regions: RegionTree<Guidance>) -> Self {
        let mut brought: Vec<f32> = regions.values().iter().map(|g| g.brought).collect();
        brought.sort_by(f32::total_cmp);
        let brightest = brought.get(brought.len() * 19 / 20).copied().unwrap_or(0.0);
        Self { regions, brightest }
    }

    /// The guidance at `p`; `None` outside the regions or where nothing was learned.
    #[inline]
    pub fn at(&self, p: Vec3) -> Option<&Guidance> {
        self.regions.at(p)
    }

    /// The regions.
    pub fn regions(&self) -> &RegionTree<Guidance> {
        &self.regions
    }

    /// What a bounce brings back in the scene's brightest regions.
    pub fn brightest(&self) -> f32 {
        self.brightest
    }

    /// What was learned, for a person: how many regions learned anything, how many aim at
    /// openings, of how many, and the guide's size.
    pub fn summary(&self) -> String {
        let (learned, regions) = self.regions.learned();
        let aiming = self.regions.values().iter().filter(|g| g.aim.is_some());
        format!(
            "{} of {regions} regions aim at openings ({learned} learned), {:.1} KiB",
            aiming.count(),
            self.regions.bytes() as f64 / 1024.0
        )
    }
}

/// What one region's bounces learned.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Guidance {
    /// Where its bounces are aimed (`None`: drawn from the BSDF alone).
    pub aim: Option<Aim>,
    /// The luminance a bounce here brought back on average, per unit of throughput: what
    /// continuing a path here is worth, which roulette weighs against what the path's pixel is
    /// worth (see [`crate::integrator`]).
    pub brought: f32,
}

/// How bounces in one region are aimed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aim {
    /// The probability that a bounce here is aimed at an opening, not drawn from the BSDF.
    pub share: f32,
    /// The openings aimed at (the first `count`), with the probability of each among them.
    openings: [u32; MAX_AIMED],
    chances: [f32; MAX_AIMED],
    count: u8,
}

impl Aim {
    /// Aims at `openings` (at most [`MAX_AIMED`]), each picked in proportion to its weight,
    /// with probability `share` held between [`LEAST_SHARE`] and [`MAX_SHARE`]; `None` without
    /// an opening of positive weight or a positive share.
    pub fn new(openings: &[(u32, f64)], share: f64) -> Option<Self> {
        let kept = &openings[..openings.len().min(MAX_AIMED)];
        let total: f64 = kept.iter().map(|&(_, w)| w.max(0.0)).sum();
        if !(total > 0.0 && total.is_finite() && share > 0.0) {
            return None;
        }
        let mut aim = Aim {
            share: (share as f32).clamp(LEAST_SHARE, MAX_SHARE),
            openings: [0; MAX_AIMED],
            chances: [0.0; MAX_AIMED],
            count: kept.len() as u8,
        };
        for (k, &(opening, weight)) in kept.iter().enumerate() {
            aim.openings[k] = opening;
            aim.chances[k] = (weight.max(0.0) / total) as f32;
        }
        Some(aim)
    }

    /// The openings aimed at, with the probability of each among them.
    pub fn openings(&self) -> impl Iterator<Item = (u32, f32)> + '_ {
        let n = self.count as usize;
        self.openings[..n]
            .iter()
            .copied()
            .zip(self.chances[..n].iter().copied())
    }

    /// A direction from `from` at `time` towards a uniform point of one of the openings (picked
    /// with `u_pick`), drawn with `u`; `None` when `from` is not in front of that opening.
    #[inline]
    pub fn sample(
        &self,
        portals: &Portals,
        time: f64,
        from: Vec3,
        u_pick: f32,
        u: Vec2,
    ) -> Option<Vec3> {
        let mut start = 0.0;
        let mut picked = self.openings[0];
        for (opening, chance) in self.openings() {
            picked = opening;
            start += chance;
            if u_pick < start {
                break;
            }
        }
        aperture_sampling::sample(portals, picked as usize, time, from, u).map(|(dir, _)| dir)
    }

    /// The solid-angle density with which [`Self::sample`] gives direction `dir` from `from`.
    #[inline]
    pub fn pdf(&self, portals: &Portals, time: f64, from: Vec3, dir: Vec3) -> f32 {
        self.openings()
            .map(|(opening, chance)| {
                chance * aperture_sampling::pdf(portals, opening as usize, time, from, dir)
            })
            .sum()
    }

    /// The density of a bounce here: aimed with `aimed` density with probability
    /// [`Self::share`], drawn from the BSDF with `bsdf` density otherwise.
    #[inline]
    pub fn mixed(&self, bsdf: f32, aimed: f32) -> f32 {
        (1.0 - self.share) * bsdf + self.share * aimed
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::portals::masks::Mask;
    use crate::portals::openings::OpeningLook;
    use glam::{DQuat, DVec2, DVec3};
    use rift_fx::rig::{Rig, Similarity};

    /// Two pairs of openings: 0 (a disk) and 2 (a rectangle) face +X from x = 0, at z = −1 and
    /// z = +1; 1 and 3 are their pairs far away.
    fn two_windows() -> Portals {
        let facing_x = DQuat::from_rotation_y(std::f64::consts::FRAC_PI_2);
        let here = |z| Similarity::new(facing_x, DVec3::new(0.0, 0.0, z), 1.0);
        let far = |z| Similarity::from_translation(DVec3::new(100.0, 0.0, z));
        let mut rig = Rig::still_pair(here(-1.0), far(-1.0));
        let mut second = Rig::still_pair(here(1.0), far(1.0)).openings;
        for (k, opening) in second.iter_mut().enumerate() {
            opening.name = format!("second {k}");
            opening.there = rift_fx::rig::ThereFrame::Paired(3 - k);
        }
        rig.openings.extend(second);
        let disk = Mask::Disk { radius: 0.4 };
        let rectangle = Mask::Rectangle {
            half: DVec2::new(0.3, 0.5),
        };
        Portals::new(
            rig,
            vec![disk.clone(), disk, rectangle.clone(), rectangle],
            vec![OpeningLook::default(); 4],
            [0.0, 0.0],
            &[false; 4],
        )
    }

    #[test]
    fn aimed_directions_have_the_density_the_aim_gives_them() {
        let portals = two_windows();
        let aim = Aim::new(&[(0, 3.0), (2, 1.0)], 0.6).expect("aims");
        assert_eq!(aim.openings().collect::<Vec<_>>(), [(0, 0.75), (2, 0.25)]);
        let from = Vec3::new(2.0, 0.3, 0.2);
        // Σ 1/pdf over aimed directions estimates the solid angle the two openings cover
        // together; each also counts the solid angle it covers alone. Four picks (three land on
        // the disk) each over the whole grid of points.
        let n = 64u32;
        let (mut sum, mut hits) = (0.0f64, [0u32; 2]);
        for pick in 0..4 {
            let u_pick = (pick as f32 + 0.5) / 4.0;
            for k in 0..n * n {
                let u = Vec2::new(
                    ((k % n) as f32 + 0.5) / n as f32,
                    ((k / n) as f32 + 0.5) / n as f32,
                );
                let dir = aim
                    .sample(&portals, 0.0, from, u_pick, u)
                    .expect("in front");
                let pdf = aim.pdf(&portals, 0.0, from, dir);
                assert!(pdf > 0.0);
                sum += 1.0 / pdf as f64;
                hits[(dir.z > 0.0) as usize] += 1;
            }
        }
        let estimated = sum / (4 * n * n) as f64;
        let solid_angle = |i: usize| {
            // Integrates the uniform aperture density of opening i alone.
            let alone = Aim::new(&[(i as u32, 1.0)], 1.0).expect("aims");
            let mut s = 0.0f64;
            for k in 0..n * n {
                let u = Vec2::new(
                    ((k % n) as f32 + 0.5) / n as f32,
                    ((k / n) as f32 + 0.5) / n as f32,
                );
                let dir = alone.sample(&portals, 0.0, from, 0.5, u).expect("in front");
                s += 1.0 / alone.pdf(&portals, 0.0, from, dir) as f64;
            }
            s / (n * n) as f64
        };
        let both = solid_angle(0) + solid_angle(2);
        assert!(
            (estimated - both).abs() < 1e-3 * both,
            "{estimated} against {both}"
        );
        // Three in four aimed at the disk (at z = −1).
        assert_eq!(hits, [3 * n * n, n * n]);
    }

    #[test]
    fn the_mixture_keeps_the_bsdf_share_and_refuses_empty_aims() {
        let aim = Aim::new(&[(5, 1.0)], 3.0).expect("aims");
        assert_eq!(aim.share, MAX_SHARE);
        assert!((aim.mixed(1.0, 0.0) - (1.0 - MAX_SHARE)).abs() < 1e-6);
        assert!((aim.mixed(0.0, 2.0) - 2.0 * MAX_SHARE).abs() < 1e-6);
        assert_eq!(Aim::new(&[], 0.5), None);
        assert_eq!(Aim::new(&[(1, 0.0)], 0.5), None);
        assert_eq!(Aim::new(&[(1, 1.0)], 0.0), None);
        assert_eq!(Aim::new(&[(1, f64::NAN)], 0.5), None);
        // More openings than it keeps: the first MAX_AIMED.
        let many: Vec<(u32, f64)> = (0..9).map(|i| (i, 1.0)).collect();
        let aim = Aim::new(&many, 0.5).expect("aims");
        assert_eq!(aim.openings().count(), MAX_AIMED);
    }

    #[test]
    fn behind_an_opening_nothing_is_aimed_and_nothing_has_density() {
        let portals = two_windows();
        let aim = Aim::new(&[(0, 1.0)], 0.5).expect("aims");
        let behind = Vec3::new(-1.0, 0.0, -1.0);
        assert_eq!(
            aim.sample(&portals, 0.0, behind, 0.2, Vec2::splat(0.5)),
            None
        );
        assert_eq!(aim.pdf(&portals, 0.0, behind, Vec3::X), 0.0);
    }
}
