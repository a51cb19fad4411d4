//! `rift fx` end to end: outputs, determinism, and bad input.

use crate::common;

use common::{files_in, fx_frames, rift, root, stderr};

fn small_shot() -> String {
    std::fs::read_to_string(root().join("tests/data/small_shot.toml")).unwrap()
}

/// Writes `text` as `name` in `dir`, runs `rift fx` on it into `dir/out`, and checks the run
/// failed with a message naming the file and containing every one of `expect`, leaving no files.
fn expect_failure(name: &str, text: Option<&str>, extra: &[&str], expect: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    if let Some(text) = text {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    let mut args = vec!["fx", name, "-o", "out"];
    args.extend_from_slice(extra);
    let out = rift(dir.path(), &args);
    let msg = stderr(&out);
    assert!(
        !out.status.success(),
        "{name}: expected failure, got success"
    );
    assert_eq!(out.status.code(), Some(1), "{name}: exit code");
    for e in expect {
        assert!(msg.contains(e), "{name}: message {msg:?} lacks {e:?}");
    }
    assert!(!msg.contains("panicked"), "{name}: panicked: {msg}");
    let written = files_in(&dir.path().join("out"));
    assert!(written.is_empty(), "{name}: left files behind: {written:?}");
}

#[test]
fn writes_every_format_for_every_frame_and_ring() {
    let dir = tempfile::tempdir().unwrap();
    let shot = root().join("tests/data/small_shot.toml");
    let names: Vec<String> = fx_frames(dir.path(), &shot, &[])
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    for f in 1001..=1003 {
        for expected in [
            format!("small.{f}.usda"),
            format!("small.{f}.ringcache"),
            format!("small.a.{f}.ply"),
            format!("small.b.{f}.ply"),
        ] {
            assert!(names.contains(&expected), "missing {expected} in {names:?}");
        }
    }
    // And the shot's stage over the three frames.
    assert!(
        names.contains(&"small.usda".to_owned()),
        "no stage in {names:?}"
    );
    assert_eq!(names.len(), 13, "no stray temporary files: {names:?}");
}

#[test]
fn output_is_byte_identical_for_any_thread_count_and_frame_subset() {
    let dir = tempfile::tempdir().unwrap();
    let shot = root().join("tests/data/small_shot.toml");
    let shot = shot.to_str().unwrap();
    for (threads, out) in [("1", "one"), ("2", "two"), ("3", "three")] {
        let r = rift(
            dir.path(),
            &[
                "fx",
                shot,
                "--frames",
                "1001-1004",
                "-o",
                out,
                "--threads",
                threads,
            ],
        );
        assert!(r.status.success(), "{}", stderr(&r));
    }
    let alone = rift(dir.path(), &["fx", shot, "--frames", "1003", "-o", "alone"]);
    assert!(alone.status.success());
    let one = files_in(&dir.path().join("one"));
    assert_eq!(one.len(), 17);
    for other in ["two", "three"] {
        for f in &one {
            let g = dir.path().join(other).join(f.file_name().unwrap());
            assert!(
                std::fs::read(f).unwrap() == std::fs::read(&g).unwrap(),
                "{} differs with {other} threads",
                f.display()
            );
        }
    }
    // Every frame's files; the stage spans the frames of its own run.
    for f in files_in(&dir.path().join("alone")) {
        if f.file_name().unwrap() == "small.usda" {
            continue;
        }
        let g = dir.path().join("one").join(f.file_name().unwrap());
        assert!(
            std::fs::read(&f).unwrap() == std::fs::read(&g).unwrap(),
            "{} differs when generated alone",
            f.display()
        );
    }
}

#[test]
fn ply_and_cache_carry_the_same_curves() {
    let dir = tempfile::tempdir().unwrap();
    let shot = root().join("tests/data/small_shot.toml");
    let r = rift(
        dir.path(),
        &["fx", shot.to_str().unwrap(), "--frames", "1005", "-o", "o"],
    );
    assert!(r.status.success());
    let cache = rift_fx::export::cache::read(&dir.path().join("o/small.1005.ringcache")).unwrap();
    assert_eq!(cache.frame, 1005);
    assert_eq!(cache.rings.len(), 2);
    for ring in &cache.rings {
        let bytes = std::fs::read(
            dir.path()
                .join(format!("o/small.{}.1005.ply", ring.opening)),
        )
        .unwrap();
        let header_end = bytes
            .windows(11)
            .position(|w| w == b"end_header\n")
            .unwrap()
            + 11;
        let header = std::str::from_utf8(&bytes[..header_end]).unwrap();
        assert!(header.starts_with("ply\nformat binary_little_endian 1.0\n"));
        assert!(header.contains(&format!("element vertex {}\n", ring.len())));
        let props: Vec<&str> = header
            .lines()
            .filter_map(|l| l.strip_prefix("property "))
            .collect();
        assert_eq!(props.len(), rift_fx::export::ply::PROPERTIES.len());
        let body = &bytes[header_end..];
        let stride = 4 * props.len();
        assert_eq!(body.len(), stride * ring.len());
        let field = |row: usize, col: usize| {
            f32::from_le_bytes(body[row * stride + 4 * col..][..4].try_into().unwrap())
        };
        let strand =
            |row: usize| i32::from_le_bytes(body[row * stride + 48..][..4].try_into().unwrap());
        for (s, range) in ring.strand_ranges().enumerate() {
            for i in range {
                let p = ring.points[i];
                assert_eq!([field(i, 0), field(i, 1), field(i, 2)], p.to_array());
                assert_eq!(
                    [field(i, 3), field(i, 4), field(i, 5)],
                    ring.velocities[i].to_array()
                );
                assert_eq!(
                    [field(i, 6), field(i, 7), field(i, 8)],
                    ring.accelerations[i].to_array()
                );
                assert!((field(i, 9) as f64 - 1005.0 / 24.0).abs() < 1e-4);
                let angle = field(i, 10);
                assert!((0.0..std::f32::consts::TAU).contains(&angle));
                assert!((angle.cos() * field(i, 11) - p.x).abs() < 1e-5);
                assert_eq!(strand(i), s as i32);
                assert_eq!(
                    [field(i, 13), field(i, 14), field(i, 15)],
                    ring.colors[i].to_array()
                );
                assert_eq!(field(i, 16), ring.intensities[i]);
                assert_eq!(field(i, 17), ring.widths[i]);
            }
        }
    }
}

#[test]
fn a_corrupt_cache_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let shot = root().join("tests/data/small_shot.toml");
    assert!(
        rift(
            dir.path(),
            &[
                "fx",
                shot.to_str().unwrap(),
                "--frames",
                "1001",
                "-o",
                "o",
                "--format",
                "cache"
            ]
        )
        .status
        .success()
    );
    let path = dir.path().join("o/small.1001.ringcache");
    let mut bytes = std::fs::read(&path).unwrap();
    bytes.truncate(bytes.len() - 100);
    std::fs::write(&path, &bytes).unwrap();
    let err = rift_fx::export::cache::read(&path).unwrap_err().to_string();
    assert!(
        err.contains("small.1001.ringcache") && err.contains("not a valid ring cache"),
        "{err}"
    );
}

