//! `rift bench`: performance measurements printed as tables. Timings are medians over repeats;
//! compare ratios within one run, since the machines are shared.

mod convergence;
mod deforming;
mod furnace;
mod fx;
mod lights;
mod portals;
mod rays;
mod scaling;
mod stability;
mod strands;
mod textures;
mod through;

use clap::{Args, Subcommand};
use std::time::Instant;

/// What to measure.
#[derive(Subcommand)]
pub enum BenchCommand {
    /// Ring generation and export throughput on a heavy shot.
    Fx(fx::FxBenchArgs),
    /// Error against a converged reference as samples grow: relMSE, seconds, efficiency.
    Convergence(convergence::ConvergenceArgs),
    /// Closest-hit and occlusion ray throughput on a generated mesh.
    Rays(rays::RaysArgs),
    /// The cost of one teleport, and render time per extra portal level.
    Portals(portals::PortalsArgs),
    /// Round-curve ray throughput on many moving strand segments (and the same held still).
    Strands(strands::StrandsArgs),
    /// Light selection on a ring-lit shot: the light tree against power-proportional choice.
    Lights(lights::LightsArgs),
    /// Light sampling through openings, on against off, on the room the camera stands in.
    Through(through::ThroughArgs),
    /// Bounces aimed at openings, on against off, on a room lit by light that bounced beyond
    /// an opening.
    Bounce(through::BounceArgs),
    /// The numerical stress table: furnaces at extreme scales, placements, radiance and
    /// roughness, and long chains of scaled teleports, each against its tolerance.
    Stability(stability::StabilityArgs),
    /// Energy kept by lossless rough BSDFs (white furnace) across roughness.
    Furnace(furnace::FurnaceArgs),
    /// How render cost grows with triangles, strand segments, openings and emitters: a table
    /// and a log-log plot.
    Scaling(scaling::ScalingArgs),
    /// What textures cost: mipmap build time per megapixel, and a scene of a gigabyte of
    /// 8-bit textures: its load time and peak memory.
    Textures(textures::TexturesArgs),
    /// What a deforming mesh costs: load time per frame, peak memory, and ray throughput
    /// against the same mesh standing still.
    Deforming(deforming::DeformingArgs),
}

