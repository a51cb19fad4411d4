//! `rift bench through` and `rift bench bounce`: light sampling through openings, and bounces
//! aimed at them, each on against off.

use super::{Products, Timing, alternate};
use clap::Args;
use rift_fx::Shot;
use rift_render::prepare::Prepared;
use rift_render::scene::Overrides;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `rift bench through`.
#[derive(Args)]
pub struct ThroughArgs {
    /// A shot with a room lit through openings.
    #[arg(default_value = "examples/shots/lit_through.toml")]
    shot: PathBuf,
    #[command(flatten)]
    on_off: OnOffArgs,
}

/// Arguments of `rift bench bounce`.
#[derive(Args)]
pub struct BounceArgs {
    /// A shot with a room lit by light that bounced beyond an opening.
    #[arg(default_value = "examples/shots/bounce_through.toml")]
    shot: PathBuf,
    #[command(flatten)]
    on_off: OnOffArgs,
}

/// What an on-against-off comparison renders.
#[derive(Args)]
pub struct OnOffArgs {
    /// Frame to render (default: the shot's first).
    #[arg(long)]
    frame: Option<i64>,
    /// Samples per pixel of the measured renders.
    #[arg(long, default_value_t = 64)]
    spp: u32,
    /// Samples per pixel of the reference (rendered with the feature on).
    #[arg(long, default_value_t = 2048)]
    reference_spp: u32,
    /// Image width (the height follows the shot's aspect).
    #[arg(long, default_value_t = 160)]
    width: u32,
    /// Also render every round with a second seed and compare by the variance the two show,
    /// which the reference's own noise does not enter (it brings relMSE ratios towards 1).
    #[arg(long)]
    variance: bool,
    #[command(flatten)]
    timing: Timing,
}

/// Efficiency of light sampling through openings: on and off in turn, against a reference
/// rendered with it on, over the pixels of the room the camera stands in (no teleport).
pub fn run(args: ThroughArgs) -> anyhow::Result<()> {
    let products = on_against_off(&args.shot, &args.on_off, |on| Overrides {
        light_through_openings: Some(on),
        ..Default::default()
    })?;
    let (ratio, from_variance) = products.ratios(1, 0);
    println!(
        "light sampling through openings is {ratio:.2}x as efficient (1/(relMSE·s)) as without it"
    );
    print_variance_ratio(from_variance);
    Ok(())
}

/// Efficiency of bounces aimed at openings, the same way.
pub fn run_bounce(args: BounceArgs) -> anyhow::Result<()> {
    let products = on_against_off(&args.shot, &args.on_off, |on| Overrides {
        guide_through_openings: Some(on),
        ..Default::default()
    })?;
    let (ratio, from_variance) = products.ratios(1, 0);
    println!(
        "bounces aimed at openings are {ratio:.2}x as efficient (1/(relMSE·s)) as BSDF sampling alone"
    );
    print_variance_ratio(from_variance);
    Ok(())
}

/// The ratio from two seeds' variance, where measured.
fn print_variance_ratio(ratio: Option<f64>) {
    if let Some(ratio) = ratio {
        println!(
            "from two seeds' variance, which the reference's own noise does not enter: {ratio:.2}x"
        );
    }
}

/// Renders `shot` with the `overrides` of a feature on and off in turn, against a reference
/// rendered with it on, over the pixels of the room the camera stands in (no teleport); what
/// each costs for its error ("on" first).
fn on_against_off(
    shot_path: &Path,
    args: &OnOffArgs,
    overrides: impl Fn(bool) -> Overrides,
) -> anyhow::Result<Products<2>> {
    use rift_render::frame::passes::{RenderOptions, render};
    anyhow::ensure!(
        args.spp > 0 && args.reference_spp > 0 && args.timing.repeats > 0 && args.width > 0,
        "expected positive counts"
    );
    let mut shot = Shot::load(shot_path)?;
    let frame = args.frame.unwrap_or(shot.frames.first);
    let [w, h] = shot.camera.projection.resolution;
    let height = ((args.width as f64 * h as f64 / w as f64).round() as u32).max(1);
    shot.camera.projection.resolution = [args.width, height];
    let build = |on: bool, seed| {
        Prepared::build(
            &shot,
            frame,
            &Overrides {
                seed: Some(seed),
                ..overrides(on)
            },
        )
    };
    let threads = crate::cli::with_threads(args.timing.threads, rayon::current_num_threads)?;
    let t = Instant::now();
    let reference_scene = build(true, 9_999)?;
    let reference = crate::cli::with_threads(args.timing.threads, || {
        render(&reference_scene, &RenderOptions::new(args.reference_spp))
    })?;
    let room = |i: usize| reference.portal_depth[i] == 0.0;
    let pixels = (0..reference.rgb.len()).filter(|&i| room(i)).count();
    anyhow::ensure!(
        pixels > 0,
        "{}: the camera sees no pixel without an opening",
        shot_path.display()
    );
    println!(
        "{}: frame {frame} ({}x{height}, {pixels} pixels in the camera's room), reference {} spp in {:.1} s, {threads} threads, median of {}",
        shot_path.display(),
        args.width,
        args.reference_spp,
        t.elapsed().as_secs_f64(),
        args.timing.repeats
    );
    if let Some(guide) = &reference_scene.bounce_guide {
        println!(
            "bounce guide: {}; trained in {:.2} s",
            guide.summary(),
            reference_scene.training_seconds
        );
    }
    alternate(
        ["on", "off"],
        |k, seed| Ok(build(k == 0, seed)?),
        (
            args.spp,
            args.timing.repeats,
            args.timing.threads,
            args.variance,
        ),
        &reference.rgb,
        room,
    )
}
