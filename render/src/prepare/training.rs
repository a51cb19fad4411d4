//! Learning light selection per region ([`crate::lights::guide`]) from training paths.
//!
//! The tree's importance is an unoccluded bound. It cannot see that a ring lying in the plane of
//! the wall it lights sends that wall little, that the lamps of a room are behind a wall from the
//! room next door, or that one side of a ring hides behind the other. So, before rendering, a few
//! camera paths are traced at a low resolution ([`TRAINING_WIDTH`] pixels across,
//! [`TRAINING_SPP`] paths each), and every light sample they take is recorded with what it
//! brought, shadow ray included (the path loop's [`Recorder`]). The places those samples were
//! taken at are cut into regions ([`LightGuide::learn`]).
//!
//! In each region, for each lane of the tree's root and of the root's children, the samples
//! give the second moment of the estimate that lane alone would make. One-sample selection has
//! the least variance when lanes are chosen in proportion to the root of that moment. Each
//! lane's factor turns the tree's mean share in the region into that proportion, blended with
//! the tree's own share ([`TREE_SHARE`]) so that no lane the tree would pick is ever starved.
//!
//! Where the scene has an environment beside its emitters, each region also learns the split
//! between them the same way: the estimate behind the split counts the sky in full inside a
//! closed room, and the emitters in full behind a wall.
//!
//! What is recorded is each sample's MIS-weighted value: what light sampling itself must bring,
//! leaving out what BSDF sampling finds well (a wide sky, a big lamp close by).
//!
//! The tree's root holds the kinds of emitters apart when there are at most four (the lamps,
//! and each ring's strands; see [`crate::lights::emitters`]), so the root's factors are what a
//! region learns about each ring and the lamps, and the next level's about each quarter of a
//! ring.
//!
//! The same paths record their bounces (the path loop's `Recorder::bounce`), from which
//! [`aiming`] learns where bounces are aimed at openings, with a second pass of paths aimed
//! where the first saw bounces leave through them.
//!
//! Training depends only on the scene (its resolution, camera and seed), never on the crop, the
//! sample range or the thread count, so every part of a split render learns the same guide.

use crate::camera::Lens;
use crate::geometry::Ray;
#[cfg(doc)]
use crate::integrator::Recorder;
use crate::integrator::{Context, LightRecord, Recording, Wanted, trace};
use crate::lights::Lights;
use crate::lights::emitters::Picked;
use crate::lights::guide::{LightGuide, REGION_SAMPLES, RegionFactors};
use crate::lights::tree::{PerLane, WIDTH};
use crate::prepare::aiming;
use crate::sampling::{SampleStream, hash32};
use crate::through::BounceGuide;
use glam::Vec2;
use rayon::prelude::*;

/// Training paths: the camera's frame at about this many pixels across (at most its own);
/// fewer in fuzz builds, as for [`crate::prepare::visibility`]'s grid.
const TRAINING_WIDTH: u32 = if cfg!(fuzzing) { 16 } else { 160 };
/// Paths per training pixel.
const TRAINING_SPP: u32 = 4;
/// Light samples a region must have seen before its factors are trusted.
const LEAST_SAMPLES: usize = 32;
/// The tree's own share kept in every choice: what the guide cannot starve. On the showcase
/// and `lit_through`, 0.1 to 0.35 all measured within half a percent of noise of 0.2.
const TREE_SHARE: f64 = 0.2;
/// The largest factor a lane gets: a lane the tree all but ignores where it brought most of the
/// light is raised this far, which keeps the descent's weights far from overflow.
const MAX_FACTOR: f64 = 1e4;

/// What training paths taught.
pub struct Trained {
    /// Light selection per region (`None` unless asked for and some path took a light sample).
    pub light_guide: Option<LightGuide>,
    /// Bounces aimed at openings per region (`None` unless asked for and some region found
    /// light coming through openings).
    pub bounce_guide: Option<BounceGuide>,
}

