//! `rift bench scaling`: how the cost of rendering grows with the size of a scene, along five
//! axes, each from generated scenes: triangles (a height field, 10³ to 10⁷), strand segments
//! (small spinning loops side by side, 10² to 10⁶), openings (a wall of them, 1 to 64), windows
//! (a room lit only through 1 to 64 of them, so light sampling searches them at every point)
//! and emitters (small lamps over a floor, 1 to 10⁵). All but strands are whole renders (time
//! per path, the scene's build timed apart, peak memory of the build and render); strands are
//! closest-hit queries on their BVH, the part of a render they change. Printed as a table (and CSV) and
//! drawn as a log-log plot of the cost relative to each axis's smallest scene.

use super::{Timing, median};
use clap::Args;
use rayon::prelude::*;
use rift_render::Ray;
use rift_render::frame::passes::{RenderOptions, render};
use rift_render::prepare::Prepared;
use rift_render::rift_fx::Shot;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `rift bench scaling`.
#[derive(Args)]
pub struct ScalingArgs {
    /// The largest triangle count (the triangle axis runs in powers of ten up to it).
    #[arg(long, default_value_t = 10_000_000)]
    max_triangles: usize,
    /// Image width and height of the renders.
    #[arg(long, default_value_t = 96)]
    res: u32,
    /// Samples per pixel of the renders.
    #[arg(long, default_value_t = 4)]
    spp: u32,
    /// Where to write the table as CSV.
    #[arg(long, default_value = "out/scaling.csv")]
    csv: PathBuf,
    /// Where to write the log-log plot.
    #[arg(long, default_value = "out/scaling.png")]
    plot: PathBuf,
    #[command(flatten)]
    timing: Timing,
}

/// One measured scene.
struct Point {
    axis: &'static str,
    size: usize,
    build: f64,
    /// Microseconds per camera path (renders) or per ray (strand queries).
    cost: f64,
    /// Peak resident memory over the build and the render, MiB (renders only, where the
    /// kernel lets the mark be reset).
    peak_mib: Option<f64>,
}

pub fn run(args: ScalingArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.res > 0 && args.spp > 0 && args.timing.repeats > 0 && args.max_triangles >= 1000,
        "expected positive sizes and at least 1000 triangles"
    );
    let dir = tempfile::tempdir()?;
    let mut points = Vec::new();
    println!(
        "rift bench scaling: renders of {0}x{0} at {1} spp (cost per camera path; each timed \
         sample renders for at least {3} s), strand queries (cost per ray); median of {2}",
        args.res, args.spp, args.timing.repeats, LEAST_SAMPLE_SECONDS
    );
    println!(
        "(peak MiB: the process's high-water mark over each build and render; memory the \
         allocator kept from a larger scene before counts)"
    );
    println!(
        "{:<10} {:>10} {:>9} {:>12} {:>10}",
        "axis", "size", "build s", "µs", "peak MiB"
    );
    let mut report = |p: Point| {
        println!(
            "{:<10} {:>10} {:>9.2} {:>12.3} {:>10}",
            p.axis,
            p.size,
            p.build,
            p.cost,
            p.peak_mib.map_or("-".into(), |m| format!("{m:.0}"))
        );
        points.push(p);
    };
    let mut n = 1000;
    while n <= args.max_triangles {
        let shot = triangles_shot(dir.path(), n, args.res)?;
        report(measure_render("triangles", n, &shot, &args)?);
        n *= 10;
    }
    for n in [100, 1_000, 10_000, 100_000, 1_000_000] {
        report(measure_strands(n, &args.timing)?);
    }
    for n in [1, 2, 4, 8, 16, 32, 64] {
        let shot = openings_shot(dir.path(), n, args.res)?;
        report(measure_render("openings", n, &shot, &args)?);
    }
    for n in [1, 2, 4, 8, 16, 32, 64] {
        let shot = windows_shot(dir.path(), n, args.res)?;
        report(measure_render("windows", n, &shot, &args)?);
    }
    for n in [1, 10, 100, 1_000, 10_000, 100_000] {
        let shot = emitters_shot(dir.path(), n, args.res)?;
        report(measure_render("emitters", n, &shot, &args)?);
    }
    write_csv(&args.csv, &points)?;
    let axes = ["triangles", "strands", "openings", "windows", "emitters"];
    let series: Vec<(&str, Vec<(f64, f64)>)> = axes
        .into_iter()
        .map(|axis| {
            let pts: Vec<&Point> = points.iter().filter(|p| p.axis == axis).collect();
            let first = pts[0].cost;
            (
                axis,
                pts.iter()
                    .map(|p| (p.size as f64, p.cost / first))
                    .collect(),
            )
        })
        .collect();
    crate::plot::scaling_png(&args.plot, &series)?;
    println!("wrote {} and {}", args.csv.display(), args.plot.display());
    Ok(())
}

