//! Radiometry against independent ground truth: the Cornell box pack in ../shared/reference
//! (Mitsuba 3 at 16384 spp; Cycles agrees to 0.1%). An unbiased renderer matches its per-channel
//! mean to a few tenths of a percent, and its relative MSE falls as 1/spp.

use crate::common;

use common::{cornell_dir, rift, root, stderr};
use glam::DVec3;
use rift_render::frame::film::{channel_mean, relative_mse};
use rift_render::texture::read_exr_rgb;
use std::path::PathBuf;

pub(crate) fn reference() -> PathBuf {
    let path = root().join("../shared/reference/cornell/reference.exr");
    assert!(
        path.is_file(),
        "the Cornell reference pack is expected beside the checkout, at {}",
        path.display()
    );
    path
}

#[test]
fn cornell_matches_the_reference_mean_and_converges_as_one_over_spp() {
    let (_, _, reference) = read_exr_rgb(&reference()).unwrap();
    let ref_mean = channel_mean(&reference);
    // Whole paths: split ones (the example's) converge faster than 1/spp, as their branches
    // stratify against each other.
    let (mean8, mse8) = render_with_branches(8, 1);
    let (mean32, mse32) = render_with_branches(32, 1);
    for mean in [mean8, mean32] {
        let ratio = mean / ref_mean;
        // The mean of 65k pixels is far more precise than one pixel: 0.5% is many standard
        // deviations at 8 spp, and a bias such as a wrong MIS weight or a two-sided light breaks it.
        assert!(
            (ratio - DVec3::ONE).abs().max_element() < 0.005,
            "mean {mean} vs reference {ref_mean} (ratio {ratio})"
        );
    }
    // Four times the samples: a quarter of the error (within 25%: noise in the estimate itself).
    let fall = mse8 / mse32;
    assert!(
        (3.0..5.0).contains(&fall),
        "relMSE {mse8:.3e} at 8 spp, {mse32:.3e} at 32 spp: falls by {fall:.2}"
    );
}

#[test]
fn split_paths_keep_the_reference_mean_and_lower_the_error() {
    let (_, _, reference) = read_exr_rgb(&reference()).unwrap();
    let ref_mean = channel_mean(&reference);
    let spp = 16;
    let (mean1, mse1) = render_with_branches(spp, 1);
    let (mean4, mse4) = render_with_branches(spp, 4);
    let ratio = mean4 / ref_mean;
    assert!(
        (ratio - DVec3::ONE).abs().max_element() < 0.005,
        "4 branches: mean {mean4} vs reference {ref_mean} (ratio {ratio}; whole paths {mean1})"
    );
    // Four branches a sample quarter the bounce light's variance, which is nearly all of the
    // box's (measured: 0.24 of the error at 256 spp). Branches drawing the same numbers would
    // leave it whole.
    assert!(
        mse4 < 0.4 * mse1,
        "relMSE {mse4:.3e} with 4 branches against {mse1:.3e} without"
    );
}

/// Renders the example at `spp` with `[render] indirect_samples = branches` through the CLI,
/// returning (mean, relMSE against the reference).
fn render_with_branches(spp: u32, branches: u32) -> (DVec3, f64) {
    let dir = cornell_dir(|t| {
        let t = t.replace("indirect_samples = 4\n", "");
        t.replace(
            "seed = 0",
            &format!("seed = 0\nindirect_samples = {branches}"),
        )
    });
    let out = dir.path().join("c.exr");
    let r = rift(
        dir.path(),
        &[
            "render",
            "shot.toml",
            "--spp",
            &spp.to_string(),
            "-o",
            out.to_str().unwrap(),
        ],
    );
    assert!(r.status.success(), "{}", stderr(&r));
    let (w, h, img) = read_exr_rgb(&out).unwrap();
    let (rw, rh, reference) = read_exr_rgb(&reference()).unwrap();
    assert_eq!((w, h), (rw, rh));
    (channel_mean(&img), relative_mse(&img, &reference))
}

/// `rift bench convergence` of the Cornell box with `options` (the counts among them), writing
/// out/c.csv and out/c.png in `dir`: its standard output and the CSV's header and rows.
fn convergence_bench(dir: &tempfile::TempDir, options: &[&str]) -> (String, String, Vec<Vec<f64>>) {
    let reference = reference();
    let mut args = vec![
        "bench",
        "convergence",
        "shot.toml",
        "--reference",
        reference.to_str().unwrap(),
        "--csv",
        "out/c.csv",
        "--plot",
        "out/c.png",
    ];
    args.extend_from_slice(options);
    let r = rift(dir.path(), &args);
    assert!(r.status.success(), "{}", stderr(&r));
    let csv = std::fs::read_to_string(dir.path().join("out/c.csv")).unwrap();
    let rows = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    let header = csv.lines().next().unwrap_or_default().to_string();
    (
        String::from_utf8_lossy(&r.stdout).into_owned(),
        header,
        rows,
    )
}

#[test]
fn convergence_bench_writes_table_csv_and_plot() {
    let dir = cornell_dir(|t| t);
    let (_, _, rows) = convergence_bench(&dir, &["--spp", "1,2"]);
    assert_eq!(rows.len(), 2);
    assert!(
        rows[1][2] < rows[0][2],
        "relMSE falls with samples: {rows:?}"
    );
    let png = std::fs::read(dir.path().join("out/c.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
}

/// `--variance` renders each count with two seeds: the variance they show falls as 1/spp and,
/// while the reference's own noise is far below the error (few samples), matches relMSE; the
/// image mean against the reference is printed.
#[test]
fn convergence_bench_measures_the_variance_of_two_seeds() {
    let dir = cornell_dir(|t| t);
    let (out, header, rows) =
        convergence_bench(&dir, &["--spp", "2,8", "--variance", "--seed", "7"]);
    assert!(out.contains("seeds 7 and 8"), "{out}");
    assert!(out.contains("image mean against the reference"), "{out}");
    assert!(header.starts_with("spp,seconds,rel_mse,efficiency,mpaths_per_s,rel_variance,"));
    for row in &rows {
        let (rel, variance) = (row[2], row[5]);
        assert!((variance / rel - 1.0).abs() < 0.1, "{rows:?}");
        assert!((row[6] - 1.0 / (variance * row[1])).abs() < 1e-6 * row[6]);
    }
    let falls = rows[0][5] / rows[1][5];
    assert!((3.0..6.0).contains(&falls), "4x the samples: {falls}");
}
