//! `rift bench`: performance measurements printed as tables. Timings are medians over repeats;
//! compare ratios within one run, since the machines are shared.

mod furnace;
mod rays;
mod stability;

use anyhow::Context;
use clap::{Args, Subcommand};
use rayon::prelude::*;
use rift_fx::Shot;
use rift_fx::export::{self, Format};
use rift_fx::ring::RingGenerator;
use rift_render::Ray;
use rift_render::visibility::RayClass;
use std::path::PathBuf;
use std::time::Instant;

/// What to measure.
#[derive(Subcommand)]
pub enum BenchCommand {
    /// Ring generation and export throughput on a heavy shot.
    Fx(FxBenchArgs),
    /// Error against a converged reference as samples grow: relMSE, seconds, efficiency.
    Convergence(ConvergenceArgs),
    /// Closest-hit and occlusion ray throughput on a generated mesh.
    Rays(rays::RaysArgs),
    /// The cost of one teleport, and render time per extra portal level.
    Portals(PortalsArgs),
    /// Round-curve ray throughput on many moving strand segments (and the same held still).
    Strands(StrandsArgs),
    /// Light selection on a ring-lit shot: the light tree against power-proportional choice.
    Lights(LightsArgs),
    /// Light sampling through openings, on against off, on the room the camera stands in.
    Through(ThroughArgs),
    /// The numerical stress table: furnaces at extreme scales, placements, radiance and
    /// roughness, and long chains of scaled teleports, each against its tolerance.
    Stability(stability::StabilityArgs),
    /// Energy kept by lossless rough BSDFs (white furnace) across roughness.
    Furnace(furnace::FurnaceArgs),
}

/// Arguments of `rift bench through`.
#[derive(Args)]
pub struct ThroughArgs {
    /// A shot with a room lit through openings.
    #[arg(default_value = "examples/shots/lit_through.toml")]
    shot: PathBuf,
    /// Frame to render (default: the shot's first).
    #[arg(long)]
    frame: Option<i64>,
    /// Samples per pixel of the measured renders.
    #[arg(long, default_value_t = 64)]
    spp: u32,
    /// Samples per pixel of the reference (light sampling through openings on).
    #[arg(long, default_value_t = 2048)]
    reference_spp: u32,
    /// Image width (the height follows the shot's aspect).
    #[arg(long, default_value_t = 160)]
    width: u32,
    /// Timed repeats (the median is reported), each with its own seed.
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
}

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
    /// Timed repeats (the median is reported).
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
}

/// Arguments of `rift bench lights`.
#[derive(Args)]
pub struct LightsArgs {
    /// A shot lit only by its rings.
    #[arg(default_value = "examples/shots/ring_on_wall.toml")]
    shot: PathBuf,
    /// Samples per pixel of the measured renders.
    #[arg(long, default_value_t = 16)]
    spp: u32,
    /// Samples per pixel of the reference (rendered with the light tree).
    #[arg(long, default_value_t = 1024)]
    reference_spp: u32,
    /// Image width (the height follows the shot's aspect).
    #[arg(long, default_value_t = 320)]
    width: u32,
    /// Timed repeats (the median is reported), each with its own seed.
    #[arg(long, default_value_t = 5)]
    repeats: usize,
    /// Let shadow rays pass through strands, so the light reaching a point no longer depends
    /// on which strands hide others: what is left is what light selection controls.
    #[arg(long)]
    no_strand_shadows: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
}

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
    /// Timed repeats (the median is reported).
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
}

/// Arguments of `rift bench convergence`.
#[derive(Args)]
pub struct ConvergenceArgs {
    /// The shot to render (its first frame).
    shot: PathBuf,
    /// The converged reference image (EXR, same resolution).
    #[arg(long)]
    reference: PathBuf,
    /// Sample counts to measure, comma-separated.
    #[arg(long, default_value = "16,64,256,1024")]
    spp: String,
    /// Where to write the table as CSV.
    #[arg(long, default_value = "out/convergence.csv")]
    csv: PathBuf,
    /// Where to write the log-log convergence plot.
    #[arg(long, default_value = "out/convergence.png")]
    plot: PathBuf,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
}

/// Arguments of `rift bench fx`.
#[derive(Args)]
pub struct FxBenchArgs {
    /// The shot to measure.
    #[arg(default_value = "examples/shots/heavy_rings.toml")]
    shot: PathBuf,
    /// Timed repeats per stage (the median is reported).
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    /// Frames kept in memory and written per export repeat.
    #[arg(long, default_value_t = 8)]
    export_frames: usize,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
}