#[test]
fn missing_file() {
    expect_failure("nowhere.toml", None, &[], &["nowhere.toml", "cannot read"]);
}

#[test]
fn unknown_key() {
    let text = small_shot().replace("strands = 4", "strands = 4\nstrandz = 5");
    expect_failure(
        "bad.toml",
        Some(&text),
        &[],
        &["bad.toml", "portal[0].ring.strandz", "unknown field"],
    );
}

#[test]
fn wrong_type() {
    let text = small_shot().replace("fps = 24.0", "fps = \"fast\"");
    expect_failure(
        "bad.toml",
        Some(&text),
        &[],
        &["bad.toml", "shot.fps", "invalid type", "line 4"],
    );
}

#[test]
fn zero_strands() {
    let text = small_shot().replace("strands = 3", "strands = 0");
    expect_failure(
        "bad.toml",
        Some(&text),
        &[],
        &["bad.toml: portal[1].ring.strands: expected a positive integer"],
    );
}

#[test]
fn preset_mistakes() {
    // An unknown preset, named with the ones there are.
    let text = small_shot().replacen("radius = 0.8", "preset = \"wobbly\"\nradius = 0.8", 1);
    expect_failure(
        "bad.toml",
        Some(&text),
        &[],
        &[
            "portal[0].ring.preset",
            "\"wobbly\"",
            "rift, calm, crackling",
            "line",
        ],
    );
    // Overriding instability the calm preset does not have.
    let text = small_shot().replacen(
        "radius = 0.8",
        "preset = \"calm\"\nradius = 0.8\ninstability = { flare = 0.1 }",
        1,
    );
    expect_failure(
        "bad.toml",
        Some(&text),
        &[],
        &[
            "portal[0].ring.instability",
            "\"calm\" preset has no instability",
        ],
    );
    // Without a preset, the strand count is required.
    let text = small_shot().replace("strands = 4\n", "");
    expect_failure(
        "bad.toml",
        Some(&text),
        &[],
        &["portal[0].ring.strands", "missing"],
    );
    // An override out of range names its key.
    let text = small_shot().replacen(
        "radius = 0.8",
        "preset = \"rift\"\nradius = 0.8\ninstability = { flare = 3.0 }",
        1,
    );
    expect_failure(
        "bad.toml",
        Some(&text),
        &[],
        &["portal[0].ring.instability.flare"],
    );
}

