//! Learning where bounces are aimed at openings ([`crate::through::bounce_guide`]) from the
//! bounces training paths made ([`super::training`]).
//!
//! Each recorded bounce knows what came back along it (its own estimate of the light it
//! scatters) and the opening its ray teleported through at once, if any. In a region, let T be
//! what came back through the openings and R the rest. When the openings' part is sampled
//! mostly by aiming and the rest mostly by the BSDF, a mixture that aims with probability a has
//! a variance near T²/a + R²/(1 − a), least at a = T / (T + R): the region aims with the share
//! of its light that came through openings, at each opening in proportion to what it brought,
//! held between `bounce_guide`'s `LEAST_SHARE` and `MAX_SHARE` (why: there). Regions where no
//! light came through an opening do not aim.
//!
//! Bounces drawn from the BSDF alone rarely leave through a small opening (a few in a region's
//! hundreds), too few to tell T from. So training runs twice: the first paths, from the BSDF
//! alone, only show which openings each (large) region's bounces leave through at all
//! ([`prior`]); the second aim half their bounces at those, and what they bring teaches the
//! guide ([`learn`]). Whatever the paths were drawn with, each bounce's value is an unbiased
//! estimate of its part, so T and R are too.
use crate::integrator::BounceRecord;
use crate::sampling::regions::RegionTree;
use crate::through::bounce_guide::{Aim, BounceGuide, Guidance, MAX_AIMED};

/// A region of the guide is halved while it holds more bounces than this.
const REGION_BOUNCES: usize = 512;
/// Bounces a region must have seen before its aim is trusted.
const LEAST_BOUNCES: usize = 64;
/// A region of the first training pass's guide is halved while it holds more bounces than
/// this: large, so that the rare bounces through an opening are seen.
const PRIOR_REGION_BOUNCES: usize = 8192;
/// The share of bounces the second training pass aims at the openings the first saw.
const PRIOR_SHARE: f64 = 0.5;

/// What bounces learn, region by region, from `records`; `None` when no region saw enough
/// of them.
pub fn learn(records: &[BounceRecord]) -> Option<BounceGuide> {
    regions_of(records, REGION_BOUNCES, aim)
}

/// Where the second training pass aims, from the first pass's `records`: in large regions,
/// half the bounces at the openings some bounce there left through, in proportion to how many
/// did; `None` when none did.
pub fn prior(records: &[BounceRecord]) -> Option<BounceGuide> {
    regions_of(records, PRIOR_REGION_BOUNCES, |records, members, _| {
        let mut seen = through_openings(records, members, |_| 1.0);
        most_first(&mut seen);
        Aim::new(&seen, PRIOR_SHARE)
    })
}

/// The guide over `records` in regions of at most `most` bounces, each aimed as `aim` teaches
/// from its bounces and their total value; `None` when no region saw enough bounces.
fn regions_of(
    records: &[BounceRecord],
    most: usize,
    aim: impl Fn(&[BounceRecord], &[u32], f64) -> Option<Aim> + Sync,
) -> Option<BounceGuide> {
    let guide = RegionTree::learn(
        records.len(),
        most,
        |i| records[i as usize].p,
        |members| guidance(records, members, &aim),
    )?;
    (guide.learned().0 > 0).then(|| BounceGuide::new(guide))
}

/// A region's guidance from its bounces (`members`, indices of `records`), aimed as `aim`
/// teaches from them and their total value; `None` when they are too few.
fn guidance(
    records: &[BounceRecord],
    members: &[u32],
    aim: impl Fn(&[BounceRecord], &[u32], f64) -> Option<Aim>,
) -> Option<Guidance> {
    if members.len() < LEAST_BOUNCES {
        return None;
    }
    let total: f64 = members
        .iter()
        .map(|&i| records[i as usize].value as f64)
        .sum();
    Some(Guidance {
        aim: aim(records, members, total),
        brought: (total / members.len() as f64) as f32,
    })
}

/// The openings `members`' bounces left through (in the order first met), each with the sum
/// of `weight` over them.
fn through_openings(
    records: &[BounceRecord],
    members: &[u32],
    weight: impl Fn(&BounceRecord) -> f64,
) -> Vec<(u32, f64)> {
    let mut through: Vec<(u32, f64)> = Vec::new();
    for &i in members {
        let record = &records[i as usize];
        if let Some(opening) = record.opening {
            match through.iter_mut().find(|(o, _)| *o == opening) {
                Some((_, sum)) => *sum += weight(record),
                None => through.push((opening, weight(record))),
            }
        }
    }
    through
}

/// Sorts openings by weight, most first (ties to the lower index, so the order is the same
/// whatever the records' order), keeping those an aim holds.
fn most_first(openings: &mut Vec<(u32, f64)>) {
    openings.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    openings.truncate(MAX_AIMED);
}