/// Runs a benchmark.
pub fn run(cmd: BenchCommand) -> anyhow::Result<()> {
    match cmd {
        BenchCommand::Fx(args) => fx(args),
        BenchCommand::Convergence(args) => convergence(args),
        BenchCommand::Rays(args) => rays::rays(args),
        BenchCommand::Portals(args) => portals(args),
        BenchCommand::Strands(args) => strands(args),
        BenchCommand::Lights(args) => lights(args),
        BenchCommand::Through(args) => through(args),
        BenchCommand::Stability(args) => stability::run(args),
        BenchCommand::Furnace(args) => furnace::run(args),
    }
}

pub(crate) fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn fx(args: FxBenchArgs) -> anyhow::Result<()> {
    anyhow::ensure!(args.repeats > 0, "--repeats: expected a positive number");
    let shot = Shot::load(&args.shot)?;
    let generator = RingGenerator::new(&shot, shot.frames);
    let frames: Vec<i64> = shot.frames.iter().collect();
    let threads = crate::with_threads(args.threads, rayon::current_num_threads)?;

    // Generation without export: every frame, results dropped as soon as they are counted.
    let mut gen_times = Vec::new();
    let mut vertices = 0usize;
    for _ in 0..args.repeats {
        let t = Instant::now();
        vertices = crate::with_threads(args.threads, || {
            frames
                .par_iter()
                .map(|&f| generator.frame(f).vertex_count())
                .sum()
        })?;
        gen_times.push(t.elapsed().as_secs_f64());
    }
    let generation = median(gen_times);

    // Export: a few frames baked once, then written repeatedly per format.
    let kept: Vec<_> = frames
        .iter()
        .take(args.export_frames.max(1))
        .map(|&f| generator.frame(f))
        .collect();
    let kept_vertices: usize = kept.iter().map(|f| f.vertex_count()).sum();
    let dir = tempfile::tempdir().context("cannot create a temporary directory")?;
    let mut rows = Vec::new();
    for format in Format::ALL {
        let mut times = Vec::new();
        let mut bytes = 0u64;
        for _ in 0..args.repeats {
            let t = Instant::now();
            let written = crate::with_threads(args.threads, || {
                kept.par_iter()
                    .map(|f| export::write_frame(dir.path(), &shot.name, f, &[format]))
                    .collect::<Result<Vec<_>, _>>()
            })??;
            times.push(t.elapsed().as_secs_f64());
            bytes = written
                .iter()
                .flatten()
                .map(|p| std::fs::metadata(p).map(|m| m.len()).unwrap_or(0))
                .sum();
        }
        rows.push((format, median(times), bytes));
    }

    let strands: usize = shot
        .rings
        .iter()
        .flatten()
        .map(|r| r.strands as usize)
        .sum();
    println!(
        "rift bench fx: {} ({} frames, {} rings, {strands} strands, {:.0} vertices/strand on average), {threads} threads, median of {}",
        args.shot.display(),
        frames.len(),
        shot.rings.iter().flatten().count(),
        vertices as f64 / (strands * frames.len()) as f64,
        args.repeats
    );
    println!(
        "{:<14} {:>10} {:>16} {:>22} {:>10}",
        "stage", "vertices", "median s", "strand-vertices/s", "MB/s"
    );
    println!(
        "{:<14} {:>10} {:>16.3} {:>22.3e} {:>10}",
        "generate",
        vertices,
        generation,
        vertices as f64 / generation,
        "-"
    );
    for (format, secs, bytes) in rows {
        println!(
            "{:<14} {:>10} {:>16.3} {:>22.3e} {:>10.1}",
            format!("export {format:?}").to_lowercase(),
            kept_vertices,
            secs,
            kept_vertices as f64 / secs,
            bytes as f64 / secs / 1e6
        );
    }
    Ok(())
}