#[test]
fn negative_radius() {
    let text = small_shot().replacen("radius = 0.8", "radius = -0.8", 1);
    expect_failure(
        "bad.toml",
        Some(&text),
        &[],
        &["bad.toml: portal[0].ring.radius: expected a positive number"],
    );
}

#[test]
fn singular_portal_frame() {
    let text = small_shot().replace("scale = 1.5", "scale = 0.0");
    expect_failure(
        "bad.toml",
        Some(&text),
        &[],
        &["bad.toml: portal[1].here.scale", "singular"],
    );
    let text = small_shot().replace(
        "here = { position = [-1.2, 1.5, 0.0], rotation_degrees = [0.0, 20.0, 0.0] }",
        "here = { position = [-1.2, 1.5, 0.0], look_at = [-1.2, 1.5, 0.0] }",
    );
    expect_failure(
        "bad.toml",
        Some(&text),
        &[],
        &["bad.toml: portal[0].here.look_at", "singular"],
    );
}

#[test]
fn non_similarity_pairing() {
    let text = small_shot().replace(
        "here = { position = [2.0, 1.6, -4.0], rotation_degrees = [0.0, -35.0, 0.0], scale = 1.5 }",
        "here = { matrix = [[1.0, 0.0, 0.0, 2.0], [0.0, 2.0, 0.0, 1.6], [0.0, 0.0, 1.0, -4.0], [0.0, 0.0, 0.0, 1.0]] }",
    );
    expect_failure(
        "bad.toml",
        Some(&text),
        &[],
        &["bad.toml: portal[1].here.matrix", "not a similarity"],
    );
}

#[test]
fn pairing_with_an_unknown_opening() {
    let text = small_shot().replace("pair = \"b\"", "pair = \"zz\"");
    expect_failure(
        "bad.toml",
        Some(&text),
        &[],
        &["bad.toml: portal[0].pair", "no opening is called \"zz\""],
    );
}

#[test]
fn too_many_openings() {
    let mut text = small_shot();
    for k in 0..4097 {
        text += &format!(
            "[[portal]]\nname = \"extra{k}\"\nhere = {{ position = [{k}.0, 0.0, 50.0] }}\n\
             there = {{ position = [{k}.0, 0.0, 60.0] }}\n"
        );
    }
    expect_failure(
        "bad.toml",
        Some(&text),
        &[],
        &["bad.toml: portal[4096]", "at most 4096 openings"],
    );
}

#[test]
fn unwritable_output_directory() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("shot.toml"), small_shot()).unwrap();
    // A regular file where a directory is needed: fails even for root.
    std::fs::write(dir.path().join("blocker"), b"").unwrap();
    let out = rift(dir.path(), &["fx", "shot.toml", "-o", "blocker/out"]);
    assert_eq!(out.status.code(), Some(1));
    let msg = stderr(&out);
    assert!(
        msg.contains("blocker/out") && msg.contains("output directory"),
        "{msg}"
    );
    assert_eq!(files_in(dir.path()).len(), 2, "nothing else written");
}

#[test]
fn bad_frames_and_formats() {
    let text = small_shot();
    expect_failure(
        "s.toml",
        Some(&text),
        &["--frames", "1010-1001"],
        &["--frames", "ends before it starts"],
    );
    expect_failure(
        "s.toml",
        Some(&text),
        &["--format", "usd,obj"],
        &["--format", "unknown format \"obj\""],
    );
}

#[test]
fn syntax_error_names_the_line() {
    expect_failure(
        "bad.toml",
        Some("[shot\nname = 1\n"),
        &[],
        &["bad.toml", "line 1"],
    );
}

#[test]
fn lengths_beyond_single_precision() {
    for (from, to, key) in [
        ("radius = 0.8", "radius = 1e40", "portal[0].ring.radius"),
        (
            "position = [-1.2, 1.5, 0.0]",
            "position = [-1.2e20, 1.5, 0.0]",
            "portal[0].here.position",
        ),
        ("scale = 1.5", "scale = 1e39", "portal[1].here.scale"),
    ] {
        let text = small_shot().replacen(from, to, 1);
        assert_ne!(text, small_shot(), "{from} is not in the shot");
        expect_failure("bad.toml", Some(&text), &[], &["bad.toml", key, "1e12"]);
    }
}

#[test]
fn rings_larger_than_the_memory_budget_are_refused_before_baking() {
    expect_failure(
        "small.toml",
        Some(&small_shot()),
        &["--max-memory", "4K"],
        &["baking", "needs", "4.0 KiB available", "fx.max_segments"],
    );
}
