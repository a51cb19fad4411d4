//! `rift bench strands`: round-curve ray throughput on many moving strand segments.

use super::{Timing, median};
use clap::Args;
use rayon::prelude::*;
use rift_render::Ray;
use std::time::Instant;

/// Arguments of `rift bench strands`.
#[derive(Args)]
pub struct StrandsArgs {
    /// Strands in the generated ring.
    #[arg(long, default_value_t = 100)]
    strands: usize,
    /// Segments per strand.
    #[arg(long, default_value_t = 1000)]
    segments: usize,
    /// Rays per measurement.
    #[arg(long, default_value_t = 2_000_000)]
    rays: usize,
    #[command(flatten)]
    timing: Timing,
}

/// A ring of `strands` closed strands of `segments` segments around +Z, radius near 1 with a
/// wave on it, spinning both ways at up to 2 turns per second: velocity ω×p and acceleration
/// ω×(ω×p) per vertex, as fx bakes them.
fn spinning_ring(strands: usize, segments: usize) -> rift_fx::ring::RingCurves {
    use glam::Vec3;
    let mut c = rift_fx::ring::RingCurves {
        opening: "bench".into(),
        ..Default::default()
    };
    for s in 0..strands {
        let spin =
            if s % 2 == 0 { 1.0 } else { -1.0 } * (6.0 + 6.0 * (s as f32 * 0.37).sin().abs());
        let w = Vec3::Z * spin;
        c.vertex_counts.push(segments as u32);
        c.directions.push(if s % 2 == 0 { 1 } else { -1 });
        for k in 0..segments {
            let u = std::f32::consts::TAU * k as f32 / segments as f32;
            let r = 1.0 + 0.07 * (s as f32 / strands as f32) + 0.02 * (7.0 * u + s as f32).sin();
            let p = Vec3::new(
                r * u.cos(),
                r * u.sin(),
                0.03 * (5.0 * u + 2.0 * s as f32).sin(),
            );
            c.points.push(p);
            c.velocities.push(w.cross(p));
            c.accelerations.push(w.cross(w.cross(p)));
            c.widths.push(0.004);
            c.colors.push(Vec3::ONE);
            c.intensities.push(1.0);
        }
    }
    c
}

/// Ray `i` from all around towards a random point of the ring's band, at a random time in
/// `shutter`.
fn band_ray(i: usize, shutter: [f64; 2]) -> (glam::Vec3, glam::Vec3, f64) {
    let h = |k: u32| super::hashed(i, 8, k);
    let angle = std::f32::consts::TAU * h(0);
    let target = glam::Vec3::new(angle.cos(), angle.sin(), 0.0) * (0.98 + 0.12 * h(1));
    let from = glam::Vec3::new(h(2) - 0.5, h(3) - 0.5, h(4) - 0.5).normalize_or_zero() * 3.0
        + glam::Vec3::Z * 0.5;
    let time = shutter[0] + (shutter[1] - shutter[0]) * h(5) as f64;
    (from, (target - from).normalize(), time)
}

