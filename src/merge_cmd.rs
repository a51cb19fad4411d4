//! `rift merge`: parts of one frame (sample ranges from `rift render --samples`, windows from
//! `--crop`, or both) back into the image one render would have made.
//!
//! Each part's pixels are means over the samples that counted (its `spp` channel). Radiance-like
//! channels (beauty, through-openings light, directly seen emission, alpha, portal depth) merge
//! as means weighted by
//! those counts; first-hit AOVs (albedo, normal, depth) are means over the samples that hit,
//! so they are weighted by count × alpha. The not-through-openings layer is written again as
//! beauty − through. Light-group layers (`lightgroup.<name>`) merge like the beauty, and every
//! part must hold the same ones. Sums in single precision are the only difference from a whole render:
//! the result equals it to float rounding.

use anyhow::{Context, bail};
use clap::Args;
use rayon::prelude::*;
use rift_render::frame::film::{
    BACKGROUND_DEPTH, ExrLayer, Image, LIGHT_GROUP_PREFIX, Metadata, THROUGH_LAYER, Window,
    read_exr_layer,
};
use rift_render::scene::light_groups::DEFAULT_GROUP;
use rift_render::scene::rings::frame_path;
use std::path::{Path, PathBuf};

/// Arguments of `rift merge`.
#[derive(Args)]
pub struct MergeArgs {
    /// The merged EXR to write.
    output: PathBuf,
    /// The parts: EXRs `rift render` wrote for one frame with --samples and/or --crop.
    #[arg(required = true)]
    parts: Vec<PathBuf>,
    /// The frame: `#`s in the output and part names become its number, zero-padded to their
    /// count as `rift render` writes them (for farm jobs, whose task knows only the number).
    #[arg(long)]
    frame: Option<i64>,
    /// The most memory the merge may take, such as `8G` (default: what the system has
    /// available); parts that need more are refused before their pixels are read.
    #[arg(long, value_name = "SIZE", value_parser = crate::memory::parse_size)]
    max_memory: Option<u64>,
    /// Denoise the merged frame (parts never are).
    #[command(flatten)]
    denoise: crate::cli::DenoiseArgs,
}

/// One part, read and checked.
struct Part {
    path: PathBuf,
    layer: ExrLayer,
    window: Window,
    range: [u32; 2],
}

/// The header numbers parts must share, and the name each is reported by.
const SHARED: [(&str, &str); 3] = [
    ("rift/frame", "frame"),
    ("rift/seed", "seed"),
    ("rift/shotId", "shot"),
];

/// Channels every part must hold.
const REQUIRED: [&str; 16] = [
    "R",
    "G",
    "B",
    "emission.R",
    "emission.G",
    "emission.B",
    "A",
    "Z",
    "spp",
    "portalDepth",
    "albedo.R",
    "albedo.G",
    "albedo.B",
    "N.X",
    "N.Y",
    "N.Z",
];

pub fn run(args: MergeArgs) -> anyhow::Result<()> {
    let args = match args.frame {
        Some(frame) => {
            let numbered = |p: &PathBuf| PathBuf::from(frame_path(&p.to_string_lossy(), frame));
            MergeArgs {
                output: numbered(&args.output),
                parts: args.parts.iter().map(numbered).collect(),
                frame: None,
                max_memory: args.max_memory,
                denoise: args.denoise,
            }
        }
        None => args,
    };
    if args.denoise.denoise {
        crate::cli::ensure_denoiser()?;
    }
    ensure_parts_fit(&args.parts, args.max_memory)?;
    let parts = args
        .parts
        .par_iter()
        .map(|p| read_part(p))
        .collect::<anyhow::Result<Vec<_>>>()?;
    check_compatible(&parts)?;
    let (window, total) = check_coverage(&parts)?;
    let mut image = merge(&parts, window, total);
    if args.denoise.denoise {
        let quality = args.denoise.denoise_quality;
        crate::cli::denoise_frame(&mut image, quality, None, "rift merge")?;
    }
    image
        .write_exr(&args.output)
        .with_context(|| format!("writing {}", args.output.display()))?;
    eprintln!(
        "rift merge: {} parts -> {} ({}x{} pixels, {} samples per pixel)",
        parts.len(),
        args.output.display(),
        window.width(),
        window.height(),
        total
    );
    Ok(())
}