fn convergence(args: ConvergenceArgs) -> anyhow::Result<()> {
    let shot = Shot::load(&args.shot)?;
    let (rw, rh, reference) = rift_render::film::read_exr_rgb(&args.reference)?;
    let [w, h] = shot.camera.projection.resolution;
    anyhow::ensure!(
        (w as usize, h as usize) == (rw, rh),
        "{}: the reference is {rw}x{rh}, the shot renders {w}x{h}",
        args.reference.display()
    );
    let counts: Vec<u32> = args
        .spp
        .split(',')
        .map(|t| {
            t.trim()
                .parse::<u32>()
                .ok()
                .filter(|&n| (1..=1 << 16).contains(&n))
        })
        .collect::<Option<_>>()
        .ok_or_else(|| {
            anyhow::anyhow!("--spp: expected comma-separated sample counts from 1 to 65536")
        })?;
    let frame = shot.frames.first;
    let scene = rift_render::Scene::build(&shot, frame)?;
    let threads = crate::with_threads(args.threads, rayon::current_num_threads)?;
    println!(
        "rift bench convergence: {} against {}, {w}x{h}, {threads} threads",
        args.shot.display(),
        args.reference.display()
    );
    println!(
        "{:>6} {:>10} {:>12} {:>12} {:>10}",
        "spp", "seconds", "relMSE", "efficiency", "Mpaths/s"
    );
    let mut csv = String::from("spp,seconds,rel_mse,efficiency,mpaths_per_s\n");
    let mut points = Vec::new();
    for spp in counts {
        let t = Instant::now();
        let image = crate::with_threads(args.threads, || {
            rift_render::render::render(&scene, &rift_render::render::RenderOptions::new(spp))
        })?;
        let seconds = t.elapsed().as_secs_f64();
        let rel = rift_render::film::relative_mse(&image.rgb, &reference);
        let efficiency = 1.0 / (rel * seconds);
        let mpaths = (w as f64 * h as f64 * spp as f64) / seconds / 1e6;
        println!("{spp:>6} {seconds:>10.3} {rel:>12.4e} {efficiency:>12.1} {mpaths:>10.3}");
        csv.push_str(&format!("{spp},{seconds},{rel},{efficiency},{mpaths}\n"));
        points.push((spp, rel));
    }
    for path in [&args.csv, &args.plot] {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            crate::fx_cmd::prepare_output_dir(dir)?;
        }
    }
    rift_fx::export::atomic::write(&args.csv, |w| w.write_all(csv.as_bytes()))?;
    let title = format!(
        "{} against {}",
        args.shot.file_name().unwrap_or_default().to_string_lossy(),
        args.reference
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
    );
    crate::plot::convergence_png(&args.plot, &title, &points)?;
    println!("wrote {} and {}", args.csv.display(), args.plot.display());
    Ok(())
}

