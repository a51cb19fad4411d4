//! `rift bench deforming`: what a deforming mesh costs. A wavy sheet of `--triangles` triangles
//! animated over `--frames` frames is written as a binary PLY sequence with velocities; each
//! frame's scene is then loaded (its files read and the tree refit per segment), timed, with
//! the process's peak memory over one load; and rays at random times through the shutter are
//! traced against the deforming sheet and against the same sheet standing still (one frame's
//! file as an ordinary mesh), the two alternated in one run.

use super::median;
use super::scaling::{reset_peak_memory, status_mib};
use clap::Args;
use rayon::prelude::*;
use rift_fx::Shot;
use rift_render::Scene;
use rift_render::geometry::{Ray, every_triangle};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `rift bench deforming`.
#[derive(Args)]
pub struct DeformingArgs {
    /// Triangles in the deforming sheet.
    #[arg(long, default_value_t = 1_000_000)]
    triangles: usize,
    /// Frames in its sequence.
    #[arg(long, default_value_t = 24)]
    frames: i64,
    /// Rays per measurement.
    #[arg(long, default_value_t = 2_000_000)]
    rays: usize,
    #[command(flatten)]
    timing: super::Timing,
    /// Keep the sequence and the shots in this folder (else a temporary one).
    #[arg(long)]
    keep: Option<PathBuf>,
    /// Write no velocities: vertices then move in straight lines between frames.
    #[arg(long)]
    no_velocities: bool,
}

pub fn run(args: DeformingArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.triangles >= 2 && args.frames >= 2 && args.rays > 0 && args.timing.repeats > 0,
        "expected at least 2 triangles and 2 frames, and positive counts"
    );
    let temporary = tempfile::tempdir()?;
    let dir = args.keep.as_deref().unwrap_or(temporary.path());
    std::fs::create_dir_all(dir)?;
    let cells = ((args.triangles / 2) as f64).sqrt().ceil() as usize;
    let t = Instant::now();
    let mut bytes = 0u64;
    for frame in 1..=args.frames {
        let path = dir.join(format!("sheet.{frame:04}.ply"));
        bytes += write_frame(&path, cells, frame, !args.no_velocities)?;
    }
    println!(
        "rift bench deforming: a sheet of {} triangles over {} frames ({:.0} MB of binary PLY \
         {} velocities, written in {:.1} s)",
        2 * cells * cells,
        args.frames,
        if args.no_velocities {
            "without"
        } else {
            "with"
        },
        bytes as f64 / 1e6,
        t.elapsed().as_secs_f64()
    );
    let deforming = shot(dir, "deforming", "sheet.####.ply", args.frames)?;
    let middle = (1 + args.frames) / 2;
    let still = shot(dir, "still", &format!("sheet.{middle:04}.ply"), args.frames)?;
    load_table(&deforming, args.frames)?;
    let scenes = [("deforming", &deforming), ("standing still", &still)]
        .map(|(name, shot)| Ok::<_, anyhow::Error>((name, Scene::load(shot, middle)?)));
    let [a, b] = scenes;
    let (a, b) = (a?, b?);
    ray_table(&[a, b], &args)
}

/// Each frame's load (its files read, the tree built and refit, the scene assembled), and the
/// peak memory over the middle frame's.
fn load_table(shot: &Shot, frames: i64) -> anyhow::Result<()> {
    let mut seconds = Vec::new();
    for frame in 1..=frames {
        let t = Instant::now();
        drop(Scene::load(shot, frame)?);
        seconds.push(t.elapsed().as_secs_f64());
    }
    let (fastest, slowest) = seconds
        .iter()
        .fold((f64::MAX, 0.0f64), |(a, b), &s| (a.min(s), b.max(s)));
    println!(
        "  load per frame (3 samples read, tree built over them and refit per segment): \
         median {:.2} s (fastest {fastest:.2}, slowest {slowest:.2})",
        median(seconds)
    );
    let peak_known = reset_peak_memory();
    let before = status_mib("VmRSS:").unwrap_or(0.0);
    let scene = Scene::load(shot, (1 + frames) / 2)?;
    let held = scene.accel.deformation_bytes() as f64 / 1e6;
    match (peak_known, status_mib("VmHWM:")) {
        (true, Some(peak)) => println!(
            "  peak memory over one frame's load: {:.0} MB above the {before:.0} MB before it; \
             the deformation holds {held:.0} MB",
            (peak - before) * 1.048_576
        ),
        _ => println!("  peak memory: not measurable here; the deformation holds {held:.0} MB"),
    }
    Ok(())
}

