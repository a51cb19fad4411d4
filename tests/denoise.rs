//! Denoising (`--denoise`: Open Image Denoise, loaded from the pyoidn package tests/setup.sh
//! installs in tests/.venv): the denoised frame is closer to a converged one than the noisy
//! frame it came from, which is kept as the `noisy` layer, and the emission the camera sees
//! directly is left as rendered; light groups and the
//! through-openings layers still sum to the denoised beauty; a split render merged and
//! denoised equals the single render denoised; and what cannot work is refused before anything
//! is rendered or written.

use crate::common;
use crate::light_groups::{
    assert_groups_sum_to_beauty, layers_miss_beauty, lit_through, render_env,
};

use common::{rift_env, root, stderr};
use glam::Vec3;
use rift_render::frame::film::{ExrLayer, channel_mean, read_exr_layer, relative_mse};
use std::path::{Path, PathBuf};
use std::process::Output;

/// libOpenImageDenoise.so.2 inside tests/.venv's pyoidn.
pub(crate) fn oidn_library() -> PathBuf {
    let lib = root().join("tests/.venv/lib");
    let found = std::fs::read_dir(&lib)
        .ok()
        .into_iter()
        .flatten()
        .filter_map(|e| e.ok())
        .map(|e| {
            e.path()
                .join("site-packages/pyoidn/oidn/lib/libOpenImageDenoise.so.2")
        })
        .find(|p| p.is_file());
    found.unwrap_or_else(|| panic!("pyoidn is not in {} (run tests/setup.sh)", lib.display()))
}

/// `rift` in `dir` with `args`, OIDN found through RIFT_OIDN_LIBRARY = `library`.
fn rift_with(dir: &Path, library: &Path, args: &[&str]) -> Output {
    rift_env(dir, args, &[("RIFT_OIDN_LIBRARY", library)])
}

/// Renders `shot` at 64x36 into `out` with `extra`, OIDN found in tests/.venv.
fn render(dir: &Path, shot: &Path, out: &str, extra: &[&str]) {
    let library = oidn_library();
    render_env(dir, shot, out, extra, &[("RIFT_OIDN_LIBRARY", &library)]);
}

/// The layer `prefix` ("" for the beauty, "noisy." for the noisy one) as RGB.
fn rgb(layer: &ExrLayer, prefix: &str) -> Vec<Vec3> {
    let c = |k: &str| &layer.channels[&format!("{prefix}{k}")];
    let (r, g, b) = (c("R"), c("G"), c("B"));
    (0..r.len()).map(|i| Vec3::new(r[i], g[i], b[i])).collect()
}

#[test]
fn a_denoised_cornell_box_is_closer_to_the_reference_and_keeps_the_noisy_frame() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let shot = root().join("examples/cornell.toml");
    let shot = shot.to_str().unwrap();
    for (out, extra) in [("noisy.exr", None), ("denoised.exr", Some("--denoise"))] {
        let mut args = vec!["render", shot, "-o", out, "--spp", "16"];
        args.extend(extra);
        let r = rift_with(d, &oidn_library(), &args);
        assert!(r.status.success(), "{}", stderr(&r));
    }
    let [noisy, denoised] =
        ["noisy.exr", "denoised.exr"].map(|f| read_exr_layer(&d.join(f)).unwrap());
    // The noisy layer is the frame as rendered, to the bit.
    assert_eq!(rgb(&denoised, "noisy."), rgb(&noisy, ""));
    let (_, _, reference) =
        rift_render::texture::read_exr_rgb(&crate::cornell::reference()).unwrap();
    let before = relative_mse(&rgb(&noisy, ""), &reference);
    let after = relative_mse(&rgb(&denoised, ""), &reference);
    eprintln!("Cornell box at 4 spp: relMSE {before:.5} noisy, {after:.5} denoised");
    assert!(
        after < 0.25 * before,
        "denoised {after} against noisy {before}"
    );
    let mean = |v: &[Vec3]| channel_mean(v).element_sum();
    let ratio = mean(&rgb(&denoised, "")) / mean(&reference);
    assert!(
        (ratio - 1.0).abs() < 0.02,
        "denoised mean {ratio} of the reference's"
    );
}

