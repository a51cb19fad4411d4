//! `rift render`: render frames of a shot to EXR.

use crate::fx_cmd::prepare_output_dir;
use anyhow::bail;
use clap::Args;
use rift_fx::{FrameRange, Shot};
use rift_render::Scene;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `rift render`.
#[derive(Args)]
pub struct RenderArgs {
    /// The shot file (TOML).
    shot: PathBuf,
    /// One frame (default: the shot's first).
    #[arg(long, conflicts_with = "frames")]
    frame: Option<i64>,
    /// A range of frames, `1001-1010`.
    #[arg(long)]
    frames: Option<String>,
    /// Output path; `#`s become the (zero-padded) frame number. Default: `[render] output`.
    #[arg(short, long)]
    output: Option<String>,
    /// Samples per pixel (overrides the shot).
    #[arg(long)]
    spp: Option<u32>,
    /// Seed (overrides the shot).
    #[arg(long)]
    seed: Option<u32>,
    /// Worker threads (default: all cores). The image is identical for any count.
    #[arg(long)]
    threads: Option<usize>,
    /// Image size in pixels, overriding the shot (the vertical field of view is kept).
    #[arg(long, num_args = 2, value_names = ["W", "H"])]
    res: Option<Vec<u32>>,
    /// Also write an sRGB PNG preview beside each EXR.
    #[arg(long)]
    png: bool,
}

/// Replaces the run of `#` in `pattern` with `frame`, zero-padded to the run's length.
pub fn frame_path(pattern: &str, frame: i64) -> String {
    match pattern.find('#') {
        None => pattern.to_owned(),
        Some(start) => {
            let len = pattern[start..].chars().take_while(|&c| c == '#').count();
            format!(
                "{}{:0len$}{}",
                &pattern[..start],
                frame,
                &pattern[start + len..]
            )
        }
    }
}

/// Runs `rift render`.
pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    let mut shot = Shot::load(&args.shot)?;
    if let Some(res) = &args.res {
        if res.iter().any(|&v| v == 0 || v > 65536) {
            bail!("--res: expected a width and height from 1 to 65536 pixels");
        }
        shot.camera.projection.resolution = [res[0], res[1]];
    }
    let frames = match (&args.frames, args.frame) {
        (Some(text), _) => FrameRange::parse(text).map_err(|e| anyhow::anyhow!("--frames: {e}"))?,
        (None, Some(f)) => FrameRange { first: f, last: f },
        (None, None) => FrameRange {
            first: shot.frames.first,
            last: shot.frames.first,
        },
    };
    if args.spp == Some(0) || args.spp.is_some_and(|s| s > 1 << 16) {
        bail!("--spp: expected 1 to 65536 samples per pixel");
    }
    for frame in frames.iter() {
        let mut scene = Scene::build(&shot, frame)?;
        if let Some(spp) = args.spp {
            scene.settings.spp = spp;
        }
        if let Some(seed) = args.seed {
            scene.settings.seed = seed;
        }
        let pattern = args
            .output
            .clone()
            .unwrap_or_else(|| scene.settings.output.clone());
        if frames.len() > 1 && !pattern.contains('#') {
            bail!("{pattern}: several frames need a `#` frame token in the output name");
        }
        let path = PathBuf::from(frame_path(&pattern, frame));
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            prepare_output_dir(dir)?;
        }
        let started = Instant::now();
        let spp = scene.settings.spp;
        let image = crate::with_threads(args.threads, || rift_render::render::render(&scene, spp))?;
        let seconds = started.elapsed().as_secs_f64();
        image.write_exr(&path)?;
        if args.png {
            image.write_png(&path.with_extension("png"))?;
        }
        eprintln!(
            "rift render: frame {frame}: {}x{} at {spp} spp in {seconds:.2} s ({:.2} Mpaths/s) -> {}{}",
            image.width,
            image.height,
            (image.width * image.height) as f64 * spp as f64 / seconds / 1e6,
            path.display(),
            if image.discarded > 0 {
                format!(" ({} non-finite samples discarded)", image.discarded)
            } else {
                String::new()
            }
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::frame_path;

    #[test]
    fn frame_tokens() {
        assert_eq!(frame_path("out/a.####.exr", 7), "out/a.0007.exr");
        assert_eq!(frame_path("out/a.#.exr", 1001), "out/a.1001.exr");
        assert_eq!(frame_path("out/a.exr", 3), "out/a.exr");
    }
}