/// A timed sample of a render point renders again until this many seconds have passed: a
/// small scene at 96×96 and 4 spp renders in a few milliseconds, where one render at a time
/// measured the scheduler more than the scene (a point of the openings axis came out twice
/// its neighbours, and not in the next run).
const LEAST_SAMPLE_SECONDS: f64 = 0.25;

/// Builds `shot` and times `repeats` samples of its renders: build seconds, median µs per
/// camera path, and the peak memory of the whole.
fn measure_render(
    axis: &'static str,
    size: usize,
    shot: &Path,
    args: &ScalingArgs,
) -> anyhow::Result<Point> {
    let peak_known = reset_peak_memory();
    let t = Instant::now();
    let shot = Shot::load(shot)?;
    let prepared = Prepared::build(&shot, shot.frames.first, &Default::default())?;
    let build = t.elapsed().as_secs_f64();
    let paths = (args.res * args.res * args.spp) as f64;
    let mut times = Vec::new();
    for _ in 0..args.timing.repeats {
        let t = Instant::now();
        let mut renders = 0;
        while renders == 0 || t.elapsed().as_secs_f64() < LEAST_SAMPLE_SECONDS {
            crate::cli::with_threads(args.timing.threads, || {
                render(&prepared, &RenderOptions::new(args.spp))
            })?;
            renders += 1;
        }
        times.push(t.elapsed().as_secs_f64() / renders as f64);
    }
    Ok(Point {
        axis,
        size,
        build,
        cost: median(times) / paths * 1e6,
        peak_mib: if peak_known {
            status_mib("VmHWM:")
        } else {
            None
        },
    })
}

/// Segments per strand on the strand axis: each strand is a small spinning loop, and more
/// segments mean more loops side by side, so a ray meets as many strands at every size.
const LOOP_SEGMENTS: usize = 100;

/// `segments / LOOP_SEGMENTS` small loops in a square grid over [−1, 1]² (z = 0), each
/// spinning about its own centre at 12 rad/s (velocity ω×r and acceleration ω×(ω×r) per
/// vertex, as fx bakes them), with widths in proportion to their size; and the ray of index
/// `i` from above towards a random point of a random loop at a random shutter time.
fn loop_grid(
    segments: usize,
) -> (
    rift_fx::ring::RingCurves,
    impl Fn(usize) -> (glam::Vec3, glam::Vec3, f64),
) {
    use glam::Vec3;
    let loops = (segments / LOOP_SEGMENTS).max(1);
    let per_row = (loops as f64).sqrt().ceil() as usize;
    let spacing = 2.0 / per_row as f32;
    let radius = 0.3 * spacing;
    let centre = move |k: usize| {
        Vec3::new(
            ((k % per_row) as f32 + 0.5) * spacing - 1.0,
            ((k / per_row) as f32 + 0.5) * spacing - 1.0,
            0.0,
        )
    };
    let mut c = rift_fx::ring::RingCurves {
        opening: "bench".into(),
        ..Default::default()
    };
    let w = Vec3::Z * 12.0;
    for k in 0..loops {
        c.vertex_counts.push(LOOP_SEGMENTS as u32);
        c.directions.push(1);
        for j in 0..LOOP_SEGMENTS {
            let u = std::f32::consts::TAU * j as f32 / LOOP_SEGMENTS as f32;
            let r = Vec3::new(u.cos(), u.sin(), 0.1 * (3.0 * u).sin()) * radius;
            c.points.push(centre(k) + r);
            c.velocities.push(w.cross(r));
            c.accelerations.push(w.cross(w.cross(r)));
            c.widths.push(0.02 * radius);
            c.colors.push(Vec3::ONE);
            c.intensities.push(1.0);
        }
    }
    let ray = move |i: usize| {
        let h = |n: u32| super::hashed(i, 8, n);
        let k = ((h(0) * loops as f32) as usize).min(loops - 1);
        let angle = std::f32::consts::TAU * h(1);
        let target =
            centre(k) + Vec3::new(angle.cos(), angle.sin(), 0.0) * radius * (0.9 + 0.2 * h(2));
        let from = target + Vec3::new(h(3) - 0.5, h(4) - 0.5, 1.0).normalize() * 2.0;
        let time = (h(5) as f64 - 0.5) / 48.0;
        (from, (target - from).normalize(), time)
    };
    (c, ray)
}