/// Learns light selection (when `lights`) and where to aim bounces at openings (when `aims`)
/// for the paths of `ctx` (its scene, and light sampling through its openings as prepared; no
/// guide yet) from training paths over its camera's frame. Light selection is learned only
/// where it descends a tree.
pub fn train(ctx: &Context, lights: bool, aims: bool) -> Trained {
    let learns_lights = lights && ctx.scene.lights.descends_tree();
    if !(learns_lights || aims) {
        return Trained {
            light_guide: None,
            bounce_guide: None,
        };
    }
    let wanted = Wanted {
        lights: learns_lights,
        bounces: aims,
    };
    let recording = training_records(ctx, 0, wanted);
    let light_records = &recording.lights;
    let lights = &ctx.scene.lights;
    Trained {
        light_guide: learns_lights
            .then(|| {
                LightGuide::learn(
                    light_records.len(),
                    REGION_SAMPLES,
                    |i| light_records[i as usize].receiver.p,
                    |members| learn(lights, light_records, members),
                )
            })
            .flatten(),
        bounce_guide: aims.then(|| learn_aims(ctx, &recording)).flatten(),
    }
}

/// Where to aim bounces at openings, learned by a second pass of training paths aimed where the
/// first pass (`first`) saw bounces leave through openings ([`aiming`]).
fn learn_aims(ctx: &Context, first: &Recording) -> Option<BounceGuide> {
    let prior = aiming::prior(&first.bounces)?;
    let bounces = Wanted {
        lights: false,
        bounces: true,
    };
    let second = training_records(&ctx.aiming(Some(&prior)), 1, bounces);
    aiming::learn(&second.bounces)
}

/// The factors one region's samples (`members`, indices of `records`) teach; `None` when they
/// are too few.
fn learn(lights: &Lights, records: &[LightRecord], members: &[u32]) -> Option<RegionFactors> {
    if members.len() < LEAST_SAMPLES {
        return None;
    }
    let mut moments = Moments::default();
    for &i in members {
        let r = &records[i as usize];
        let Some(shares) = lights.lane_shares(&r.receiver) else {
            continue;
        };
        let sky_share = lights.estimated_environment_share(&r.receiver) as f64;
        // The lanes an emitter's path took, and which side of the split the sample fell on
        // (`Some(true)`: the environment).
        let (lanes, side) = match r.took {
            Some(Picked::Emitter(e)) => {
                let lanes = lights.top_lanes(e);
                (lanes, lanes.map(|_| false))
            }
            Some(Picked::Environment) => (None, Some(true)),
            None => (None, None),
        };
        // Within the emitters' side, a sample's own estimate leaves out the split's share.
        moments.add(&shares, lanes, r.value as f64 * (1.0 - sky_share));
        moments.add_split(sky_share, side, r.value as f64);
    }
    Some(RegionFactors {
        lanes: moments.factors(lights.lane_costs()),
        sky: if lights.splits_by_estimate() {
            moments.sky_factor()
        } else {
            1.0
        },
    })
}

/// The records of [`TRAINING_SPP`] paths a pixel over the camera's frame at about
/// [`TRAINING_WIDTH`] pixels across, row after row (the same whatever the thread count), for
/// training pass `pass` (each its own samples), keeping what is `wanted`.
fn training_records(ctx: &Context, pass: u32, wanted: Wanted) -> Recording {
    let scene = ctx.scene;
    let [w, h] = scene.camera.projection.resolution;
    let width = TRAINING_WIDTH.min(w).max(1);
    let height = ((h as u64 * width as u64 / w.max(1) as u64) as u32).max(1);
    let seed = hash32(scene.settings.seed ^ 0x4c16_47e5 ^ pass.wrapping_mul(0x9e37_79b9));
    let rows: Vec<Recording> = (0..height)
        .into_par_iter()
        .map(|y| {
            let mut row = Recording::new(wanted);
            for x in 0..width {
                let pixel_seed = hash32(hash32(y * width + x) ^ seed);
                for i in 0..TRAINING_SPP {
                    let pixel = (
                        Vec2::new(x as f32, y as f32),
                        Vec2::new(width as f32, height as f32),
                    );
                    let s = &mut SampleStream::new(i, pixel_seed);
                    training_path(ctx, pixel, s, &mut row);
                }
            }
            row
        })
        .collect();
    // Row after row into one list, each row freed as it is moved (a flattening collect would
    // hold every record twice at its peak: 20 MB on the showcase).
    let mut records = Recording::new(wanted);
    records
        .lights
        .reserve(rows.iter().map(|r| r.lights.len()).sum());
    records
        .bounces
        .reserve(rows.iter().map(|r| r.bounces.len()).sum());
    for row in rows {
        records.lights.extend(row.lights);
        records.bounces.extend(row.bounces);
    }
    records
}

