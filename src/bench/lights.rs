//! `rift bench lights`: light selection on a ring-lit shot: the light tree against power-proportional choice.

use super::{Threads, alternate};
use clap::Args;
use rift_fx::Shot;
use rift_render::prepare::Prepared;
use std::path::PathBuf;
use std::time::Instant;

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
    /// Let shadow rays pass through strands, so the light reaching a point no longer depends
    /// on which strands hide others: what is left is what light selection controls.
    #[arg(long)]
    no_strand_shadows: bool,
    /// Timed repeats (the median is reported), each with its own seed.
    #[arg(long, default_value_t = 5)]
    repeats: usize,
    /// Also render every round with a second seed and compare by the variance the two show,
    /// which the reference's own noise does not enter (it brings relMSE ratios towards 1).
    #[arg(long)]
    variance: bool,
    #[command(flatten)]
    threads: Threads,
}

pub fn run(args: LightsArgs) -> anyhow::Result<()> {
    use rift_render::frame::passes::{RenderOptions, render};
    use rift_render::lights::emitters::LightSelection;
    use rift_render::scene::Overrides;
    anyhow::ensure!(
        args.spp > 0 && args.reference_spp > 0 && args.repeats > 0 && args.width > 0,
        "expected positive counts"
    );
    let mut shot = Shot::load(&args.shot)?;
    let [w, h] = shot.camera.projection.resolution;
    let height = ((args.width as f64 * h as f64 / w as f64).round() as u32).max(1);
    shot.camera.projection.resolution = [args.width, height];
    let build = |selection, seed| -> anyhow::Result<Prepared> {
        let mut scene = rift_render::Scene::load_with(
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
                *flags = flags.without(rift_render::portals::visibility::RayClass::Shadow);
            }
        }
        Ok(Prepared::new(scene))
    };
    let threads = crate::cli::with_threads(args.threads.threads, rayon::current_num_threads)?;
    let t = Instant::now();
    let reference_scene = build(LightSelection::Tree, 9_999)?;
    let reference = crate::cli::with_threads(args.threads.threads, || {
        render(&reference_scene, &RenderOptions::new(args.reference_spp))
    })?;
    let emitters = build(LightSelection::Tree, 0)?.scene.strands.segments.len();
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
    let choices = [
        LightSelection::Learned,
        LightSelection::Tree,
        LightSelection::Power,
    ];
    let products = alternate(
        ["learned", "tree", "power"],
        |k, seed| build(choices[k], seed),
        (args.spp, args.repeats, args.threads.threads, args.variance),
        &reference.rgb,
        |_| true,
    )?;
    let ((tree, tree_variance), (power, power_variance)) =
        (products.ratios(1, 0), products.ratios(2, 0));
    println!(
        "for the same error, the plain tree needs {tree:.2}x the time of the learned one, and \
         power-proportional {power:.2}x"
    );
    if let (Some(tree), Some(power)) = (tree_variance, power_variance) {
        println!("from two seeds' variance: {tree:.2}x and {power:.2}x");
    }
    Ok(())
}
