//! `rift bench convergence`: error against a converged reference as samples grow.

use super::Threads;
use clap::Args;
use glam::Vec3;
use rift_fx::Shot;
use rift_render::frame::Image;
use rift_render::frame::film;
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
    let counts = sample_counts(&args.spp)?;
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
            rift_render::prepare::Prepared::build(&shot, shot.frames.first, &overrides)
        })
        .collect::<Result<Vec<_>, _>>()?;
    let threads = crate::cli::with_threads(args.threads.threads, rayon::current_num_threads)?;
    let seed_list: Vec<String> = seeds.iter().map(u32::to_string).collect();
    println!(
        "rift bench convergence: {} against {}, {w}x{h}, {threads} threads, seed{} {}",
        args.shot.display(),
        args.reference.display(),
        if args.variance { "s" } else { "" },
        seed_list.join(" and ")
    );
    let mut table = Table::new(args.variance, (w as usize) * (h as usize));
    let mut last = Vec::new();
    for spp in counts {
        let mut seconds = 0.0;
        let mut images = Vec::new();
        for seeded in &prepared {
            let t = Instant::now();
            images.push(crate::cli::with_threads(args.threads.threads, || {
                rift_render::frame::render(seeded, &rift_render::frame::RenderOptions::new(spp))
            })?);
            seconds += t.elapsed().as_secs_f64() / prepared.len() as f64;
        }
        table.add(spp, seconds, &images, &reference);
        last = images;
    }
    print_mean_against(&last, &reference);
    write_outputs(&args, &table)
}

/// The sample counts `--spp` lists.
fn sample_counts(list: &str) -> anyhow::Result<Vec<u32>> {
    list.split(',')
        .map(|t| {
            t.trim()
                .parse::<u32>()
                .ok()
                .filter(|&n| (1..=1 << 16).contains(&n))
        })
        .collect::<Option<_>>()
        .ok_or_else(|| {
            anyhow::anyhow!("--spp: expected comma-separated sample counts from 1 to 65536")
        })
}

/// The table printed as it grows, its CSV and the plot's points.
struct Table {
    pixels: usize,
    csv: String,
    points: Vec<(u32, f64)>,
}

impl Table {
    /// Prints the header; `variance`: with the two seeds' columns.
    fn new(variance: bool, pixels: usize) -> Self {
        let mut header = format!(
            "{:>6} {:>10} {:>12} {:>12} {:>10}",
            "spp", "seconds", "relMSE", "efficiency", "Mpaths/s"
        );
        let mut csv = String::from("spp,seconds,rel_mse,efficiency,mpaths_per_s");
        if variance {
            header += &format!(" {:>12} {:>12}", "variance", "efficiency");
            csv += ",rel_variance,variance_efficiency";
        }
        println!("{header}");
        csv.push('\n');
        Self {
            pixels,
            csv,
            points: Vec::new(),
        }
    }

    /// The row of `images` (one per seed; two give the variance columns) rendered at `spp` in
    /// `seconds` each on average.
    fn add(&mut self, spp: u32, seconds: f64, images: &[Image], reference: &[Vec3]) {
        let rel = images
            .iter()
            .map(|image| film::relative_mse(&image.rgb, reference))
            .sum::<f64>()
            / images.len() as f64;
        let efficiency = 1.0 / (rel * seconds);
        let mpaths = (self.pixels as f64 * spp as f64) / seconds / 1e6;
        let mut line =
            format!("{spp:>6} {seconds:>10.3} {rel:>12.4e} {efficiency:>12.1} {mpaths:>10.3}");
        self.csv
            .push_str(&format!("{spp},{seconds},{rel},{efficiency},{mpaths}"));
        if let [a, b] = images {
            let variance = film::relative_variance(&a.rgb, &b.rgb, reference);
            let from_variance = 1.0 / (variance * seconds);
            line += &format!(" {variance:>12.4e} {from_variance:>12.1}");
            self.csv.push_str(&format!(",{variance},{from_variance}"));
        }
        println!("{line}");
        self.csv.push('\n');
        self.points.push((spp, rel));
    }
}

/// Prints the mean of `images` against the reference's, per channel: the bias check that the
/// variance of two seeds cannot make.
fn print_mean_against(images: &[Image], reference: &[Vec3]) {
    let mean = images
        .iter()
        .map(|image| film::channel_mean(&image.rgb))
        .sum::<glam::DVec3>()
        / images.len().max(1) as f64;
    let off = (mean / film::channel_mean(reference) - 1.0) * 100.0;
    println!(
        "image mean against the reference at the last count (%): {:+.3} {:+.3} {:+.3}",
        off.x, off.y, off.z
    );
}

/// Writes the table's CSV and plot where `args` asks.
fn write_outputs(args: &ConvergenceArgs, table: &Table) -> anyhow::Result<()> {
    for path in [&args.csv, &args.plot] {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            crate::cli::prepare_output_dir(dir)?;
        }
    }
    rift_fx::export::atomic::write(&args.csv, |w| w.write_all(table.csv.as_bytes()))?;
    let title = format!(
        "{} against {}",
        args.shot.file_name().unwrap_or_default().to_string_lossy(),
        args.reference
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
    );
    crate::plot::convergence_png(&args.plot, &title, &table.points)?;
    println!("wrote {} and {}", args.csv.display(), args.plot.display());
    Ok(())
}