/// Traces one training path through `pixel` (its corner and the training frame's size), with
/// the shot camera at a time in the shutter.
fn training_path(
    ctx: &Context,
    (corner, size): (Vec2, Vec2),
    s: &mut SampleStream,
    records: &mut Recording,
) {
    let scene = ctx.scene;
    let [open, close] = scene.shutter;
    let [jx, jy, lx, ly] = s.next_4d();
    let time = open + (close - open) * s.time() as f64;
    let lens = Lens::at(&scene.camera, time);
    let (o, d) = lens.ray((corner + Vec2::new(jx, jy)) / size, Vec2::new(lx, ly));
    let range = if scene.clip.is_none() {
        Some((0.0, f32::INFINITY))
    } else {
        scene.clip.interval(&lens, o, d)
    };
    if let Some((t_min, t_max)) = range {
        let ray = Ray::new(o, d, t_max, time).between(t_min, t_max);
        let sample = trace(ctx, ray, s, records);
        records.path_done(sample.radiance);
    }
}

/// What one region's light samples showed.
#[derive(Clone, Copy, Debug, Default)]
struct Moments {
    /// Per root lane, the sum over the samples that took it of value² × its share: the second
    /// moment of the estimate that lane alone would make, times the sample count.
    root: [f64; WIDTH],
    /// The same for each root lane's child lanes.
    second: [[f64; WIDTH]; WIDTH],
    /// Sums of the tree's shares at every sample's point.
    root_share: [f64; WIDTH],
    second_share: [[f64; WIDTH]; WIDTH],
    /// The same for the split between the environment and the emitters: the second moments
    /// of each side's own estimate, and the sum of the environment's estimated share.
    sky: f64,
    emitters: f64,
    sky_share: f64,
    samples: f64,
}

impl Moments {
    /// Adds a sample whose point the tree gives `shares`, which took the lanes `lanes` (none
    /// for the environment or no light) and brought `value`.
    fn add(&mut self, shares: &PerLane, lanes: Option<(usize, Option<usize>)>, value: f64) {
        for j in 0..WIDTH {
            self.root_share[j] += shares.root[j] as f64;
            for k in 0..WIDTH {
                self.second_share[j][k] += shares.second[j][k] as f64;
            }
        }
        let Some((j, second)) = lanes else {
            return;
        };
        // The lane's own estimate is the sample's over its share; weighing the square by the
        // probability of taking the lane gives its second moment.
        let root_share = shares.root[j] as f64;
        self.root[j] += value * value * root_share;
        if let Some(k) = second {
            self.second[j][k] += value * value * root_share * shares.second[j][k] as f64;
        }
    }

    /// Adds a sample to the split: the environment's estimated share at its point, whether it
    /// took the environment (`Some(true)`) or an emitter (`Some(false)`), and what it brought.
    fn add_split(&mut self, sky_share: f64, took_sky: Option<bool>, value: f64) {
        self.samples += 1.0;
        self.sky_share += sky_share;
        match took_sky {
            Some(true) => self.sky += value * value * sky_share,
            Some(false) => self.emitters += value * value * (1.0 - sky_share),
            None => {}
        }
    }

