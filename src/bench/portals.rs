//! `rift bench portals`: the cost of one teleport and of each extra portal level.

use super::{Timing, median};
use anyhow::Context;
use clap::Args;
use rift_fx::Shot;
use rift_render::portals::visibility::RayClass;
use rift_render::prepare::Prepared;
use rift_render::{Ray, Scene};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `rift bench portals`.
#[derive(Args)]
pub struct PortalsArgs {
    /// A shot with openings, seen in each other by its camera.
    #[arg(default_value = "examples/shots/hall_of_mirrors.toml")]
    shot: PathBuf,
    /// Portal depth limits to render at, comma-separated.
    #[arg(long, default_value = "0,1,2,4,8,16")]
    depths: String,
    /// Samples per pixel of each render.
    #[arg(long, default_value_t = 8)]
    spp: u32,
    #[command(flatten)]
    timing: Timing,
}

/// Runs `rift bench portals`: the cost of a teleport against a ray, then render time against
/// the depth limit.
pub fn run(args: PortalsArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.timing.repeats > 0 && args.spp > 0,
        "expected positive counts"
    );
    let depths: Vec<u32> = args
        .depths
        .split(',')
        .map(|d| d.trim().parse::<u32>())
        .collect::<Result<_, _>>()
        .context("--depths: expected comma-separated integers")?;
    let shot = Shot::load(&args.shot)?;
    let scene = Scene::load(&shot, shot.frames.first)?;
    anyhow::ensure!(
        !scene.portals.is_empty(),
        "{}: the shot has no opening",
        args.shot.display()
    );
    teleport_cost(&args, &scene)?;
    render_time_by_depth(&args, &shot, depths)
}

/// Times one teleport (finding the opening along a camera ray, then moving the ray through it)
/// and one closest-hit ray, over camera rays that meet an opening, on one thread.
fn teleport_cost(args: &PortalsArgs, scene: &Scene) -> anyhow::Result<()> {
    let threads = crate::cli::with_threads(args.timing.threads, rayon::current_num_threads)?;
    let [w, h] = scene.camera.projection.resolution.map(|v| v as usize);
    let time = scene.shutter[0];
    let lens = rift_render::camera::Lens::at(&scene.camera, time);
    let rays: Vec<_> = (0..w * h)
        .map(|i| {
            let ndc = glam::Vec2::new(
                ((i % w) as f32 + 0.5) / w as f32,
                ((i / w) as f32 + 0.5) / h as f32,
            );
            lens.ray(ndc, glam::Vec2::splat(0.5))
        })
        .filter(|&(o, d)| {
            scene
                .portals
                .intersect(&Ray::new(o, d, f32::INFINITY, time))
                .is_some()
        })
        .collect();
    anyhow::ensure!(!rays.is_empty(), "the camera sees no opening");
    let rounds = (4_000_000 / rays.len()).max(1);
    let timed = |f: &dyn Fn(glam::Vec3, glam::Vec3) -> f32| {
        median(
            (0..args.timing.repeats)
                .map(|_| {
                    let t = Instant::now();
                    let mut sink = 0.0f32;
                    for _ in 0..rounds {
                        for &(o, d) in &rays {
                            sink += f(o, d);
                        }
                    }
                    std::hint::black_box(sink);
                    t.elapsed().as_secs_f64() / (rounds * rays.len()) as f64
                })
                .collect(),
        )
    };
    let portals = &scene.portals;
    let teleport_ns = 1e9
        * timed(&|o, d| {
            let hit = portals.intersect(&Ray::new(o, d, f32::INFINITY, time));
            hit.and_then(|hit| portals.teleport(&hit, d, time))
                .map_or(0.0, |t| t.origin.x)
        });
    let ray_ns = 1e9
        * timed(&|o, d| {
            scene
                .intersect(&Ray::new(o, d, f32::INFINITY, time), RayClass::Camera)
                .map_or(0.0, |hit| hit.t())
        });
    println!(
        "rift bench portals: {} ({} openings, {} triangles), {threads} threads, median of {}",
        args.shot.display(),
        portals.len(),
        scene.triangles.len(),
        args.timing.repeats
    );
    println!(
        "one teleport (find the opening + move the ray, one thread): {teleport_ns:.1} ns; one closest-hit ray in this scene: {ray_ns:.1} ns"
    );
    Ok(())
}

/// Prints the render time at each depth limit of `depths`, with the mean portal level the
/// camera's paths reached, and the time each further level costs.
fn render_time_by_depth(args: &PortalsArgs, shot: &Shot, depths: Vec<u32>) -> anyhow::Result<()> {
    use rift_render::frame::{RenderOptions, render};
    println!(
        "{:>6} {:>10} {:>12} {:>16}",
        "depth", "seconds", "mean level", "s per level"
    );
    let mut first: Option<(f64, f64)> = None;
    for depth in depths {
        // Built anew: the depth limit bounds the times rays can reach.
        let overrides = rift_render::scene::Overrides {
            max_portal_depth: Some(depth),
            ..Default::default()
        };
        let prepared = Prepared::build(shot, shot.frames.first, &overrides)?;
        let mut times = Vec::new();
        let mut image = None;
        for _ in 0..args.timing.repeats {
            let t = Instant::now();
            image = Some(crate::cli::with_threads(args.timing.threads, || {
                render(&prepared, &RenderOptions::new(args.spp))
            })?);
            times.push(t.elapsed().as_secs_f64());
        }
        let secs = median(times);
        let image = image.expect("at least one repeat");
        let level = image.portal_depth.iter().map(|&d| d as f64).sum::<f64>()
            / image.portal_depth.len() as f64;
        let per_level = match first {
            Some((s0, l0)) if level > l0 => format!("{:.4}", (secs - s0) / (level - l0)),
            _ => "-".to_owned(),
        };
        first.get_or_insert((secs, level));
        println!("{depth:>6} {secs:>10.3} {level:>12.3} {per_level:>16}");
    }
    Ok(())
}
