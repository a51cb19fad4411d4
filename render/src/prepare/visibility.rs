//! Measuring the light-visibility grid ([`crate::through::light_visibility`]): per cell, the
//! unblocked share of ordinary light samples traced from random points inside it, then, once
//! the openings' exits are known, what light sampling through the openings is worth there.

use crate::integrator::probe_light;
use crate::lights::Receiver;
use crate::sampling::SampleStream;
use crate::scene::Scene;
use crate::through::{Cells, LightVisibility, Strategies, View};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// Light samples traced from each cell.
const PROBES: u32 = 32;
/// The least share any cell reports.
const FLOOR: f32 = 0.01;

/// The unblocked share of ordinary light sampling over the cells of a grid over `bounds`
/// (lower and upper corner) in `scene`, at times in `times`; no grid for an infinite box.
/// Every point searches the openings until [`measure_worth`] says where that pays.
pub fn measure_unblocked(scene: &Scene, bounds: [Vec3; 2], times: [f64; 2]) -> LightVisibility {
    let Some(cells) = Cells::new(bounds) else {
        return LightVisibility::none();
    };
    let share = (0..cells.count() as u32)
        .into_par_iter()
        .map(|i| probe(scene, cells.corner(i), cells.size(), times, i))
        .collect();
    LightVisibility::new(cells, share)
}

/// Measures, per cell of the grid `view` searches with (its openings' exits measured, every
/// point searching), the mean [`Strategies::worth`] at its probe points over `times`.
pub fn measure_worth(view: &View, times: [f64; 2]) -> Vec<f32> {
    let Some(cells) = view.survey.visibility.cells() else {
        return Vec::new();
    };
    (0..cells.count() as u32)
        .into_par_iter()
        .map(|i| cell_worth(view, cells, i, times))
        .collect()
}

/// The mean [`Strategies::worth`] at [`PROBES`] points of cell `i` of `cells` (no surface:
/// every opening in front of a point counts).
fn cell_worth(view: &View, cells: &Cells, i: u32, times: [f64; 2]) -> f32 {
    let corner = cells.corner(i);
    let mut stream = SampleStream::new(i, 0x0be5_ea7c);
    let mut strategies = None;
    let mut sum = 0.0f32;
    for _ in 0..PROBES {
        let receiver = random_point(&mut stream, corner, cells.size(), times);
        Strategies::update(&mut strategies, view, &receiver);
        sum += strategies.as_ref().map_or(0.0, Strategies::worth);
    }
    sum / PROBES as f32
}

/// The unblocked share of [`PROBES`] light samples from random points of the cell at
/// `corner` with sides `size` (1 when none of them brings light).
fn probe(scene: &Scene, corner: Vec3, size: Vec3, times: [f64; 2], cell: u32) -> f32 {
    let mut stream = SampleStream::new(cell, 0x7153_11b5);
    let (mut all, mut unblocked) = (0.0f64, 0.0f64);
    for _ in 0..PROBES {
        let receiver = random_point(&mut stream, corner, size, times);
        let [u, v, _, _] = stream.uniform_4d();
        // Ordinary light sampling, as next-event estimation draws it, and its shadow ray.
        if let Some(probe) = probe_light(scene, &receiver, Vec2::new(u, v)) {
            all += probe.weight;
            unblocked += probe.weight * probe.transmitted;
        }
    }
    if all > 0.0 {
        ((unblocked / all) as f32).max(FLOOR)
    } else {
        1.0
    }
}

/// A probe point drawn from `stream`: uniform in the cell at `corner` with sides `size`, at a
/// uniform time in `times`, with no surface.
fn random_point(stream: &mut SampleStream, corner: Vec3, size: Vec3, times: [f64; 2]) -> Receiver {
    let [x, y, z, t] = stream.uniform_4d();
    Receiver {
        p: corner + size * Vec3::new(x, y, z),
        n: None,
        time: times[0] + (times[1] - times[0]) * t as f64,
    }
}