    /// The factor of the environment's weight that takes its mean estimated share to the
    /// root of its second moment's share, blended like the lanes'.
    fn sky_factor(&self) -> f32 {
        let mean = self.sky_share / self.samples.max(1.0);
        let [sky, emitters] = [self.sky, self.emitters].map(|m| m.max(0.0).sqrt());
        if !(sky + emitters > 0.0 && (sky + emitters).is_finite() && mean > 0.0 && mean < 1.0) {
            return 1.0;
        }
        let learned = sky / (sky + emitters);
        let blended = (1.0 - TREE_SHARE) * learned + TREE_SHARE * mean;
        // The weight ratio that turns the mean share into the blended one.
        let factor = blended * (1.0 - mean) / ((1.0 - blended) * mean);
        factor.clamp(1.0 / MAX_FACTOR, MAX_FACTOR) as f32
    }

    /// The factors that take the tree's shares to the learned ones, for lanes whose samples
    /// cost `costs`.
    fn factors(&self, costs: &PerLane) -> PerLane {
        PerLane {
            root: lane_factors(&self.root, &self.root_share, &costs.root),
            second: std::array::from_fn(|j| {
                lane_factors(&self.second[j], &self.second_share[j], &costs.second[j])
            }),
        }
    }
}

/// Factors that turn lanes' mean shares (`share_sums`, summed over the samples) into shares in
/// proportion to the root of their second moments (`moment_sums`) over their samples' `costs`
/// (the most efficient one-sample choice), blended with the tree's own by [`TREE_SHARE`]; all
/// 1 when the lanes brought nothing.
fn lane_factors(
    moment_sums: &[f64; WIDTH],
    share_sums: &[f64; WIDTH],
    costs: &[f32; WIDTH],
) -> [f32; WIDTH] {
    let roots: [f64; WIDTH] =
        std::array::from_fn(|k| (moment_sums[k].max(0.0) / costs[k].max(1e-6) as f64).sqrt());
    let (root_total, share_total) = (roots.iter().sum::<f64>(), share_sums.iter().sum::<f64>());
    if !(root_total > 0.0 && share_total > 0.0 && root_total.is_finite()) {
        return [1.0; WIDTH];
    }
    std::array::from_fn(|k| {
        let tree = share_sums[k] / share_total;
        if tree <= 0.0 {
            return 1.0;
        }
        let learned = roots[k] / root_total;
        let factor = ((1.0 - TREE_SHARE) * learned + TREE_SHARE * tree) / tree;
        factor.min(MAX_FACTOR) as f32
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn factors_move_shares_towards_the_root_of_second_moments_over_costs() {
        let even = [0.25f64; WIDTH];
        let ones = [1.0f32; WIDTH];
        // What the tree gives is what was seen: nothing moves.
        let f = lane_factors(&[1.0, 1.0, 1.0, 1.0], &even, &ones);
        assert!(f.iter().all(|&f| (f - 1.0).abs() < 1e-6), "{f:?}");
        // A lane that never brought light keeps only the tree's share of it.
        let f = lane_factors(&[1.0, 1.0, 1.0, 0.0], &even, &ones);
        assert!((f[3] - TREE_SHARE as f32).abs() < 1e-6, "{f:?}");
        // Second moments 16:4:1:1 want shares 4:2:1:1; a lane costing four times as much
        // wants half the share.
        let f = lane_factors(&[16.0, 4.0, 1.0, 1.0], &even, &ones);
        let g = lane_factors(&[16.0, 4.0, 1.0, 1.0], &even, &[4.0, 1.0, 1.0, 1.0]);
        let shares = |f: [f32; WIDTH]| {
            let total: f32 = f.iter().sum();
            f.map(|f| f / total)
        };
        let blend = |learned: f32| (1.0 - TREE_SHARE as f32) * learned + TREE_SHARE as f32 * 0.25;
        let (s, t) = (shares(f), shares(g));
        assert!(
            (s[0] - blend(0.5)).abs() < 1e-5 && (s[1] - blend(0.25)).abs() < 1e-5,
            "{s:?}"
        );
        assert!((t[0] - blend(2.0 / 6.0)).abs() < 1e-5, "{t:?}");
        // Nothing seen at all: no change.
        assert_eq!(lane_factors(&[0.0; WIDTH], &even, &ones), [1.0; WIDTH]);
    }
}
