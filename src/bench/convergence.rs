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
    let prepared = rift_render::prepare::Prepared::build(&shot, frame, &Default::default())?;
    let threads = crate::cli::with_threads(args.threads.threads, rayon::current_num_threads)?;
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
        let image = crate::cli::with_threads(args.threads.threads, || {
            rift_render::frame::render(&prepared, &rift_render::frame::RenderOptions::new(spp))
        })?;
        let seconds = t.elapsed().as_secs_f64();
        let rel = rift_render::frame::film::relative_mse(&image.rgb, &reference);
        let efficiency = 1.0 / (rel * seconds);
        let mpaths = (w as f64 * h as f64 * spp as f64) / seconds / 1e6;
        println!("{spp:>6} {seconds:>10.3} {rel:>12.4e} {efficiency:>12.1} {mpaths:>10.3}");
        csv.push_str(&format!("{spp},{seconds},{rel},{efficiency},{mpaths}\n"));
        points.push((spp, rel));
    }
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