#[test]
fn light_groups_and_the_through_openings_layers_still_sum_to_the_denoised_beauty() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let shot = lit_through(d);
    render(d, &shot, "denoised.exr", &["--spp", "4", "--denoise"]);
    assert_groups_sum_to_beauty(
        &d.join("denoised.exr"),
        &["blue", "default", "lamp", "ring"],
    );
    let denoised = read_exr_layer(&d.join("denoised.exr")).unwrap();
    let worst = layers_miss_beauty(&denoised, &["throughOpenings", "notThroughOpenings"]);
    assert!(
        worst <= 1e-4,
        "the through-openings layers miss the beauty by {worst:e}"
    );
}

#[test]
fn a_merged_split_render_denoised_equals_the_single_render_denoised() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let shot = lit_through(d);
    render(d, &shot, "whole.exr", &["--spp", "8", "--denoise"]);
    render(d, &shot, "a.exr", &["--samples", "0-3"]);
    render(d, &shot, "b.exr", &["--samples", "3-8"]);
    let merged = rift_with(
        d,
        &oidn_library(),
        &["merge", "merged.exr", "a.exr", "b.exr", "--denoise"],
    );
    assert!(merged.status.success(), "{}", stderr(&merged));
    let [whole, merged] = ["whole.exr", "merged.exr"].map(|f| read_exr_layer(&d.join(f)).unwrap());
    // The noisy layers agree to float rounding (1.2e-7 measured); the denoiser's network moves
    // its output about a thousand times as much as such differences in its input (1.0e-4
    // measured on the beauty and the light group, 1.5e-5 on the through-openings layer), so the
    // denoised layers are held to 1e-3, still far below any difference of samples (a sample more
    // or less changes pixels by percents).
    for (prefix, tolerance) in [
        ("", 1e-3),
        ("noisy.", 1e-6),
        ("lightgroup.lamp.", 1e-3),
        ("throughOpenings.", 1e-3),
    ] {
        let (a, b) = (rgb(&whole, prefix), rgb(&merged, prefix));
        let worst = a
            .iter()
            .zip(&b)
            .flat_map(|(p, q)| {
                (0..3).map(move |k| ((p[k] - q[k]).abs() / p[k].abs().max(1e-2)) as f64)
            })
            .fold(0.0, f64::max);
        assert!(
            worst < tolerance,
            "{prefix:?}: merged and whole differ by {worst:e}"
        );
    }
}

#[test]
fn what_cannot_be_denoised_is_refused_before_anything_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let shot = lit_through(d);
    let shot = shot.to_str().unwrap();
    // No library where it is said to be: the error says how to install it.
    let missing = d.join("nowhere/libOpenImageDenoise.so.2");
    let out = rift_with(
        d,
        &missing,
        &["render", shot, "-o", "x.exr", "--spp", "1", "--denoise"],
    );
    let e = stderr(&out);
    assert!(!out.status.success(), "{e}");
    assert!(
        e.contains("--denoise") && e.contains("pip install pyoidn"),
        "{e}"
    );
    assert!(e.contains("nowhere/libOpenImageDenoise.so.2"), "{e}");
    // A sample-range part: parts never are denoised, the merge is.
    let library = oidn_library();
    let args = [
        "render",
        shot,
        "-o",
        "x.exr",
        "--samples",
        "0-2",
        "--denoise",
    ];
    let out = rift_with(d, &library, &args);
    let e = stderr(&out);
    assert!(
        !out.status.success() && e.contains("rift merge --denoise"),
        "{e}"
    );
    // Merging with the library missing: refused before the parts are read.
    let out = rift_with(d, &missing, &["merge", "m.exr", "a.exr", "--denoise"]);
    assert!(!out.status.success() && stderr(&out).contains("pip install pyoidn"));
    for file in ["x.exr", "m.exr", "x.png"] {
        assert!(!d.join(file).exists(), "{file} was written");
    }
}

#[test]
fn the_readme_main_job_renders_the_showcase_at_16_spp_denoised() {
    // tools/main_job.sh, small: OIDN found in tests/.venv (no download), the frame denoised
    // with its noisy beauty kept, and the PNG preview written beside it.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("main.####.exr");
    let run = std::process::Command::new(root().join("tools/main_job.sh"))
        .args(["--res", "48", "27", "-o", out.to_str().unwrap()])
        .env("RIFT_BINARY", env!("CARGO_BIN_EXE_rift"))
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", stderr(&run));
    let layer = read_exr_layer(&dir.path().join("main.0012.exr")).unwrap();
    assert!(layer.channels.contains_key("noisy.R"), "not denoised");
    assert!(layer.channels["spp"].iter().all(|&s| s == 16.0));
    assert!(dir.path().join("main.0012.png").is_file());
}
