//! `rift bench fx`: ring generation and export throughput.

use super::{Timing, median};
use anyhow::Context;
use clap::Args;
use rayon::prelude::*;
use rift_fx::Shot;
use rift_fx::export::{self, Format};
use rift_fx::ring::RingGenerator;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `rift bench fx`.
#[derive(Args)]
pub struct FxBenchArgs {
    /// The shot to measure.
    #[arg(default_value = "examples/shots/heavy_rings.toml")]
    shot: PathBuf,
    /// Frames kept in memory and written per export repeat.
    #[arg(long, default_value_t = 8)]
    export_frames: usize,
    #[command(flatten)]
    timing: Timing,
}

pub fn run(args: FxBenchArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.timing.repeats > 0,
        "--repeats: expected a positive number"
    );
    let shot = Shot::load(&args.shot)?;
    let generator = RingGenerator::new(&shot, shot.frames);
    let frames: Vec<i64> = shot.frames.iter().collect();
    let threads = crate::cli::with_threads(args.timing.threads, rayon::current_num_threads)?;

    // Generation without export: every frame, results dropped as soon as they are counted.
    let mut gen_times = Vec::new();
    let mut vertices = 0usize;
    for _ in 0..args.timing.repeats {
        let t = Instant::now();
        vertices = crate::cli::with_threads(args.timing.threads, || {
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
        for _ in 0..args.timing.repeats {
            let t = Instant::now();
            let written = crate::cli::with_threads(args.timing.threads, || {
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
        args.timing.repeats
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