/// Refuses, from their headers, parts whose pixels (each channel as read and as the merge
/// weighs it) and the merged image would not fit in memory.
fn ensure_parts_fit(paths: &[PathBuf], max_memory: Option<u64>) -> anyhow::Result<()> {
    let mut needed = 0u64;
    let mut largest = 0usize;
    for path in paths {
        let (pixels, channels) = rift_render::frame::film::exr_layer_shape(path)?;
        needed = needed.saturating_add((pixels as u64).saturating_mul(channels as u64 * 8));
        largest = largest.max(pixels);
    }
    // The merged window is at least the largest part; its sums take about 160 bytes a pixel.
    let merged =
        rift_render::frame::passes::film_bytes(largest).saturating_add(largest as u64 * 160);
    crate::memory::ensure_fits(
        &format!("merging {} parts", paths.len()),
        needed.saturating_add(merged),
        crate::memory::budget(max_memory),
        "merge fewer parts at a time (merged parts merge again), or give more with --max-memory",
    )
}

fn read_part(path: &Path) -> anyhow::Result<Part> {
    let layer = read_exr_layer(path).with_context(|| format!("reading {}", path.display()))?;
    let fail = |what: String| anyhow::anyhow!("{}: {what}", path.display());
    for name in REQUIRED {
        if !layer.channels.contains_key(name) {
            return Err(fail(format!(
                "no `{name}` channel: not an image `rift render` wrote"
            )));
        }
    }
    if layer.channels.keys().any(|c| c.starts_with("CryptoObject")) {
        return Err(fail(
            "it has Cryptomatte layers, which rift merge does not combine; render a frame \
             with --cryptomatte in one piece"
                .into(),
        ));
    }
    let number = |key: &str| {
        layer
            .numbers
            .get(key)
            .copied()
            .ok_or_else(|| fail(format!("no `{key}` header: written by an older rift?")))
    };
    let (start, end) = (number("rift/sampleStart")?, number("rift/spp")?);
    for (key, _) in SHARED {
        number(key)?;
    }
    let (x0, y0) = layer.position;
    let (w, h) = layer.size;
    if x0 < 0 || y0 < 0 || x0 as usize + w > layer.display.0 || y0 as usize + h > layer.display.1 {
        return Err(fail("its data window leaves the frame".into()));
    }
    if !(start >= 0.0 && start < end) {
        return Err(fail(format!("an empty sample range {start}-{end}")));
    }
    let window = Window {
        x0: x0 as usize,
        x1: x0 as usize + w,
        y0: y0 as usize,
        y1: y0 as usize + h,
    };
    Ok(Part {
        path: path.to_owned(),
        layer,
        window,
        range: [start as u32, end as u32],
    })
}

/// Every part is of the same frame of the same shot, seed and resolution.
fn check_compatible(parts: &[Part]) -> anyhow::Result<()> {
    let first = &parts[0];
    for p in &parts[1..] {
        if p.layer.display != first.layer.display {
            bail!(
                "{}: a {}x{} frame, but {} is {}x{}",
                p.path.display(),
                p.layer.display.0,
                p.layer.display.1,
                first.path.display(),
                first.layer.display.0,
                first.layer.display.1
            );
        }
        for (key, what) in SHARED {
            if p.layer.numbers[key] != first.layer.numbers[key] {
                bail!(
                    "{}: another {what} than {} ({} against {}): parts of different renders",
                    p.path.display(),
                    first.path.display(),
                    p.layer.numbers[key],
                    first.layer.numbers[key]
                );
            }
        }
        if p.layer.channels.contains_key(&format!("{THROUGH_LAYER}.R"))
            != first
                .layer
                .channels
                .contains_key(&format!("{THROUGH_LAYER}.R"))
        {
            bail!(
                "{}: its layers differ from {}'s (through-openings light)",
                p.path.display(),
                first.path.display()
            );
        }
        if light_groups(&p.layer) != light_groups(&first.layer) {
            bail!(
                "{}: its light groups ({}) differ from {}'s ({})",
                p.path.display(),
                light_groups(&p.layer).join(", "),
                first.path.display(),
                light_groups(&first.layer).join(", ")
            );
        }
    }
    Ok(())
}