/// Closest-hit and occlusion rays per second on each scene, the scenes alternated within each
/// repeat, with the ratio to the first.
fn ray_table(scenes: &[(&str, Scene)], args: &DeformingArgs) -> anyhow::Result<()> {
    let rays: Vec<Ray> = (0..args.rays)
        .map(|i| {
            // `rift bench rays`' rays over the same square, each at its own time.
            let (origin, dir) = super::rays::ray(i);
            let shutter = scenes[0].1.shutter;
            let time = shutter[0] + (shutter[1] - shutter[0]) * super::hashed(i, 1, 0) as f64;
            Ray::new(origin, dir, f32::INFINITY, time)
        })
        .collect();
    let mut closest = vec![Vec::new(); scenes.len()];
    let mut occlusion = vec![Vec::new(); scenes.len()];
    for _ in 0..args.timing.repeats {
        for (k, (_, scene)) in scenes.iter().enumerate() {
            let t = Instant::now();
            let hits = crate::cli::with_threads(args.timing.threads, || {
                rays.par_iter()
                    .filter(|r| scene.accel.intersect(r, &every_triangle).is_some())
                    .count()
            })?;
            closest[k].push(t.elapsed().as_secs_f64());
            let t = Instant::now();
            let blocked = crate::cli::with_threads(args.timing.threads, || {
                rays.par_iter()
                    .filter(|r| {
                        let bounded = Ray::new(r.origin, r.dir, 3.0, r.time);
                        scene.accel.occluded(&bounded, &every_triangle)
                    })
                    .count()
            })?;
            occlusion[k].push(t.elapsed().as_secs_f64());
            anyhow::ensure!(
                blocked == hits,
                "occlusion and closest-hit queries disagree"
            );
        }
    }
    println!(
        "  {} incoherent rays at random times in the shutter, median of {}:",
        args.rays, args.timing.repeats
    );
    println!(
        "  {:<16} {:>14} {:>10} {:>14} {:>10}",
        "sheet", "closest Mrays/s", "ratio", "occlusion Mrays/s", "ratio"
    );
    let rate = |times: &[f64]| args.rays as f64 / median(times.to_vec()) / 1e6;
    for (k, (name, _)) in scenes.iter().enumerate() {
        let (c, o) = (rate(&closest[k]), rate(&occlusion[k]));
        println!(
            "  {name:<16} {c:>14.2} {:>10.2} {o:>14.2} {:>10.2}",
            c / rate(&closest[0]),
            o / rate(&occlusion[0])
        );
    }
    Ok(())
}

/// A shot of the sheet `mesh` (a sequence or one file) under a white sky, shutter ±¼ frame.
fn shot(dir: &Path, name: &str, mesh: &str, frames: i64) -> anyhow::Result<Shot> {
    let path = dir.join(format!("{name}.toml"));
    let text = format!(
        "[shot]\nname = \"{name}\"\nfps = 24.0\nframes = [1, {frames}]\nshutter = [-0.25, 0.25]\n\
         [camera]\nresolution = [64, 64]\nfov_degrees = 40.0\n\
         transform = {{ position = [0.0, 3.0, 2.0], look_at = [0.0, 0.0, 0.0] }}\n\
         [environment]\nradiance = [1.0, 1.0, 1.0]\n\
         [[material]]\nname = \"grey\"\ntype = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]\n\
         [[object]]\nname = \"sheet\"\nmesh = \"{mesh}\"\nmaterial = \"grey\"\n"
    );
    std::fs::write(&path, text)?;
    Ok(Shot::load(&path)?)
}

/// The sheet's height at (x, z) and frame `f`: waves travelling across it, a few centimetres
/// a frame.
fn height(x: f32, z: f32, f: f32) -> f32 {
    0.1 * (7.0 * x + 0.4 * f).sin() * (5.0 * z - 0.3 * f).cos()
        + 0.03 * (31.0 * x + 17.0 * z + 0.9 * f).sin()
}

/// Writes frame `frame` of the sheet (`cells`² quads over [−1, 1]², two triangles each) as a
/// binary PLY, with per-vertex velocities (units per second at 24 frames a second) when
/// `velocities`; returns the bytes written.
fn write_frame(path: &Path, cells: usize, frame: i64, velocities: bool) -> anyhow::Result<u64> {
    let side = cells + 1;
    let f = frame as f32;
    let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
    let velocity_properties = match velocities {
        true => "property float vx\nproperty float vy\nproperty float vz\n",
        false => "",
    };
    write!(
        out,
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\n\
         property float x\nproperty float y\nproperty float z\n{velocity_properties}\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        side * side,
        2 * cells * cells
    )?;
    let step = 2.0 / cells as f32;
    for i in 0..side {
        for j in 0..side {
            let (x, z) = (i as f32 * step - 1.0, j as f32 * step - 1.0);
            let y = height(x, z, f);
            let dy = (height(x, z, f + 0.01) - height(x, z, f - 0.01)) / 0.02 * 24.0;
            let values = [x, y, z, 0.0, dy, 0.0];
            for v in &values[..if velocities { 6 } else { 3 }] {
                out.write_all(&v.to_le_bytes())?;
            }
        }
    }
    let at = |i: usize, j: usize| (i * side + j) as i32;
    for i in 0..cells {
        for j in 0..cells {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            for tri in [[a, b, c], [a, c, d]] {
                out.write_all(&[3])?;
                for v in tri {
                    out.write_all(&v.to_le_bytes())?;
                }
            }
        }
    }
    out.flush()?;
    Ok(std::fs::metadata(path)?.len())
}
