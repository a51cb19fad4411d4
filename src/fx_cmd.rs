//! `rift fx`: generate a shot's rings frame by frame, in parallel, and export them.

use crate::cli::prepare_output_dir;
use crate::progress::Progress;
use anyhow::bail;
use clap::Args;
use rayon::prelude::*;
use rift_fx::FrameRange;
use rift_fx::export::{self, Format};
use rift_fx::ring::RingGenerator;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `rift fx`.
#[derive(Args)]
pub struct FxArgs {
    /// The shot file (TOML).
    shot: PathBuf,
    /// Frames to generate: `1001` or `1001-1096` (default: the shot's range).
    #[arg(long)]
    frames: Option<String>,
    /// Output directory (created if missing).
    #[arg(short, long, default_value = "out")]
    output: PathBuf,
    /// Formats to write, comma-separated: usd, ply, cache.
    #[arg(long, default_value = "usd,ply,cache")]
    format: String,
    /// Image size in pixels, overriding the shot's, as `rift render --res` does: rings are
    /// tessellated for their size on screen, so caches for a render at another size are baked
    /// at that size.
    #[arg(long, num_args = 2, value_names = ["W", "H"], action = clap::ArgAction::Set)]
    res: Option<Vec<u32>>,
    /// Worker threads (default: all cores). Output is identical for any count.
    #[arg(long)]
    threads: Option<usize>,
    /// The most memory baking may take, such as `8G` (default: what the system has
    /// available); a shot whose rings could need more is refused before baking.
    #[arg(long, value_name = "SIZE", value_parser = crate::memory::parse_size)]
    max_memory: Option<u64>,
    /// Also measure how well the baked velocity and acceleration reproduce the true motion
    /// across the shutter, and print the largest error.
    #[arg(long)]
    check_motion: bool,
}

/// Runs `rift fx`.
pub fn run(args: FxArgs) -> anyhow::Result<()> {
    let mut shot = crate::cli::load_shot(&args.shot, "fx")?;
    if let Some(res) = &args.res {
        shot.camera.projection.resolution = crate::cli::parse_res(res)?;
    }
    let frames = match &args.frames {
        Some(text) => FrameRange::parse(text).map_err(|e| anyhow::anyhow!("--frames: {e}"))?,
        None => shot.frames,
    };
    let formats = Format::parse_list(&args.format).map_err(|e| anyhow::anyhow!("--format: {e}"))?;
    if shot.rings.iter().all(Option::is_none) {
        bail!(
            "{}: no opening has a ring (add a [portal.ring] table)",
            shot.source.display()
        );
    }
    prepare_output_dir(&args.output)?;

    let started = Instant::now();
    let generator = RingGenerator::new(&shot, frames);
    let threads = crate::cli::with_threads(args.threads, rayon::current_num_threads)?;
    crate::memory::ensure_fits(
        &format!("baking {threads} frames at once"),
        generator
            .frame_bytes_bound(frames)
            .saturating_mul(threads.min(frames.len()) as u64),
        crate::memory::budget(args.max_memory),
        "lower fx.max_segments or [portal.ring] strands, or use fewer --threads",
    )?;
    let progress = Progress::new("rift fx", frames.len());
    let frame_list: Vec<i64> = frames.iter().collect();
    let outcome = crate::cli::with_threads(args.threads, || {
        frame_list
            .par_iter()
            .map(|&frame| {
                let baked = generator.checked_frame(frame)?;
                let files = export::write_frame(&args.output, &shot.name, &baked, &formats)?;
                let motion = args.check_motion.then(|| generator.motion_error(frame, 9));
                progress.done(&format!(
                    "frame {frame}: {} file{}",
                    files.len(),
                    if files.len() == 1 { "" } else { "s" }
                ));
                Ok::<_, rift_fx::FxError>((baked.vertex_count(), files.len(), motion))
            })
            .collect::<Vec<_>>()
    })?;
    progress.finish();
    let stage = if formats.contains(&Format::Usd) && outcome.iter().all(Result::is_ok) {
        // The characters beside the rings, shaped and placed as the renderer has them.
        let samples = export::usd_stage::sample_frames(&shot, frames);
        let meshes = rift_render::scene::characters::sampled(&shot, &samples)?;
        Some(export::write_stage(&args.output, &shot, frames, &meshes)?)
    } else {
        None
    };

    let mut vertices = 0;
    let mut files = 0;
    let mut worst: Option<rift_fx::ring::MotionError> = None;
    for result in outcome {
        let (v, f, motion) = result?;
        vertices += v;
        files += f;
        if let Some(m) = motion
            && worst
                .as_ref()
                .is_none_or(|w| m.max_relative > w.max_relative)
        {
            worst = Some(m);
        }
    }
    eprintln!(
        "rift fx: {} frames, {vertices} strand-vertices, {files} files in {} ({:.2} s)",
        frames.len(),
        args.output.display(),
        started.elapsed().as_secs_f64()
    );
    if let Some(stage) = stage {
        eprintln!(
            "rift fx: {} plays frames {}-{} with the camera and openings",
            stage.display(),
            frames.first,
            frames.last
        );
    }
    if let Some(m) = worst {
        eprintln!(
            "rift fx: motion reconstruction across the shutter: max error {:.3e} = {:.3e} × ring radius \
             (fastest strand {:.3e} × radius)",
            m.max, m.max_relative, m.fastest_strand_relative
        );
    }
    Ok(())
}
