//! Every BSDF against an independent renderer: the shots in tests/data/bsdf (a sphere and a slab
//! of one material on a checkered floor, under a lamp or a sky) rendered by rift, compared with
//! Mitsuba 3's renders of the same scenes (written with their noise by
//! `tools/bsdf_vs_mitsuba.py generate`).
//!
//! Two seeds give rift's own noise without trusting any model of it: the squared difference of
//! the two renders, pixel by pixel, estimates each pixel's variance. Region means must then agree
//! within 0.5% plus four standard errors of the difference (rift's and Mitsuba's together), and
//! the relMSE against Mitsuba's image must be what the two noises alone explain; a wrong Fresnel
//! term, Jacobian or pdf shifts a region by several of those.

use crate::common;

use common::{rift, root, stderr};
use glam::{DVec3, Vec3};
use rift_render::texture::read_exr_rgb;
use serde::Deserialize;
use std::path::Path;

/// Samples per pixel of each of rift's two renders.
const SPP: u32 = 192;

#[derive(Deserialize)]
struct References {
    render: Vec<Reference>,
}

#[derive(Deserialize)]
struct Reference {
    shot: String,
    pixel_noise: f64,
    regions: Vec<Vec<[f64; 3]>>,
    region_sem: Vec<Vec<[f64; 3]>>,
}

/// Renders `shot` with `seed` into `out`, returning the pixels and the width.
fn render(shot: &Path, seed: u32, out: &Path) -> (usize, Vec<Vec3>) {
    let r = rift(
        out.parent().unwrap(),
        &[
            "render",
            shot.to_str().unwrap(),
            "--spp",
            &SPP.to_string(),
            "--seed",
            &seed.to_string(),
            "-o",
            out.to_str().unwrap(),
        ],
    );
    assert!(r.status.success(), "{}: {}", shot.display(), stderr(&r));
    let (w, _, pixels) = read_exr_rgb(out).unwrap();
    (w, pixels)
}

/// Per region (rows × cols over a w-wide image): the sum of `value(pixel index)` and the count.
fn region_sums(
    w: usize,
    h: usize,
    rows: usize,
    cols: usize,
    value: impl Fn(usize) -> DVec3,
) -> Vec<(DVec3, f64)> {
    let mut out = vec![(DVec3::ZERO, 0.0); rows * cols];
    for y in 0..h {
        for x in 0..w {
            let region = (y * rows / h) * cols + x * cols / w;
            out[region].0 += value(y * w + x);
            out[region].1 += 1.0;
        }
    }
    out
}

/// Compares one shot; returns a description of each failure.
fn compare(reference: &Reference, dir: &Path) -> Vec<String> {
    let data = root().join("tests/data/bsdf");
    let shot = data.join(&reference.shot);
    let stem = reference.shot.trim_end_matches(".toml");
    let (w, a) = render(&shot, 1, &dir.join(format!("{stem}_1.exr")));
    let (_, b) = render(&shot, 2, &dir.join(format!("{stem}_2.exr")));
    let (rw, rh, mitsuba) =
        read_exr_rgb(&data.join("references").join(format!("{stem}.exr"))).unwrap();
    assert_eq!((w, a.len()), (rw, rw * rh), "{stem}: resolution");
    let (rows, cols) = (reference.regions.len(), reference.regions[0].len());
    let mean = |i: usize| (a[i].as_dvec3() + b[i].as_dvec3()) * 0.5;
    // Var(mean of two) per pixel = E[(a − b)²]/4.
    let variance = |i: usize| {
        let d = a[i].as_dvec3() - b[i].as_dvec3();
        d * d * 0.25
    };
    let sums = region_sums(w, rh, rows, cols, mean);
    let variances = region_sums(w, rh, rows, cols, variance);
    let mut failures = Vec::new();
    for (r, ((sum, n), (var, _))) in sums.iter().zip(&variances).enumerate() {
        let (i, j) = (r / cols, r % cols);
        let ours = *sum / *n;
        let theirs = DVec3::from_array(reference.regions[i][j]);
        let their_sem = DVec3::from_array(reference.region_sem[i][j]);
        let sigma = (*var / (n * n) + their_sem * their_sem).powf(0.5);
        let allowed = 0.005 * theirs + 4.0 * sigma + DVec3::splat(1e-4);
        if ((ours - theirs).abs() - allowed).max_element() > 0.0 {
            failures.push(format!(
                "{stem} region ({i},{j}): rift {ours:.5} Mitsuba {theirs:.5} (±{sigma:.5})"
            ));
        }
    }
    // relMSE against Mitsuba: rift's noise (the mean of two renders) plus Mitsuba's, and
    // nothing more than chance adds.
    let rel = |i: usize, v: DVec3| {
        let m = mitsuba[i].as_dvec3();
        (v / (m * m + DVec3::splat(0.01))).element_sum() / 3.0
    };
    let pixels = a.len() as f64;
    let rel_mse = (0..a.len())
        .map(|i| rel(i, (mean(i) - mitsuba[i].as_dvec3()).powf(2.0)))
        .sum::<f64>()
        / pixels;
    let expected =
        (0..a.len()).map(|i| rel(i, variance(i))).sum::<f64>() / pixels + reference.pixel_noise;
    if rel_mse > 1.5 * expected + 1e-5 {
        failures.push(format!(
            "{stem}: relMSE {rel_mse:.3e} against Mitsuba, noise explains {expected:.3e}"
        ));
    }
    failures
}

#[test]
fn every_bsdf_matches_mitsuba_region_by_region() {
    let text = std::fs::read_to_string(root().join("tests/data/bsdf/references.toml")).unwrap();
    let references: References = toml::from_str(&text).unwrap();
    assert!(
        references.render.len() >= 50,
        "a case per BSDF and lighting"
    );
    let dir = tempfile::tempdir().unwrap();
    let failures: Vec<String> = references
        .render
        .iter()
        .flat_map(|r| compare(r, dir.path()))
        .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
