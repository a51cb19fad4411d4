//! What each opening's exit passes on, measured once per scene: how strategy search weighs
//! light sampling through a chain of openings against ordinary light sampling.
//!
//! The light tree's estimate at the centre of an exit counts every emitter in front of it
//! as if it faced the exit and nothing stood between. An opening framed by a ring sits in the
//! ring's plane, so the tree credits it with the whole ring, whose light only grazes it; walls
//! and the ring's own strands are not seen at all: in the showcase it was 145 times what the
//! exit passes on, and the render was noisier with light sampling through openings on than
//! off. Here ordinary light samples are traced, with their
//! shadow rays, from points spread over each exit and facing the way rays leave it, and their
//! mean is the estimate. It only moves samples between strategies: a poor measurement costs
//! noise, never bias.

use crate::geometry::{Ray, offset_origin};
use crate::integrator::probe_light;
use crate::lights::Receiver;
use crate::sampling::SampleStream;
use crate::scene::Scene;
use crate::through::ExitLight;
use glam::{DVec2, DVec3, Vec2};
use rayon::prelude::*;
use std::f64::consts::PI;

/// Light samples traced from each exit; fewer in fuzz builds, as for
/// [`crate::prepare::visibility`]'s grid.
const PROBES: u32 = if cfg!(fuzzing) { 256 } else { 4096 };
/// The measured estimate never falls below this share of the tree's: a few probes that all
/// missed a small bright light leave its opening some samples.
const FLOOR: f32 = 1e-3;

/// Rays traced between an exit and an opening in front of it before walls are taken to stand
/// between them.
const WALL_RAYS: u32 = 16;

/// Measures the exit of every opening of `scene`.
pub fn measure(scene: &Scene) -> Vec<ExitLight> {
    (0..scene.portals.len())
        .into_par_iter()
        .map(|i| {
            let measured = probe(scene, i);
            ExitLight {
                light: measured.light.max(FLOOR * tree_estimate(scene, i)),
                ..measured
            }
        })
        .collect()
}

/// The pairs (from, to) of `pairs` ([`crate::through::facing_pairs`]) that no
/// ray from `from`'s exit to `to`'s bounding disk passes, at the middle of the ray times: the
/// walls of the rooms between. Light sampling then does not search chains through `from` for
/// `to` beyond it; a pair a few rays missed costs noise, never bias (BSDF sampling still finds
/// its light).
pub fn walled_off(scene: &Scene, pairs: &[(u32, u32)]) -> Vec<(u32, u32)> {
    pairs
        .par_iter()
        .copied()
        .filter(|&(from, to)| !some_ray_passes(scene, from as usize, to as usize))
        .collect()
}

/// True when one of [`WALL_RAYS`] rays from points just off opening `from`'s exit to points of
/// opening `to`'s bounding disk meets no surface on the way.
fn some_ray_passes(scene: &Scene, from: usize, to: usize) -> bool {
    let portals = &scene.portals;
    let times = portals.times();
    let time = 0.5 * (times[0] + times[1]);
    let exit_time = portals.exit_time(from, time);
    let there = portals.there(from, exit_time);
    let here = portals.here(to, exit_time);
    let leaving = there.transform_direction(-DVec3::Z).normalize().as_vec3();
    let radii = [from, to].map(|i| portals.mask(i).bounding_radius());
    let mut stream = SampleStream::new(
        (from * rift_fx::shot::MAX_OPENINGS + to) as u32,
        0x3a11_0ff5,
    );
    (0..WALL_RAYS).any(|_| {
        let [a, b, c, d] = stream.uniform_4d();
        let start = there.transform_point((uniform_disk(a, b) * radii[0]).extend(0.0));
        let origin = offset_origin(start.as_vec3(), leaving);
        let end = here.transform_point((uniform_disk(c, d) * radii[1]).extend(0.0));
        let way = end.as_vec3() - origin;
        let length = way.length();
        length > 0.0
            && !scene.occluded(
                &Ray::new(origin, way / length, length * (1.0 - 1e-4), exit_time),
                None,
            )
    })
}

/// The light tree's unoccluded estimate for opening `i`'s exit: at its centre, facing the way
/// rays leave, at the middle of the ray times.
fn tree_estimate(scene: &Scene, i: usize) -> f32 {
    let times = scene.portals.times();
    let middle = 0.5 * (times[0] + times[1]);
    let there = scene.portals.there(i, middle);
    scene.lights.importance(&Receiver {
        p: there.translation.as_vec3(),
        n: Some(there.transform_direction(-DVec3::Z).as_vec3()),
        time: middle,
    })
}

/// Ordinary light samples from [`PROBES`] points over opening `i`'s bounding disk at random ray
/// times; those in its teleport region are taken to the exit as a teleport would take them.
fn probe(scene: &Scene, i: usize) -> ExitLight {
    let portals = &scene.portals;
    let [start, end] = portals.times();
    let mask = portals.mask(i);
    let radius = mask.bounding_radius();
    let mut stream = SampleStream::new(i as u32, 0x0e71_7119);
    let (mut all, mut sky, mut inside) = (0.0f64, 0.0f64, 0u32);
    for _ in 0..PROBES {
        let [x, y, t, _] = stream.uniform_4d();
        let [u, v, _, _] = stream.uniform_4d();
        let time = start + (end - start) * t as f64;
        let local = uniform_disk(x, y) * radius;
        if !mask.contains(local, time) {
            continue;
        }
        inside += 1;
        let exit_time = portals.exit_time(i, time);
        let there = portals.there(i, exit_time);
        let leaving = there.transform_direction(-DVec3::Z).normalize();
        // Just off the exit, on the side rays leave into (an opening may lie on a wall).
        let on_exit = there.transform_point(local.extend(0.0)).as_vec3();
        let receiver = Receiver {
            p: offset_origin(on_exit, leaving.as_vec3()),
            n: Some(leaving.as_vec3()),
            time: exit_time,
        };
        let Some(probe) = probe_light(scene, &receiver, Vec2::new(u, v)) else {
            continue;
        };
        let weight = probe.weight * probe.transmitted * probe.dir.dot(leaving.as_vec3()) as f64;
        if weight > 0.0 {
            all += weight;
            if probe.sky {
                sky += weight;
            }
        }
    }
    ExitLight {
        light: (PI * all / inside.max(1) as f64) as f32,
        sky_share: if all > 0.0 { (sky / all) as f32 } else { 0.0 },
    }
}

/// A point of the unit disk, uniform in area, from two numbers in [0, 1).
fn uniform_disk(x: f32, y: f32) -> DVec2 {
    let r = (x as f64).sqrt();
    let phi = 2.0 * PI * y as f64;
    DVec2::new(r * phi.cos(), r * phi.sin())
}