/// The window the parts cover and the samples per pixel they add up to: every pixel of the
/// window must be covered by sample ranges that neither overlap nor leave a gap from 0.
///
/// The parts' window edges cut the frame into cells that every part either covers whole or
/// misses, so checking one pixel per cell checks them all.
fn check_coverage(parts: &[Part]) -> anyhow::Result<(Window, u32)> {
    let window = parts.iter().skip(1).fold(parts[0].window, |w, p| Window {
        x0: w.x0.min(p.window.x0),
        x1: w.x1.max(p.window.x1),
        y0: w.y0.min(p.window.y0),
        y1: w.y1.max(p.window.y1),
    });
    let total = parts.iter().map(|p| p.range[1]).max().unwrap_or(0);
    let edges = |ends: &dyn Fn(&Window) -> [usize; 2]| {
        let mut e: Vec<usize> = parts.iter().flat_map(|p| ends(&p.window)).collect();
        e.sort_unstable();
        e.dedup();
        e
    };
    let (xs, ys) = (edges(&|w| [w.x0, w.x1]), edges(&|w| [w.y0, w.y1]));
    for cell_y in ys.windows(2) {
        for cell_x in xs.windows(2) {
            check_pixel(parts, cell_x[0], cell_y[0], total)?;
        }
    }
    Ok((window, total))
}

/// The parts holding pixel (x, y) give it the samples 0..total, each once.
fn check_pixel(parts: &[Part], x: usize, y: usize, total: u32) -> anyhow::Result<()> {
    let mut ranges: Vec<(u32, u32, usize)> = parts
        .iter()
        .enumerate()
        .filter(|(_, p)| {
            (p.window.x0..p.window.x1).contains(&x) && (p.window.y0..p.window.y1).contains(&y)
        })
        .map(|(k, p)| (p.range[0], p.range[1], k))
        .collect();
    ranges.sort_unstable();
    let mut next = 0;
    for (start, end, k) in ranges {
        if start < next {
            bail!(
                "{}: samples {start}-{end} overlap another part's at pixel ({x}, {y})",
                parts[k].path.display()
            );
        }
        if start > next {
            bail!("samples {next}-{start} of pixel ({x}, {y}) are in no part: one is missing");
        }
        next = end;
    }
    if next < total {
        bail!("samples {next}-{total} of pixel ({x}, {y}) are in no part: one is missing");
    }
    Ok(())
}

/// The light groups a part holds (`lightgroup.<name>.R/G/B` layers), in the order written.
fn light_groups(layer: &ExrLayer) -> Vec<String> {
    let mut names: Vec<String> = layer
        .channels
        .keys()
        .filter_map(|k| k.strip_prefix(LIGHT_GROUP_PREFIX)?.strip_suffix(".R"))
        .map(str::to_owned)
        .collect();
    // The default group first, as the renderer writes them.
    names.sort_by_key(|n| n != DEFAULT_GROUP);
    names
}

/// Weighted sums of every part over the window, divided out.
fn merge(parts: &[Part], window: Window, total: u32) -> Image {
    let n = window.area();
    let through = parts[0]
        .layer
        .channels
        .contains_key(&format!("{THROUGH_LAYER}.R"));
    let groups = light_groups(&parts[0].layer);
    let mut acc = Accumulator::new(n, groups.len());
    for p in parts {
        let c = &p.layer.channels;
        let rgb = |prefix: &str| {
            [
                c[&format!("{prefix}R")].as_slice(),
                c[&format!("{prefix}G")].as_slice(),
                c[&format!("{prefix}B")].as_slice(),
            ]
        };
        let (beauty, albedo, emitted) = (rgb(""), rgb("albedo."), rgb("emission."));
        let light = through.then(|| rgb(&format!("{THROUGH_LAYER}.")));
        let group_layers: Vec<_> = groups
            .iter()
            .map(|g| rgb(&format!("{LIGHT_GROUP_PREFIX}{g}.")))
            .collect();
        let normal = [&c["N.X"], &c["N.Y"], &c["N.Z"]];
        let (spp, alpha, z, portal_depth) = (&c["spp"], &c["A"], &c["Z"], &c["portalDepth"]);
        let at = |v: [&[f32]; 3], i: usize| {
            glam::DVec3::new(v[0][i] as f64, v[1][i] as f64, v[2][i] as f64)
        };
        for y in p.window.y0..p.window.y1 {
            for x in p.window.x0..p.window.x1 {
                let i = (y - p.window.y0) * p.window.width() + (x - p.window.x0);
                let o = (y - window.y0) * window.width() + (x - window.x0);
                let count = spp[i] as f64;
                let hits = count * alpha[i] as f64;
                acc.count[o] += count;
                acc.hits[o] += hits;
                acc.rgb[o] += at(beauty, i) * count;
                acc.emitted[o] += at(emitted, i) * count;
                if let Some(light) = light {
                    acc.through[o] += at(light, i) * count;
                }
                acc.portal_depth[o] += portal_depth[i] as f64 * count;
                for (sum, layer) in acc.groups.iter_mut().zip(&group_layers) {
                    sum[o] += at(*layer, i) * count;
                }
                acc.albedo[o] += at(albedo, i) * hits;
                acc.normal[o] += at(normal.map(|v| v.as_slice()), i) * hits;
                if hits > 0.0 {
                    acc.depth[o] += z[i] as f64 * hits;
                }
            }
        }
    }
    acc.finish(parts, window, total, through, groups)
}

