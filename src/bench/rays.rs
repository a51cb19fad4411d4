//! `rift bench rays`: closest-hit and occlusion throughput on a generated height field, and the
//! same triangles and rays written out (`--dump`) so another ray tracer can be timed on exactly
//! them (`tools/rays_vs_embree.py` does so with Embree).

use super::median;
use clap::Args;
use glam::Vec3;
use rayon::prelude::*;
use rift_render::geometry::{Triangle, TriangleBvh, every_triangle};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `rift bench rays`.
#[derive(Args)]
pub struct RaysArgs {
    /// Grid cells per side of the generated height field (two triangles per cell).
    #[arg(long, default_value_t = 1024)]
    cells: usize,
    /// Rays per measurement.
    #[arg(long, default_value_t = 4_000_000)]
    rays: usize,
    /// Timed repeats (the median is reported).
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Also write the triangles and rays to this folder as NumPy arrays (`triangles.npy`,
    /// `origins.npy`, `directions.npy`, little-endian f32), with the occlusion distance in
    /// `occlusion_distance.txt`.
    #[arg(long)]
    dump: Option<PathBuf>,
}

/// How far occlusion rays reach: past the whole height field from any origin.
const OCCLUSION_DISTANCE: f32 = 3.0;

pub fn rays(args: RaysArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.cells > 0 && args.rays > 0 && args.repeats > 0,
        "expected positive counts"
    );
    let tris = height_field(args.cells);
    // Made before timing, as another tracer reads them from the dump.
    let rays: Vec<(Vec3, Vec3)> = (0..args.rays).map(ray).collect();
    if let Some(dir) = &args.dump {
        dump(dir, &tris, &rays)?;
    }
    let t = Instant::now();
    let accel = TriangleBvh::build(&tris, 0);
    let build = t.elapsed().as_secs_f64();
    let threads = crate::cli::with_threads(args.threads, rayon::current_num_threads)?;
    let mut closest = Vec::new();
    let mut occlusion = Vec::new();
    let mut hits = 0;
    for _ in 0..args.repeats {
        let t = Instant::now();
        hits = crate::cli::with_threads(args.threads, || {
            rays.par_iter()
                .filter(|&&(o, d)| {
                    accel
                        .intersect(o, d, f32::INFINITY, &every_triangle)
                        .is_some()
                })
                .count()
        })?;
        closest.push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        let blocked = crate::cli::with_threads(args.threads, || {
            rays.par_iter()
                .filter(|&&(o, d)| accel.occluded(o, d, OCCLUSION_DISTANCE, &every_triangle))
                .count()
        })?;
        occlusion.push(t.elapsed().as_secs_f64());
        anyhow::ensure!(
            blocked == hits,
            "occlusion and closest-hit queries disagree"
        );
    }
    println!(
        "rift bench rays: {} triangles (BVH build {build:.2} s), {} incoherent rays ({:.1}% hit), {threads} threads, median of {}",
        tris.len(),
        args.rays,
        100.0 * hits as f64 / args.rays as f64,
        args.repeats
    );
    println!("{:<12} {:>10} {:>10}", "query", "seconds", "Mrays/s");
    for (name, times) in [("closest hit", closest), ("occlusion", occlusion)] {
        let secs = median(times);
        println!(
            "{name:<12} {secs:>10.3} {:>10.2}",
            args.rays as f64 / secs / 1e6
        );
    }
    Ok(())
}

/// Ray `i` of the incoherent set: a hashed origin above the surface and a hashed, mostly
/// downward direction (unit length).
pub(super) fn ray(i: usize) -> (Vec3, Vec3) {
    let h = |k: u32| super::hashed(i, 4, k);
    let origin = Vec3::new(2.0 * h(0) - 1.0, 0.5 + h(1), 2.0 * h(2) - 1.0);
    let dir = Vec3::new(h(3) - 0.5, -1.0, h(1) * 0.7 - 0.35).normalize();
    (origin, dir)
}

/// A wavy height field of `cells`² quads over [−1, 1]², two triangles each.
fn height_field(cells: usize) -> Vec<Triangle> {
    let height = |x: f32, z: f32| {
        0.1 * (7.0 * x).sin() * (5.0 * z).cos() + 0.03 * (31.0 * x + 17.0 * z).sin()
    };
    super::quad_grid(cells, |i, j| {
        let (x, z) = (
            2.0 * i as f32 / cells as f32 - 1.0,
            2.0 * j as f32 / cells as f32 - 1.0,
        );
        Vec3::new(x, height(x, z), z)
    })
}

/// Writes the triangles and `rays` to `dir` (see [`RaysArgs::dump`]).
fn dump(dir: &Path, tris: &[Triangle], rays: &[(Vec3, Vec3)]) -> anyhow::Result<()> {
    use anyhow::Context;
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    let vertices: Vec<f32> = tris
        .iter()
        .flat_map(|t| t.v.iter().flat_map(|v| v.to_array()))
        .collect();
    write_npy(&dir.join("triangles.npy"), &[tris.len(), 3, 3], &vertices)?;
    let flat = |pick: fn(&(Vec3, Vec3)) -> Vec3| {
        rays.iter()
            .flat_map(|r| pick(r).to_array())
            .collect::<Vec<f32>>()
    };
    write_npy(&dir.join("origins.npy"), &[rays.len(), 3], &flat(|r| r.0))?;
    write_npy(
        &dir.join("directions.npy"),
        &[rays.len(), 3],
        &flat(|r| r.1),
    )?;
    let distance = dir.join("occlusion_distance.txt");
    std::fs::write(&distance, format!("{OCCLUSION_DISTANCE}\n"))
        .with_context(|| format!("{}: cannot write", distance.display()))
}

/// A little-endian f32 array of `shape` in NumPy's `.npy` format (version 1.0).
fn write_npy(path: &Path, shape: &[usize], data: &[f32]) -> anyhow::Result<()> {
    use anyhow::Context;
    let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    let dims = if dims.len() == 1 {
        format!("{},", dims[0])
    } else {
        dims.join(", ")
    };
    let mut header = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': ({dims}), }}");
    // Magic (6) + version (2) + length (2) + header + newline, padded to 64 bytes.
    let unpadded = 10 + header.len() + 1;
    header.push_str(&" ".repeat(unpadded.next_multiple_of(64) - unpadded));
    header.push('\n');
    let mut bytes = Vec::with_capacity(10 + header.len() + 4 * data.len());
    bytes.extend_from_slice(b"\x93NUMPY\x01\x00");
    bytes.extend_from_slice(&(header.len() as u16).to_le_bytes());
    bytes.extend_from_slice(header.as_bytes());
    for v in data {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    let mut file = std::fs::File::create(path)
        .with_context(|| format!("{}: cannot create", path.display()))?;
    file.write_all(&bytes)
        .with_context(|| format!("{}: cannot write", path.display()))
}