/// Closest-hit queries on `segments` moving strand segments in small loops.
fn measure_strands(segments: usize, timing: &Timing) -> anyhow::Result<Point> {
    use rift_fx::rig::Similarity;
    use rift_render::geometry::{RingFrame, Strands};
    let (ring, ray) = loop_grid(segments);
    let shutter = [-1.0 / 96.0, 1.0 / 96.0];
    let t = Instant::now();
    let mut set = Strands::default();
    let frame = RingFrame::fixed(Similarity::IDENTITY);
    set.add_ring(&ring, frame, 0.0, shutter, 1.0);
    let build = t.elapsed().as_secs_f64();
    let rays = 500_000;
    let mut times = Vec::new();
    for _ in 0..timing.repeats {
        let t = Instant::now();
        crate::cli::with_threads(timing.threads, || {
            (0..rays)
                .into_par_iter()
                .filter(|&i| {
                    let (o, d, time) = ray(i);
                    let time = time.clamp(shutter[0], shutter[1]);
                    set.intersect(&Ray::new(o, d, f32::INFINITY, time), |_| true)
                        .is_some()
                })
                .count()
        })?;
        times.push(t.elapsed().as_secs_f64());
    }
    Ok(Point {
        axis: "strands",
        size: segments,
        build,
        cost: median(times) / rays as f64 * 1e6,
        peak_mib: None,
    })
}

/// The common head of the generated shots: a camera at `eye` looking at `target`, a grey
/// diffuse material and a dim sky.
fn shot_head(res: u32, eye: [f32; 3], target: [f32; 3]) -> String {
    format!(
        "[shot]\nname = \"scaling\"\nfps = 24.0\nframes = [1, 1]\nshutter = [0.0, 0.0]\n\
         [camera]\nresolution = [{res}, {res}]\nfov_degrees = 50.0\n[camera.transform]\n\
         position = {eye:?}\nlook_at = {target:?}\n[environment]\nradiance = [0.5, 0.5, 0.5]\n\
         [[material]]\nname = \"grey\"\ntype = \"diffuse\"\nreflectance = [0.6, 0.6, 0.6]\n"
    )
}