fn portals(args: PortalsArgs) -> anyhow::Result<()> {
    use rift_render::render::{RenderOptions, render};
    anyhow::ensure!(args.repeats > 0 && args.spp > 0, "expected positive counts");
    let depths: Vec<u32> = args
        .depths
        .split(',')
        .map(|d| d.trim().parse::<u32>())
        .collect::<Result<_, _>>()
        .context("--depths: expected comma-separated integers")?;
    let shot = Shot::load(&args.shot)?;
    let scene = rift_render::Scene::build(&shot, shot.frames.first)?;
    anyhow::ensure!(
        !scene.portals.is_empty(),
        "{}: the shot has no opening",
        args.shot.display()
    );
    let threads = crate::with_threads(args.threads, rayon::current_num_threads)?;

    // One teleport: finding the opening along a camera ray, then moving the ray through it.
    // Camera rays over the image, kept where they meet an opening.
    let [w, h] = shot.camera.projection.resolution.map(|v| v as usize);
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
            (0..args.repeats)
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
        args.repeats
    );
    println!(
        "one teleport (find the opening + move the ray, one thread): {teleport_ns:.1} ns; one closest-hit ray in this scene: {ray_ns:.1} ns"
    );

    // Render time against the depth limit.
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
        let scene = rift_render::Scene::build_with(&shot, shot.frames.first, &overrides)?;
        let mut times = Vec::new();
        let mut image = None;
        for _ in 0..args.repeats {
            let t = Instant::now();
            image = Some(crate::with_threads(args.threads, || {
                render(&scene, &RenderOptions::new(args.spp))
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

fn strands(args: StrandsArgs) -> anyhow::Result<()> {
    use rift_fx::rig::Similarity;
    use rift_render::geometry::{RingFrame, Strands};
    anyhow::ensure!(
        args.strands > 0 && args.segments > 2 && args.rays > 0 && args.repeats > 0,
        "expected positive counts (and at least 3 segments per strand)"
    );
    let ring = spinning_ring(args.strands, args.segments);
    let fixed = || RingFrame::Fixed {
        to_world: Similarity::IDENTITY,
        to_local: Similarity::IDENTITY,
    };
    // Shutter of half a frame at 24 fps around the frame.
    let shutter = [-1.0 / 96.0, 1.0 / 96.0];
    let threads = crate::with_threads(args.threads, rayon::current_num_threads)?;
    // Rays from all around towards random points of the ring's band, at random shutter times.
    let ray = |i: usize| {
        let h = |k: u32| {
            rift_render::sampling::hash32((i as u32).wrapping_mul(8).wrapping_add(k)) as f32
                / u32::MAX as f32
        };
        let angle = std::f32::consts::TAU * h(0);
        let target = glam::Vec3::new(angle.cos(), angle.sin(), 0.0) * (0.98 + 0.12 * h(1));
        let from = glam::Vec3::new(h(2) - 0.5, h(3) - 0.5, h(4) - 0.5).normalize_or_zero() * 3.0
            + glam::Vec3::Z * 0.5;
        let time = shutter[0] + (shutter[1] - shutter[0]) * h(5) as f64;
        (from, (target - from).normalize(), time)
    };
    println!(
        "rift bench strands: {} segments ({} strands), {} rays aimed at the band, {threads} threads, median of {}",
        args.strands * args.segments,
        args.strands,
        args.rays,
        args.repeats
    );
    println!(
        "{:<28} {:>9} {:>8} {:>10} {:>10}",
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
        for _ in 0..args.repeats {
            let t = Instant::now();
            hits = crate::with_threads(args.threads, || {
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
            let blocked = crate::with_threads(args.threads, || {
                (0..args.rays)
                    .into_par_iter()
                    .filter(|&i| {
                        let (o, d, time) = ray(i);
                        set.occluded(&Ray::new(o, d, f32::INFINITY, at(time)), |_| true)
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
            "{name:<28} {build:>9.3} {:>8.1} {:>7.2} Mr/s {:>5.2} Mr/s",
            100.0 * hits as f64 / args.rays as f64,
            rate(closest),
            rate(occlusion)
        );
    }
    Ok(())
}

fn lights(args: LightsArgs) -> anyhow::Result<()> {
    use rift_render::lights::LightSelection;
    use rift_render::render::{RenderOptions, render};
    use rift_render::scene::Overrides;
    anyhow::ensure!(
        args.spp > 0 && args.reference_spp > 0 && args.repeats > 0 && args.width > 0,
        "expected positive counts"
    );
    let mut shot = Shot::load(&args.shot)?;
    let [w, h] = shot.camera.projection.resolution;
    let height = ((args.width as f64 * h as f64 / w as f64).round() as u32).max(1);
    shot.camera.projection.resolution = [args.width, height];
    let build = |selection, seed| -> anyhow::Result<rift_render::Scene> {
        let mut scene = rift_render::Scene::build_with(
            &shot,
            shot.frames.first,
            &Overrides {
                light_selection: Some(selection),
                seed: Some(seed),
                ..Default::default()
            },
        )?;
        if args.no_strand_shadows {
            for flags in &mut scene.strand_flags {
                *flags = flags.without(rift_render::visibility::RayClass::Shadow);
            }
        }
        Ok(scene)
    };
    let threads = crate::with_threads(args.threads, rayon::current_num_threads)?;
    let t = Instant::now();
    let reference_scene = build(LightSelection::Tree, 9_999)?;
    let reference = crate::with_threads(args.threads, || {
        render(&reference_scene, &RenderOptions::new(args.reference_spp))
    })?;
    let emitters = build(LightSelection::Tree, 0)?.strands.segments.len();
    println!(
        "rift bench lights: {}{} ({}x{height}, {emitters} strand segments), reference {} spp in {:.1} s, {threads} threads, median of {}",
        args.shot.display(),
        if args.no_strand_shadows {
            " without strand shadows"
        } else {
            ""
        },
        args.width,
        args.reference_spp,
        t.elapsed().as_secs_f64(),
        args.repeats
    );
    println!(
        "{:<8} {:>5} {:>10} {:>10} {:>14}",
        "choice", "spp", "seconds", "relMSE", "relMSE·s"
    );
    let choices = [LightSelection::Tree, LightSelection::Power];
    let products = alternate(
        ["tree", "power"],
        |k, seed| build(choices[k], seed),
        (args.spp, args.repeats, args.threads),
        &reference.rgb,
        |_| true,
    )?;
    println!(
        "power-proportional needs {:.1}x the time of the light tree for the same error",
        products[1] / products[0]
    );
    Ok(())
}

/// Renders two variants of a scene in turn (`build(k, seed)` for variant k), `repeats` times
/// each with its own seed, so a change in the machine's load between runs falls on both
/// alike; prints each one's median seconds, median relMSE against `reference` over the
/// pixels `keep` selects, and their product, which it returns (lower is better).
fn alternate(
    names: [&str; 2],
    build: impl Fn(usize, u32) -> anyhow::Result<rift_render::Scene>,
    (spp, repeats, threads): (u32, usize, Option<usize>),
    reference: &[glam::Vec3],
    keep: impl Fn(usize) -> bool,
) -> anyhow::Result<[f64; 2]> {
    use rift_render::film::relative_mse;
    use rift_render::render::{RenderOptions, render};
    let kept = |pixels: &[glam::Vec3]| -> Vec<glam::Vec3> {
        (0..pixels.len())
            .filter(|&i| keep(i))
            .map(|i| pixels[i])
            .collect()
    };
    let reference = kept(reference);
    let mut seconds = [Vec::new(), Vec::new()];
    let mut errors = [Vec::new(), Vec::new()];
    for seed in 0..repeats as u32 {
        for k in 0..2 {
            let scene = build(k, seed)?;
            let t = Instant::now();
            let image = crate::with_threads(threads, || render(&scene, &RenderOptions::new(spp)))?;
            seconds[k].push(t.elapsed().as_secs_f64());
            errors[k].push(relative_mse(&kept(&image.rgb), &reference));
        }
    }
    println!(
        "{:<8} {:>5} {:>10} {:>10} {:>14}",
        "choice", "spp", "seconds", "relMSE", "relMSE·s"
    );
    let mut products = [0.0; 2];
    for (k, (seconds, errors)) in seconds.into_iter().zip(errors).enumerate() {
        let (s, e) = (median(seconds), median(errors));
        products[k] = s * e;
        println!(
            "{:<8} {spp:>5} {s:>10.3} {e:>10.3e} {:>14.3e}",
            names[k],
            s * e
        );
    }
    Ok(products)
}

/// Efficiency of light sampling through openings: on and off in turn, against a reference
/// rendered with it on, over the pixels of the room the camera stands in (no teleport).
fn through(args: ThroughArgs) -> anyhow::Result<()> {
    use rift_render::render::{RenderOptions, render};
    use rift_render::scene::Overrides;
    anyhow::ensure!(
        args.spp > 0 && args.reference_spp > 0 && args.repeats > 0 && args.width > 0,
        "expected positive counts"
    );
    let mut shot = Shot::load(&args.shot)?;
    let frame = args.frame.unwrap_or(shot.frames.first);
    let [w, h] = shot.camera.projection.resolution;
    let height = ((args.width as f64 * h as f64 / w as f64).round() as u32).max(1);
    shot.camera.projection.resolution = [args.width, height];
    let build = |on: bool, seed| {
        rift_render::Scene::build_with(
            &shot,
            frame,
            &Overrides {
                light_through_openings: Some(on),
                seed: Some(seed),
                ..Default::default()
            },
        )
    };
    let threads = crate::with_threads(args.threads, rayon::current_num_threads)?;
    let t = Instant::now();
    let reference_scene = build(true, 9_999)?;
    let reference = crate::with_threads(args.threads, || {
        render(&reference_scene, &RenderOptions::new(args.reference_spp))
    })?;
    let room = |i: usize| reference.portal_depth[i] == 0.0;
    let pixels = (0..reference.rgb.len()).filter(|&i| room(i)).count();
    anyhow::ensure!(
        pixels > 0,
        "{}: the camera sees no pixel without an opening",
        args.shot.display()
    );
    println!(
        "rift bench through: {} frame {frame} ({}x{height}, {pixels} pixels in the camera's room), reference {} spp in {:.1} s, {threads} threads, median of {}",
        args.shot.display(),
        args.width,
        args.reference_spp,
        t.elapsed().as_secs_f64(),
        args.repeats
    );
    let products = alternate(
        ["on", "off"],
        |k, seed| Ok(build(k == 0, seed)?),
        (args.spp, args.repeats, args.threads),
        &reference.rgb,
        room,
    )?;
    println!(
        "light sampling through openings is {:.1}x as efficient (1/(relMSE·s)) as without it",
        products[1] / products[0]
    );
    Ok(())
}
