//! `rift bench`: performance measurements printed as tables. Timings are medians over repeats;
//! compare ratios within one run, since the machines are shared.

use anyhow::Context;
use clap::{Args, Subcommand};
use rayon::prelude::*;
use rift_fx::Shot;
use rift_fx::export::{self, Format};
use rift_fx::ring::RingGenerator;
use std::path::PathBuf;
use std::time::Instant;

/// What to measure.
#[derive(Subcommand)]
pub enum BenchCommand {
    /// Ring generation and export throughput on a heavy shot.
    Fx(FxBenchArgs),
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
    }
}

fn median(mut v: Vec<f64>) -> f64 {
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