/// A shot of a wavy height field of about `triangles` triangles (binary PLY) under the sky.
fn triangles_shot(dir: &Path, triangles: usize, res: u32) -> anyhow::Result<PathBuf> {
    let cells = ((triangles as f64 / 2.0).sqrt().round() as usize).max(1);
    let side = cells + 1;
    let height = |x: f32, z: f32| {
        0.1 * (7.0 * x).sin() * (5.0 * z).cos() + 0.03 * (31.0 * x + 17.0 * z).sin()
    };
    let mut ply = std::io::BufWriter::new(std::fs::File::create(dir.join("field.ply"))?);
    write!(
        ply,
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\n\
         property float y\nproperty float z\nelement face {}\n\
         property list uchar int vertex_indices\nend_header\n",
        side * side,
        2 * cells * cells
    )?;
    for i in 0..side {
        for j in 0..side {
            let (x, z) = (
                2.0 * i as f32 / cells as f32 - 1.0,
                2.0 * j as f32 / cells as f32 - 1.0,
            );
            for v in [x, height(x, z), z] {
                ply.write_all(&v.to_le_bytes())?;
            }
        }
    }
    let at = |i: usize, j: usize| (i * side + j) as i32;
    for i in 0..cells {
        for j in 0..cells {
            for tri in [
                [at(i, j), at(i, j + 1), at(i + 1, j + 1)],
                [at(i, j), at(i + 1, j + 1), at(i + 1, j)],
            ] {
                ply.write_all(&[3])?;
                for v in tri {
                    ply.write_all(&v.to_le_bytes())?;
                }
            }
        }
    }
    ply.flush()?;
    let text = shot_head(res, [0.0, 1.2, 1.6], [0.0, 0.0, 0.0])
        + "[[object]]\nname = \"field\"\nmesh = \"field.ply\"\nmaterial = \"grey\"\n";
    write_shot(dir, "triangles", &text)
}

/// A shot of a wall with `openings` round openings in a square grid, each teleporting 100 m
/// along +X over a floor that runs under both places.
fn openings_shot(dir: &Path, openings: usize, res: u32) -> anyhow::Result<PathBuf> {
    let per_row = (openings as f64).sqrt().ceil() as usize;
    let spacing = 3.0 / per_row as f32;
    let mut text = shot_head(res, [0.0, 0.0, 3.0], [0.0, 0.0, 0.0])
        + "[[object]]\nname = \"floor\"\nmesh = \"floor.obj\"\nmaterial = \"grey\"\n";
    std::fs::write(
        dir.join("floor.obj"),
        "v -20 -1.6 -20\nv 120 -1.6 -20\nv 120 -1.6 20\nv -20 -1.6 20\nf 1 4 3 2\n",
    )?;
    for k in 0..openings {
        let x = ((k % per_row) as f32 + 0.5) * spacing - 1.5;
        let y = ((k / per_row) as f32 + 0.5) * spacing - 1.5;
        text += &format!(
            "[[portal]]\nname = \"o{k}\"\nhere = {{ position = [{x}, {y}, 0.0] }}\n\
             there = {{ position = [{}, {y}, 0.0] }}\n[portal.surface]\nradius = {}\n",
            x + 100.0,
            0.4 * spacing
        );
    }
    write_shot(dir, "openings", &text)
}

/// A shot of a closed room lit only through `windows` windows in a grid on one wall, which
/// lead into a lamp room 40 m away: every shading point in the room searches the openings for
/// light (one of them and its partner per window).
fn windows_shot(dir: &Path, windows: usize, res: u32) -> anyhow::Result<PathBuf> {
    std::fs::write(
        dir.join("room.obj"),
        super::box_obj([-3.0, 0.0, -3.0], [3.0, 3.0, 3.0], false),
    )?;
    std::fs::write(
        dir.join("lamp.obj"),
        super::box_obj([-0.2, -0.2, -0.2], [0.2, 0.2, 0.2], false),
    )?;
    let mut text = shot_head(res, [2.4, 1.5, 2.3], [-2.0, 1.1, -0.6])
        + "[[material]]\nname = \"lamp\"\ntype = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]\n\
           emission = [60.0, 52.0, 40.0]\ntwo_sided_emission = true\n\
           [[object]]\nname = \"room\"\nmesh = \"room.obj\"\nmaterial = \"grey\"\n\
           [[object]]\nname = \"lamp_room\"\nmesh = \"room.obj\"\nmaterial = \"grey\"\n\
           transform = { position = [40.0, 0.0, 0.0] }\n\
           [[object]]\nname = \"lamp\"\nmesh = \"lamp.obj\"\nmaterial = \"lamp\"\n\
           transform = { position = [40.6, 1.7, 0.2] }\n";
    let per_row = (windows as f64).sqrt().ceil() as usize;
    let (rows, columns) = (windows.div_ceil(per_row), per_row);
    let (height, width) = (2.2 / rows as f32, 5.2 / columns as f32);
    for k in 0..windows {
        let y = 0.4 + ((k / columns) as f32 + 0.5) * height;
        let z = -2.6 + ((k % columns) as f32 + 0.5) * width;
        let rectangle = [0.6 * width, 0.6 * height];
        for (name, pair, x, turn) in [("w", "t", -2.97, 90.0), ("t", "w", 42.97, -90.0)] {
            text += &format!(
                "[[portal]]\nname = \"{name}{k}\"\npair = \"{pair}{k}\"\n\
                 here = {{ position = [{x}, {y}, {z}], rotation_degrees = [0.0, {turn}, 0.0] }}\n\
                 [portal.surface]\nrectangle = {rectangle:?}\n"
            );
        }
    }
    write_shot(dir, "windows", &text)
}