pub fn run(args: StrandsArgs) -> anyhow::Result<()> {
    use rift_fx::rig::Similarity;
    use rift_render::geometry::{RingFrame, Strands};
    anyhow::ensure!(
        args.strands > 0 && args.segments > 2 && args.rays > 0 && args.timing.repeats > 0,
        "expected positive counts (and at least 3 segments per strand)"
    );
    let ring = spinning_ring(args.strands, args.segments);
    let fixed = || RingFrame::fixed(Similarity::IDENTITY);
    // Shutter of half a frame at 24 fps around the frame.
    let shutter = [-1.0 / 96.0, 1.0 / 96.0];
    let threads = crate::cli::with_threads(args.timing.threads, rayon::current_num_threads)?;
    let ray = |i: usize| band_ray(i, shutter);
    println!(
        "rift bench strands: {} segments ({} strands), {} rays aimed at the band, {threads} threads, median of {}",
        args.strands * args.segments,
        args.strands,
        args.rays,
        args.timing.repeats
    );
    println!(
        "{:<28} {:>9} {:>8} {:>11} {:>11}",
        "strands", "build s", "hit %", "closest", "occlusion"
    );
    for (name, times) in [
        ("moving (half-frame shutter)", shutter),
        ("still (shutter closed)", [0.0, 0.0]),
    ] {
        let t = Instant::now();
        let mut set = Strands::default();
        set.add_ring(&ring, fixed(), 0.0, times, 1.0);
        let build = t.elapsed().as_secs_f64();
        let at = |time: f64| time.clamp(times[0], times[1]);
        let mut closest = Vec::new();
        let mut occlusion = Vec::new();
        let mut hits = 0;
        for _ in 0..args.timing.repeats {
            let t = Instant::now();
            hits = crate::cli::with_threads(args.timing.threads, || {
                (0..args.rays)
                    .into_par_iter()
                    .filter(|&i| {
                        let (o, d, time) = ray(i);
                        set.intersect(&Ray::new(o, d, f32::INFINITY, at(time)), |_| true)
                            .is_some()
                    })
                    .count()
            })?;
            closest.push(t.elapsed().as_secs_f64());
            let t = Instant::now();
            let blocked = crate::cli::with_threads(args.timing.threads, || {
                (0..args.rays)
                    .into_par_iter()
                    .filter(|&i| {
                        let (o, d, time) = ray(i);
                        set.occluded(&Ray::new(o, d, f32::INFINITY, at(time)), None, |_| true)
                    })
                    .count()
            })?;
            occlusion.push(t.elapsed().as_secs_f64());
            anyhow::ensure!(
                blocked == hits,
                "occlusion and closest-hit queries disagree"
            );
        }
        let rate = |v: Vec<f64>| args.rays as f64 / median(v) / 1e6;
        println!(
            "{name:<28} {build:>9.3} {:>8.1} {:>6.3} Mr/s {:>6.3} Mr/s",
            100.0 * hits as f64 / args.rays as f64,
            rate(closest),
            rate(occlusion)
        );
        light_tree_cost(&set, times, &args)?;
    }
    Ok(())
}

/// Times the light tree over the strands of `set`: picking a segment for points on a wall just
/// behind the ring, and the probability of a given segment for such a point (what multiple
/// importance sampling asks when a ray finds a strand), each as nanoseconds per query.
fn light_tree_cost(
    set: &rift_render::geometry::Strands,
    times: [f64; 2],
    args: &StrandsArgs,
) -> anyhow::Result<()> {
    use rift_render::lights::emitters::{LightSelection, Lights, Receiver};
    let t = Instant::now();
    let lights = Lights::new(
        Vec::new(),
        0,
        set,
        Vec::new(),
        times,
        &[],
        None,
        LightSelection::Tree,
    );
    let build = t.elapsed().as_secs_f64();
    let receiver = |i: usize| {
        let h = |k: u32| super::hashed(i, 4, k);
        let p = glam::Vec3::new(3.0 * h(0) - 1.5, 3.0 * h(1) - 1.5, -0.1);
        let time = times[0] + (times[1] - times[0]) * h(2) as f64;
        (
            Receiver {
                p,
                n: Some(glam::Vec3::Z),
                time,
            },
            h(3),
        )
    };
    let segments = set.segments.len().max(1);
    let (mut pick, mut pmf) = (Vec::new(), Vec::new());
    for _ in 0..args.timing.repeats {
        let t = Instant::now();
        let picked = crate::cli::with_threads(args.timing.threads, || {
            (0..args.rays)
                .into_par_iter()
                .filter(|&i| {
                    let (at, u) = receiver(i);
                    lights.sampler(None).pick(u, &at, set).is_some()
                })
                .count()
        })?;
        pick.push(t.elapsed().as_secs_f64());
        anyhow::ensure!(picked > 0, "the light tree picked nothing");
        let t = Instant::now();
        let total = crate::cli::with_threads(args.timing.threads, || {
            (0..args.rays)
                .into_par_iter()
                .map(|i| {
                    let (at, _) = receiver(i);
                    lights.sampler(None).pick_pmf(i * 7919 % segments, &at) as f64
                })
                .sum::<f64>()
        })?;
        pmf.push(t.elapsed().as_secs_f64());
        anyhow::ensure!(
            total > 0.0,
            "the light tree gave every segment probability 0"
        );
    }
    let nanoseconds = |v: Vec<f64>| median(v) * 1e9 / args.rays as f64;
    println!(
        "{:<28} {build:>9.3} {:>17.1} ns/pick {:>5.1} ns/pmf",
        "  light tree over them",
        nanoseconds(pick),
        nanoseconds(pmf)
    );
    Ok(())
}
