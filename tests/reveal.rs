//! `rift reveal`: what each opening shows, checked against the path tracer's own Cryptomatte
//! (an object seen only through an opening covers as much of the image in both), objects seen
//! only through openings told from those also seen directly, and bad arguments refused.

use crate::common;

use common::{rift, root, stderr};
use rift_render::frame::cryptomatte::id;
use rift_render::frame::film::read_exr_layer;
use std::path::Path;

/// `example` as a still, pinhole, mono shot of 64x36 (its asset paths made absolute) in `dir`.
fn still(dir: &Path, example: &str) -> String {
    let text = std::fs::read_to_string(root().join("examples/shots").join(example)).unwrap();
    let mut out = String::new();
    let mut skip = false;
    for line in text.lines() {
        let trimmed = line.trim_start();
        if trimmed.starts_with('[') {
            skip = trimmed.starts_with("[camera.stereo]");
        }
        if skip || trimmed.starts_with("shutter") || trimmed.starts_with("fstop") {
            continue;
        }
        if trimmed.starts_with("resolution") {
            out += "resolution = [64, 36]\n";
            continue;
        }
        let assets = format!("{}/", root().join("examples/assets").display());
        out += &line.replace("../assets/", &assets);
        out += "\n";
        if trimmed == "[shot]" {
            out += "shutter = [0.0, 0.0]\n";
        }
    }
    std::fs::write(dir.join(example), out).unwrap();
    example.to_owned()
}

fn reveal_json(dir: &Path, shot: &str, frames: &str) -> serde_json::Value {
    let out = rift(
        dir,
        &[
            "reveal", shot, "--frames", frames, "--width", "64", "--json",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    serde_json::from_slice(&out.stdout).unwrap()
}

/// The row for `object` through `opening`.
fn row<'a>(seen: &'a serde_json::Value, opening: &str, object: &str) -> &'a serde_json::Value {
    seen["seen"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["opening"] == opening && r["object"] == object)
        .unwrap_or_else(|| panic!("{object} through {opening} not listed: {seen}"))
}

#[test]
fn what_an_opening_shows_matches_the_path_tracers_object_ids() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let shot = still(d, "through_portal.toml");
    let seen = reveal_json(d, &shot, "12");
    // The gallery stands beyond the door, out of the camera's direct view.
    let gallery = row(&seen, "room_door", "gallery");
    assert_eq!(gallery["only_through_openings"], true, "{gallery}");
    let coverage = gallery["mean_coverage"].as_f64().unwrap();
    // The path tracer's Cryptomatte of the same frame: pixels where the gallery covers most.
    let out = rift(
        d,
        &[
            "render",
            &shot,
            "--frame",
            "12",
            "--spp",
            "16",
            "--cryptomatte",
            "-o",
            "ids.exr",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let layer = read_exr_layer(&d.join("ids.exr")).unwrap();
    let (ids, cover) = (
        &layer.channels["CryptoObject00.R"],
        &layer.channels["CryptoObject00.G"],
    );
    let gallery_id = id("gallery");
    let rendered = (0..ids.len())
        .filter(|&p| ids[p] == gallery_id && cover[p] >= 0.5)
        .count() as f64
        / ids.len() as f64;
    eprintln!("gallery through the door: reveal {coverage:.4}, Cryptomatte {rendered:.4}");
    assert!(
        coverage > 0.05 && (coverage - rendered).abs() < 0.02,
        "reveal {coverage:.4} against Cryptomatte {rendered:.4}"
    );
}

#[test]
fn objects_seen_directly_too_are_told_apart() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let shot = still(d, "showcase.toml");
    let seen = reveal_json(d, &shot, "1-24");
    // The room is everywhere: through the back opening and directly.
    assert_eq!(row(&seen, "back", "room")["only_through_openings"], false);
    // The walker's copy on the far side shows only through the back opening, late in the shot.
    let copy = row(&seen, "back", "walker_there");
    assert_eq!(copy["only_through_openings"], true, "{copy}");
    assert!(copy["frames"][0].as_i64().unwrap() > 12, "{copy}");
    // The table says the same, for people.
    let out = rift(d, &["reveal", &shot, "--frames", "20", "--width", "32"]);
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(
        table
            .lines()
            .any(|l| l.contains("walker_there") && l.contains("only through openings")),
        "{table}"
    );
}

#[test]
fn bad_arguments_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let shot = still(d, "through_portal.toml");
    for (args, expected) in [
        (vec!["--frames", "x"], "--frames"),
        (vec!["--width", "0"], "--width"),
        (vec!["--step", "0"], "--step"),
    ] {
        let out = rift(d, &[&["reveal", shot.as_str()], args.as_slice()].concat());
        let e = stderr(&out);
        assert!(
            !out.status.success() && e.contains(expected),
            "{args:?}: {e}"
        );
    }
    let out = rift(d, &["reveal", "missing.toml"]);
    assert!(!out.status.success() && stderr(&out).contains("missing.toml"));
}