/// The aim one region's bounces (`members`, indices of `records`, whose values sum to
/// `total`) teach; `None` when none of their light came through openings.
fn aim(records: &[BounceRecord], members: &[u32], total: f64) -> Option<Aim> {
    let mut through = through_openings(records, members, |r| r.through as f64);
    let share = through.iter().map(|(_, v)| v).sum::<f64>() / total;
    // A region that brought nothing gives NaN, which does not aim either.
    if share.is_nan() {
        return None;
    }
    most_first(&mut through);
    Aim::new(&through, share)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::through::bounce_guide::{LEAST_SHARE, MAX_SHARE};
    use glam::Vec3;

    /// A bounce at `x` that brought `value`, all of it through `opening` when there is one.
    fn record(x: f32, opening: Option<u32>, value: f32) -> BounceRecord {
        BounceRecord {
            p: Vec3::new(x, 0.0, 0.0),
            opening,
            value,
            through: if opening.is_some() { value } else { 0.0 },
        }
    }

    #[test]
    fn a_region_aims_with_the_share_of_its_light_that_came_through_openings() {
        // 100 bounces: 80 brought 1 each without an opening, 15 brought 2 through opening 4,
        // 5 brought 3 through opening 7: shares 0.24 and 0.12 of 125.
        let records: Vec<BounceRecord> = (0..100)
            .map(|k| match k % 20 {
                0..=15 => record(0.0, None, 1.0),
                16..=18 => record(0.0, Some(4), 2.0),
                _ => record(0.0, Some(7), 3.0),
            })
            .collect();
        let members: Vec<u32> = (0..100).collect();
        let learned = guidance(&records, &members, aim).expect("enough bounces");
        assert!((learned.brought - 1.25).abs() < 1e-6, "{}", learned.brought);
        let aim = learned.aim.expect("aims");
        assert!((aim.share - 0.36).abs() < 1e-6, "{}", aim.share);
        let openings: Vec<(u32, f32)> = aim.openings().collect();
        assert_eq!(openings[0].0, 4);
        assert!((openings[0].1 - 2.0 / 3.0).abs() < 1e-6, "{openings:?}");
        assert_eq!(openings[1].0, 7);
    }

    #[test]
    fn light_met_before_an_opening_is_not_light_through_it() {
        // Every bounce left through opening 1, but 90% of what each brought was a lamp in
        // front of the opening: a tenth came through.
        let records: Vec<BounceRecord> = (0..100)
            .map(|_| BounceRecord {
                through: 0.1,
                ..record(0.0, Some(1), 1.0)
            })
            .collect();
        let aim = aim(&records, &(0..100).collect::<Vec<u32>>(), 100.0).expect("aims");
        assert!((aim.share - 0.1).abs() < 1e-6, "{}", aim.share);
    }

    #[test]
    fn shares_are_held_between_the_least_and_the_most() {
        let members: Vec<u32> = (0..100).collect();
        // 2 of 100 bounces through an opening, each bringing as much as the rest: 2%, aimed
        // at the least share all the same.
        let rare: Vec<BounceRecord> = (0..100)
            .map(|k| record(0.0, (k < 2).then_some(1), 1.0))
            .collect();
        assert_eq!(
            aim(&rare, &members, 100.0).expect("aims").share,
            LEAST_SHARE
        );
        // None through an opening: no aim.
        let none: Vec<BounceRecord> = (0..100).map(|_| record(0.0, None, 1.0)).collect();
        assert_eq!(aim(&none, &members, 100.0), None);
        // Nothing brought anything.
        let dark: Vec<BounceRecord> = (0..100).map(|_| record(0.0, Some(1), 0.0)).collect();
        assert_eq!(aim(&dark, &members, 0.0), None);
        // Too few to trust.
        let few: Vec<BounceRecord> = (0..10).map(|_| record(0.0, Some(1), 1.0)).collect();
        assert_eq!(guidance(&few, &(0..10).collect::<Vec<u32>>(), aim), None);
        // All of it through an opening: aimed at the most that keeps BSDF sampling.
        let all: Vec<BounceRecord> = (0..100).map(|_| record(0.0, Some(1), 1.0)).collect();
        assert_eq!(aim(&all, &members, 100.0).expect("aims").share, MAX_SHARE);
    }

    #[test]
    fn regions_are_learned_apart() {
        // Bounces near x = 0 see a quarter of their light through opening 2 and bring 1 each;
        // those near x = 100 see none and bring 3 each.
        let records: Vec<BounceRecord> = (0..4096)
            .map(|k| {
                let near = k % 2 == 0;
                let x = if near { 0.0 } else { 100.0 } + k as f32 / 4096.0;
                let through = near && k % 8 == 0;
                record(x, through.then_some(2), if near { 1.0 } else { 3.0 })
            })
            .collect();
        let guide = learn(&records).expect("regions learned");
        let near = guide.at(Vec3::new(0.5, 0.0, 0.0)).expect("learned near");
        assert!((near.aim.expect("aims").share - 0.25).abs() < 0.05);
        assert!((near.brought - 1.0).abs() < 1e-6);
        let far = guide.at(Vec3::new(100.5, 0.0, 0.0)).expect("learned far");
        assert_eq!(far.aim, None);
        assert!((far.brought - 3.0).abs() < 1e-6);
    }

    #[test]
    fn the_second_pass_aims_half_its_bounces_where_the_first_saw_any_leave() {
        // One bounce in a thousand near x = 0 left through opening 5; none near x = 100.
        let records: Vec<BounceRecord> = (0..2 * PRIOR_REGION_BOUNCES as u32 * 2)
            .map(|k| {
                let near = k % 2 == 0;
                let x = if near { 0.0 } else { 100.0 } + k as f32 * 1e-4;
                record(x, (near && k % 1000 == 0).then_some(5), 1.0)
            })
            .collect();
        let prior = prior(&records).expect("some region saw an opening");
        let near = prior.at(Vec3::new(0.5, 0.0, 0.0)).expect("learned near");
        let aim = near.aim.expect("aims near");
        assert_eq!(aim.share as f64, PRIOR_SHARE);
        assert_eq!(aim.openings().collect::<Vec<_>>(), [(5, 1.0)]);
        let far = prior.at(Vec3::new(100.5, 0.0, 0.0)).expect("learned far");
        assert_eq!(far.aim, None);
    }
}