/// A shot of a floor lit by `lamps` small lamps scattered under a ceiling (together as
/// bright as one), seen from above.
fn emitters_shot(dir: &Path, lamps: usize, res: u32) -> anyhow::Result<PathBuf> {
    let mut obj = String::from(
        "v -3 0 -3\nv 3 0 -3\nv 3 0 3\nv -3 0 3\nusemtl floor\nf 1 4 3 2\nusemtl lamp\n",
    );
    let size = 0.05f32;
    for k in 0..lamps {
        let h = |i: u32| super::hashed(k, 2, i);
        let (x, z) = (5.0 * h(0) - 2.5, 5.0 * h(1) - 2.5);
        for (dx, dz) in [(0.0, 0.0), (size, 0.0), (size, size), (0.0, size)] {
            obj += &format!("v {} 2 {}\n", x + dx, z + dz);
        }
        let first = 5 + 4 * k;
        obj += &format!("f {} {} {} {}\n", first, first + 1, first + 2, first + 3);
    }
    std::fs::write(dir.join("lamps.obj"), obj)?;
    let radiance = 400.0 / lamps as f32;
    let text = shot_head(res, [0.0, 1.5, 3.0], [0.0, 0.0, 0.0])
        .replace("radiance = [0.5, 0.5, 0.5]", "radiance = [0.0, 0.0, 0.0]")
        + &format!(
            "[[material]]\nname = \"lamp\"\ntype = \"diffuse\"\nreflectance = [0.0, 0.0, 0.0]\n\
         emission = [{radiance}, {radiance}, {radiance}]\n\
         [[object]]\nname = \"room\"\nmesh = \"lamps.obj\"\n"
        );
    // The OBJ's materials by name: the floor grey, the lamps emitting.
    let text = text
        + "[[material]]\nname = \"floor\"\ntype = \"diffuse\"\nreflectance = [0.6, 0.6, 0.6]\n";
    write_shot(dir, "emitters", &text)
}

fn write_shot(dir: &Path, name: &str, text: &str) -> anyhow::Result<PathBuf> {
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, text)?;
    Ok(path)
}

fn write_csv(path: &Path, points: &[Point]) -> anyhow::Result<()> {
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent)?;
    }
    let mut text = String::from("axis,size,build_seconds,microseconds,peak_mib\n");
    for p in points {
        text += &format!(
            "{},{},{:.4},{:.5},{}\n",
            p.axis,
            p.size,
            p.build,
            p.cost,
            p.peak_mib.map_or(String::new(), |m| format!("{m:.1}"))
        );
    }
    rift_fx::export::atomic::write(path, |out| out.write_all(text.as_bytes()))?;
    Ok(())
}

/// Resets the kernel's peak-memory mark of this process (Linux); true when it took (some
/// sandboxes refuse it, and a peak carried over from a larger scene would mislead).
pub(super) fn reset_peak_memory() -> bool {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
    match (status_mib("VmHWM:"), status_mib("VmRSS:")) {
        (Some(peak), Some(now)) => peak <= now + 1.0,
        _ => false,
    }
}

/// A memory figure of this process from /proc/self/status, MiB (Linux only).
pub(super) fn status_mib(key: &str) -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(key))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}
