//! Split renders merge into the whole render: sample ranges (`rift render --samples`), windows
//! (`--crop`) and both, through `rift merge`, equal one render to float rounding on the beauty,
//! the through-openings layers and every AOV; parts that do not make up one render are refused.

use crate::common;

use common::{files_in, largest_difference, rift, root, stderr};
use rift_render::frame::film::read_exr_layer;
use std::path::Path;

/// A shot with an opening (so the through-openings layers are written), small and quick.
fn shot() -> std::path::PathBuf {
    root().join("examples/shots/lit_through.toml")
}

/// Renders the shot to `out` with `extra` arguments; what it said.
fn render(dir: &Path, out: &str, extra: &[&str]) -> String {
    let shot = shot();
    let mut args = vec!["render", shot.to_str().unwrap(), "-o", out];
    if !extra.contains(&"--res") {
        args.extend_from_slice(&["--res", "48", "27"]);
    }
    args.extend_from_slice(extra);
    let r = rift(dir, &args);
    assert!(r.status.success(), "{args:?}: {}", stderr(&r));
    stderr(&r)
}

fn merge(dir: &Path, out: &str, parts: &[&str]) -> std::process::Output {
    let mut args = vec!["merge", out];
    args.extend_from_slice(parts);
    rift(dir, &args)
}

#[test]
fn sample_ranges_tiles_and_both_merge_into_the_whole_render() {
    splits_merge_into_the_whole_render(&[]);
}

/// The bounce guide is learned from the scene alone (whole frames at a fixed size and seed),
/// never from the part a render covers, so parts aimed by it merge exactly too.
#[test]
fn parts_with_bounces_aimed_at_openings_merge_into_the_whole_render() {
    splits_merge_into_the_whole_render(&["--guide-through-openings"]);
}

/// Renders the shot whole and split three ways (`flags` added to every render), merges each
/// split and compares it with the whole render.
fn splits_merge_into_the_whole_render(flags: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let render = |d: &Path, out: &str, extra: &[&str]| render(d, out, &[extra, flags].concat());
    let said = render(d, "whole.exr", &["--spp", "12"]);
    if flags.contains(&"--guide-through-openings") {
        assert!(said.contains("regions aim at openings"), "{said}");
    }
    assert!(
        read_exr_layer(&d.join("whole.exr"))
            .unwrap()
            .channels
            .contains_key("throughOpenings.R"),
        "the shot has openings"
    );
    // Three uneven sample ranges.
    for range in ["0-2", "2-9", "9-12"] {
        render(d, &format!("s{range}.exr"), &["--samples", range]);
    }
    let m = merge(d, "by_samples.exr", &["s0-2.exr", "s2-9.exr", "s9-12.exr"]);
    assert!(m.status.success(), "{}", stderr(&m));
    // Four windows.
    let crops = ["0,0.5,0,0.5", "0.5,1,0,0.5", "0,0.5,0.5,1", "0.5,1,0.5,1"];
    for (k, crop) in crops.iter().enumerate() {
        render(d, &format!("t{k}.exr"), &["--spp", "12", "--crop", crop]);
    }
    let m = merge(d, "by_tiles.exr", &["t0.exr", "t1.exr", "t2.exr", "t3.exr"]);
    assert!(m.status.success(), "{}", stderr(&m));
    // Two windows by two sample ranges.
    let mut both = Vec::new();
    for (k, crop) in ["0,1,0,0.4", "0,1,0.4,1"].iter().enumerate() {
        for range in ["0-5", "5-12"] {
            let name = format!("b{k}_{range}.exr");
            render(d, &name, &["--samples", range, "--crop", crop]);
            both.push(name);
        }
    }
    let names: Vec<&str> = both.iter().map(String::as_str).collect();
    let m = merge(d, "by_both.exr", &names);
    assert!(m.status.success(), "{}", stderr(&m));
    for merged in ["by_samples.exr", "by_tiles.exr", "by_both.exr"] {
        let worst = largest_difference(&d.join("whole.exr"), &d.join(merged));
        assert!(
            worst <= 1e-5,
            "{merged}: differs from the whole render by {worst:e}"
        );
    }
}

/// A failed merge: exit 1, a message holding each of `expect`, no output file.
fn expect_refused(dir: &Path, parts: &[&str], expect: &[&str]) {
    let out = merge(dir, "out/merged.exr", parts);
    let msg = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{parts:?}: {msg}");
    for e in expect {
        assert!(msg.contains(e), "{parts:?}: message {msg:?} lacks {e:?}");
    }
    assert!(!msg.contains("panicked"), "{msg}");
    assert!(files_in(&dir.join("out")).is_empty(), "left output behind");
}

#[test]
fn parts_that_do_not_make_one_render_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for range in ["0-4", "3-8", "4-8"] {
        render(d, &format!("s{range}.exr"), &["--samples", range]);
    }
    render(d, "seed7.exr", &["--samples", "4-8", "--seed", "7"]);
    render(d, "small.exr", &["--samples", "4-8", "--res", "24", "14"]);
    render(d, "left.exr", &["--samples", "0-4", "--crop", "0,0.5,0,1"]);
    std::fs::create_dir(d.join("out")).unwrap();
    expect_refused(d, &["s0-4.exr", "s3-8.exr"], &["s3-8.exr", "overlap"]);
    expect_refused(d, &["s4-8.exr"], &["samples 0-4", "missing"]);
    expect_refused(d, &["s0-4.exr", "seed7.exr"], &["seed7.exr", "seed"]);
    expect_refused(d, &["s0-4.exr", "small.exr"], &["small.exr", "frame"]);
    expect_refused(d, &["left.exr", "s4-8.exr"], &["samples 0-4", "missing"]);
    // A truncated part.
    let bytes = std::fs::read(d.join("s4-8.exr")).unwrap();
    std::fs::write(d.join("cut.exr"), &bytes[..bytes.len() / 2]).unwrap();
    expect_refused(d, &["s0-4.exr", "cut.exr"], &["cut.exr"]);
    // More memory than allowed, refused from the headers before any pixel is read.
    expect_refused(
        d,
        &["--max-memory", "64K", "s0-4.exr", "s4-8.exr"],
        &["merging 2 parts", "--max-memory"],
    );
    // Not a rift image at all.
    std::fs::write(d.join("text.exr"), "hello").unwrap();
    expect_refused(d, &["text.exr"], &["text.exr"]);
}

#[test]
fn sample_ranges_are_checked_on_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let shot = shot();
    let shot = shot.to_str().unwrap();
    for (args, expect) in [
        (vec!["--samples", "8-4"], "--samples"),
        (vec!["--samples", "0-70000"], "--samples"),
        (vec!["--samples", "a-b"], "--samples"),
        (
            vec!["--samples", "0-8", "--target-error", "0.1"],
            "--target-error",
        ),
        (
            vec!["--samples", "0-8", "--time-limit", "5"],
            "--time-limit",
        ),
    ] {
        let mut all = vec!["render", shot, "-o", "out/x.exr"];
        all.extend(args.iter().copied());
        let r = rift(dir.path(), &all);
        assert_eq!(r.status.code(), Some(1), "{args:?}");
        assert!(stderr(&r).contains(expect), "{args:?}: {}", stderr(&r));
        assert!(files_in(&dir.path().join("out")).is_empty());
    }
}