/// How long a timed benchmark runs: repeats (the median is reported) and threads.
#[derive(Args)]
pub struct Timing {
    /// Timed repeats (the median is reported).
    #[arg(long, default_value_t = 3)]
    pub repeats: usize,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

/// Worker threads of a benchmark that is not repeated.
#[derive(Args)]
pub struct Threads {
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

/// Runs a benchmark.
pub fn run(cmd: BenchCommand) -> anyhow::Result<()> {
    match cmd {
        BenchCommand::Fx(args) => fx::run(args),
        BenchCommand::Convergence(args) => convergence::run(args),
        BenchCommand::Rays(args) => rays::rays(args),
        BenchCommand::Portals(args) => portals::run(args),
        BenchCommand::Strands(args) => strands::run(args),
        BenchCommand::Lights(args) => lights::run(args),
        BenchCommand::Through(args) => through::run(args),
        BenchCommand::Bounce(args) => through::run_bounce(args),
        BenchCommand::Stability(args) => stability::run(args),
        BenchCommand::Furnace(args) => furnace::run(args),
        BenchCommand::Scaling(args) => scaling::run(args),
        BenchCommand::Textures(args) => textures::run(args),
        BenchCommand::Deforming(args) => deforming::run(args),
    }
}

/// Number `k` of the `count` hashed uniform numbers in [0, 1] of item `i`: the benchmarks'
/// rays, receivers and lamps, the same on every run.
pub(crate) fn hashed(i: usize, count: u32, k: u32) -> f32 {
    rift_render::sampling::hash32((i as u32).wrapping_mul(count).wrapping_add(k)) as f32
        / u32::MAX as f32
}

/// A grid of `cells`² quads, two triangles each, whose corner (`i`, `j`) for `i`, `j` in
/// 0..=`cells` is `at(i, j)`: the benchmarks' height fields.
pub(crate) fn quad_grid(
    cells: usize,
    at: impl Fn(usize, usize) -> glam::Vec3,
) -> Vec<rift_render::geometry::Triangle> {
    use rift_render::geometry::Triangle;
    let mut tris = Vec::with_capacity(2 * cells * cells);
    for i in 0..cells {
        for j in 0..cells {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            tris.push(Triangle { v: [a, b, c] });
            tris.push(Triangle { v: [a, c, d] });
        }
    }
    tris
}

/// A closed box from `lo` to `hi` as OBJ, its faces towards the inside (counter-clockwise seen
/// from inside) or, with `outward`, towards the outside.
pub(crate) fn box_obj(lo: [f32; 3], hi: [f32; 3], outward: bool) -> String {
    let mut text = String::new();
    for c in 0..8 {
        let coordinate = |axis: usize| {
            if c >> axis & 1 == 0 {
                lo[axis]
            } else {
                hi[axis]
            }
        };
        text += &format!("v {} {} {}\n", coordinate(0), coordinate(1), coordinate(2));
    }
    for face in [
        [1, 2, 4, 3],
        [5, 7, 8, 6],
        [1, 5, 6, 2],
        [3, 4, 8, 7],
        [1, 3, 7, 5],
        [2, 6, 8, 4],
    ] {
        let [a, b, c, d] = if outward {
            [face[3], face[2], face[1], face[0]]
        } else {
            face
        };
        text += &format!("f {a} {b} {c} {d}\n");
    }
    text
}

pub(crate) fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// What [`alternate`] measured of each variant: median seconds × median relMSE against the
/// reference, and with two seeds a round the same with the variance they show instead of the
/// relMSE (lower is better for both).
pub(crate) struct Products<const N: usize> {
    pub relmse: [f64; N],
    pub variance: Option<[f64; N]>,
}

impl<const N: usize> Products<N> {
    /// How many times as efficient variant `a` is as variant `b`: against the reference, and
    /// from two seeds' variance where measured.
    pub fn ratios(&self, b: usize, a: usize) -> (f64, Option<f64>) {
        (
            self.relmse[b] / self.relmse[a],
            self.variance.map(|v| v[b] / v[a]),
        )
    }
}

/// Renders variants of a scene in turn (`build(k, seed)` for variant k), `repeats` times each
/// with its own seed, so a change in the machine's load between runs falls on all alike;
/// prints each one's median seconds (of rendering, and of learning light selection where the
/// variant does), median relMSE against `reference` over the pixels `keep` selects, and their
/// product. With `two_seeds`, every round renders each variant with a second seed too (one no
/// round uses first) and adds the variance the two show ([`relative_variance`]): a reference
/// rendered with a few thousand samples has noise of its own, which adds to every relMSE
/// measured against it and so brings the variants' ratios towards 1; it does not enter the
/// variance.
///
/// [`relative_variance`]: rift_render::frame::film::relative_variance
pub(crate) fn alternate<const N: usize>(
    names: [&str; N],
    build: impl Fn(usize, u32) -> anyhow::Result<rift_render::prepare::Prepared>,
    (spp, repeats, threads, two_seeds): (u32, usize, Option<usize>, bool),
    reference: &[glam::Vec3],
    keep: impl Fn(usize) -> bool,
) -> anyhow::Result<Products<N>> {
    use rift_render::frame::film::{relative_mse, relative_variance};
    use rift_render::frame::{RenderOptions, render};
    let kept = |pixels: &[glam::Vec3]| -> Vec<glam::Vec3> {
        (0..pixels.len())
            .filter(|&i| keep(i))
            .map(|i| pixels[i])
            .collect()
    };
    let reference = kept(reference);
    let seeds_a_round = if two_seeds { 2 } else { 1 };
    let mut seconds = [(); N].map(|_| Vec::new());
    let mut errors = [(); N].map(|_| Vec::new());
    let mut variances = [(); N].map(|_| Vec::new());
    for round in 0..repeats as u32 {
        for k in 0..N {
            let mut images = Vec::new();
            for seed in [round, round + repeats as u32]
                .into_iter()
                .take(seeds_a_round)
            {
                let prepared = build(k, seed)?;
                let t = Instant::now();
                let image = crate::cli::with_threads(threads, || {
                    render(&prepared, &RenderOptions::new(spp))
                })?;
                // Learning light selection is part of what a variant costs.
                let training = prepared.training_seconds;
                seconds[k].push(t.elapsed().as_secs_f64() + training);
                let image = kept(&image.rgb);
                errors[k].push(relative_mse(&image, &reference));
                images.push(image);
            }
            if let [a, b] = &images[..] {
                variances[k].push(relative_variance(a, b, &reference));
            }
        }
    }
    Ok(print_products(
        names,
        spp,
        seconds,
        errors,
        two_seeds.then_some(variances),
    ))
}

/// The table of [`alternate`]: each variant's median seconds, relMSE and their product, and
/// with two seeds the median variance and its product; the products.
fn print_products<const N: usize>(
    names: [&str; N],
    spp: u32,
    seconds: [Vec<f64>; N],
    errors: [Vec<f64>; N],
    variances: Option<[Vec<f64>; N]>,
) -> Products<N> {
    let variances = variances.map(|v| v.map(median));
    let mut header = format!(
        "{:<8} {:>5} {:>10} {:>10} {:>14}",
        "choice", "spp", "seconds", "relMSE", "relMSE·s"
    );
    if variances.is_some() {
        header += &format!(" {:>10} {:>14}", "variance", "variance·s");
    }
    println!("{header}");
    let mut products = Products {
        relmse: [0.0; N],
        variance: variances.map(|_| [0.0; N]),
    };
    for (k, (seconds, errors)) in seconds.into_iter().zip(errors).enumerate() {
        let (s, e) = (median(seconds), median(errors));
        products.relmse[k] = s * e;
        let mut line = format!(
            "{:<8} {spp:>5} {s:>10.3} {e:>10.3e} {:>14.3e}",
            names[k],
            s * e
        );
        if let (Some(v), Some(var)) = (&mut products.variance, variances.map(|v| v[k])) {
            v[k] = s * var;
            line += &format!(" {var:>10.3e} {:>14.3e}", s * var);
        }
        println!("{line}");
    }
    products
}