/// Per output pixel: sample counts, hit counts and the weighted sums.
struct Accumulator {
    count: Vec<f64>,
    hits: Vec<f64>,
    rgb: Vec<glam::DVec3>,
    emitted: Vec<glam::DVec3>,
    through: Vec<glam::DVec3>,
    portal_depth: Vec<f64>,
    albedo: Vec<glam::DVec3>,
    normal: Vec<glam::DVec3>,
    depth: Vec<f64>,
    /// Per light group, its count-weighted radiance.
    groups: Vec<Vec<glam::DVec3>>,
}

impl Accumulator {
    fn new(n: usize, groups: usize) -> Self {
        Self {
            count: vec![0.0; n],
            hits: vec![0.0; n],
            rgb: vec![glam::DVec3::ZERO; n],
            emitted: vec![glam::DVec3::ZERO; n],
            through: vec![glam::DVec3::ZERO; n],
            portal_depth: vec![0.0; n],
            albedo: vec![glam::DVec3::ZERO; n],
            normal: vec![glam::DVec3::ZERO; n],
            depth: vec![0.0; n],
            groups: vec![vec![glam::DVec3::ZERO; n]; groups],
        }
    }

    fn finish(
        self,
        parts: &[Part],
        window: Window,
        total: u32,
        through: bool,
        group_names: Vec<String>,
    ) -> Image {
        let per_sample = |i: usize| self.count[i].max(1.0);
        let per_hit = |i: usize| self.hits[i].max(f64::MIN_POSITIVE);
        let n = self.count.len();
        let first = &parts[0].layer;
        let number = |key: &str| first.numbers.get(key).copied().unwrap_or(0.0);
        Image {
            width: first.display.0,
            height: first.display.1,
            window,
            rgb: (0..n)
                .map(|i| (self.rgb[i] / per_sample(i)).as_vec3())
                .collect(),
            emitted: (0..n)
                .map(|i| (self.emitted[i] / per_sample(i)).as_vec3())
                .collect(),
            through: through.then(|| {
                (0..n)
                    .map(|i| (self.through[i] / per_sample(i)).as_vec3())
                    .collect()
            }),
            alpha: (0..n)
                .map(|i| (self.hits[i] / per_sample(i)) as f32)
                .collect(),
            albedo: (0..n)
                .map(|i| (self.albedo[i] / per_hit(i)).as_vec3())
                .collect(),
            normal: (0..n)
                .map(|i| (self.normal[i] / per_hit(i)).as_vec3())
                .collect(),
            depth: (0..n)
                .map(|i| {
                    if self.hits[i] > 0.0 {
                        (self.depth[i] / self.hits[i]) as f32
                    } else {
                        BACKGROUND_DEPTH
                    }
                })
                .collect(),
            portal_depth: (0..n)
                .map(|i| (self.portal_depth[i] / per_sample(i)) as f32)
                .collect(),
            light_groups: group_names
                .into_iter()
                .zip(&self.groups)
                .map(|(name, sums)| {
                    let means = (0..n)
                        .map(|i| (sums[i] / per_sample(i)).as_vec3())
                        .collect();
                    (name, means)
                })
                .collect(),
            cryptomatte: None,
            noisy: None,
            spp: self.count.iter().map(|&c| c as u32).collect(),
            discarded: parts
                .iter()
                .map(|p| {
                    p.layer
                        .numbers
                        .get("rift/discardedSamples")
                        .copied()
                        .unwrap_or(0.0) as u64
                })
                .sum(),
            // The parts keep their means, not the squares an error estimate needs.
            noise: None,
            metadata: Metadata {
                frame: number("rift/frame") as i64,
                render_seconds: parts
                    .iter()
                    .map(|p| {
                        p.layer
                            .numbers
                            .get("rift/renderSeconds")
                            .copied()
                            .unwrap_or(0.0)
                    })
                    .sum(),
                spp: total,
                first_sample: 0,
                seed: number("rift/seed") as u32,
                shot_id: number("rift/shotId") as u32,
                world_to_camera: first.world_to_camera.unwrap_or_default(),
                world_to_ndc: first.world_to_ndc.unwrap_or_default(),
                view: first.view.clone(),
            },
        }
    }
}
