//! `rift bench convergence`: error against a converged reference as samples grow.

use super::Threads;
use clap::Args;
use rift_fx::Shot;
use std::path::PathBuf;
use std::time::Instant;

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
    /// The seed to render with, instead of the shot's.
    #[arg(long)]
    seed: Option<u32>,
    /// Also render each count with the next seed and report the variance the two images show
    /// (half their mean squared difference, regularised as relMSE is) and the efficiency from
    /// it: the reference's own noise, which adds to every relMSE, does not enter it. Seconds
    /// and relMSE are then the two renders' means.
    #[arg(long)]
    variance: bool,
    #[command(flatten)]
    threads: Threads,
}

pub fn run(args: ConvergenceArgs) -> anyhow::Result<()> {
    let shot = Shot::load(&args.shot)?;
    let (rw, rh, reference) = rift_render::texture::read_exr_rgb(&args.reference)?;
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
    let seed = match args.seed {
        Some(seed) => seed,
        None => rift_render::scene::Settings::read(&shot, &Default::default())?.seed,
    };
    let seeds: &[u32] = if args.variance {
        &[seed, seed.wrapping_add(1)]
    } else {
        &[seed]
    };
    let prepared = seeds
        .iter()
        .map(|&seed| {
            let overrides = rift_render::scene::Overrides {
                seed: Some(seed),
                ..Default::default()
            };
            rift_render::prepare::Prepared::build(&shot, frame, &overrides)
        })
        .collect::<Result<Vec<_>, _>>()?;
    let threads = crate::cli::with_threads(args.threads.threads, rayon::current_num_threads)?;
    println!(
        "rift bench convergence: {} against {}, {w}x{h}, {threads} threads, seed{} {}",
        args.shot.display(),
        args.reference.display(),
        if args.variance { "s" } else { "" },
        seeds
            .iter()
            .map(u32::to_string)
            .collect::<Vec<_>>()
            .join(" and ")
    );
    let mut header = format!(
        "{:>6} {:>10} {:>12} {:>12} {:>10}",
        "spp", "seconds", "relMSE", "efficiency", "Mpaths/s"
    );
    let mut csv = String::from("spp,seconds,rel_mse,efficiency,mpaths_per_s");
    if args.variance {
        header += &format!(" {:>12} {:>12}", "variance", "efficiency");
        csv += ",rel_variance,variance_efficiency";
    }
    println!("{header}");
    csv.push('\n');
    let mut points = Vec::new();
    let mut last_images = Vec::new();
    for spp in counts {
        let mut images = Vec::new();
        let mut seconds = 0.0;
        for seeded in &prepared {
            let t = Instant::now();
            images.push(crate::cli::with_threads(args.threads.threads, || {
                rift_render::frame::render(seeded, &rift_render::frame::RenderOptions::new(spp))
            })?);
            seconds += t.elapsed().as_secs_f64() / prepared.len() as f64;
        }
        let rel = images
            .iter()
            .map(|image| rift_render::frame::film::relative_mse(&image.rgb, &reference))
            .sum::<f64>()
            / images.len() as f64;
        let efficiency = 1.0 / (rel * seconds);
        let mpaths = (w as f64 * h as f64 * spp as f64) / seconds / 1e6;
        let mut line =
            format!("{spp:>6} {seconds:>10.3} {rel:>12.4e} {efficiency:>12.1} {mpaths:>10.3}");
        csv.push_str(&format!("{spp},{seconds},{rel},{efficiency},{mpaths}"));
        if let [a, b] = &images[..] {
            let variance = rift_render::frame::film::relative_variance(&a.rgb, &b.rgb, &reference);
            let from_variance = 1.0 / (variance * seconds);
            line += &format!(" {variance:>12.4e} {from_variance:>12.1}");
            csv.push_str(&format!(",{variance},{from_variance}"));
        }
        println!("{line}");
        csv.push('\n');
        points.push((spp, rel));
        last_images = images;
    }
    let reference_mean = rift_render::frame::film::channel_mean(&reference);
    let mean = last_images
        .iter()
        .map(|image| rift_render::frame::film::channel_mean(&image.rgb))
        .sum::<glam::DVec3>()
        / last_images.len() as f64;
    let off = (mean / reference_mean - 1.0) * 100.0;
    println!(
        "image mean against the reference at the last count (%): {:+.3} {:+.3} {:+.3}",
        off.x, off.y, off.z
    );
    for path in [&args.csv, &args.plot] {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            crate::cli::prepare_output_dir(dir)?;
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
