//! The USD that `rift fx` writes opens in Pixar's usd-core and passes every registered
//! `UsdValidation` validator, plus rift's own checks of what it promises to author
//! (tests/support/usd_validate.py). usd-core comes from tests/requirements.txt, which the test
//! command installs into the suite's own environment; without it this test fails rather than
//! skipping.

use crate::common;

use common::{fx_frames, python_command, rift, root, stderr};
use std::path::Path;

#[test]
fn example_shot_usd_passes_usd_core_validators() {
    let dir = tempfile::tempdir().unwrap();
    let shot = root().join("examples/shots/portal_pair.toml");
    let usda: Vec<String> = fx_frames(dir.path(), &shot, &["--format", "usd"])
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    // Three frames and the shot's stage over them.
    assert_eq!(usda.len(), 4);
    assert!(
        usda.iter().any(|p| p.ends_with("o/portal_pair.usda")),
        "{usda:?}"
    );

    let probe = python_command("python3")
        .args(["-c", "import pxr.UsdValidation"])
        .output();
    let ready = probe.as_ref().is_ok_and(|o| o.status.success());
    assert!(
        ready,
        "Pixar's usd-core is needed: tests/setup.sh installs tests/requirements.txt ({:?})",
        probe.map(|o| String::from_utf8_lossy(&o.stderr).into_owned())
    );
    let script = root().join("tests/support/usd_validate.py");
    let check = python_command("python3")
        .arg(script)
        .args(&usda)
        .output()
        .unwrap();
    let report = String::from_utf8_lossy(&check.stdout);
    assert!(
        check.status.success(),
        "usd validation failed:\n{report}{}",
        String::from_utf8_lossy(&check.stderr)
    );
    assert_eq!(report.matches(": ok").count(), 4, "{report}");
}

/// Runs a Python script of `tests/support` with `args`; panics with its output unless it
/// succeeds.
fn python(script: &str, args: &[&str], cwd: &Path) -> String {
    let out = python_command("python3")
        .arg(root().join("tests/support").join(script))
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{script} failed:\n{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    text
}

#[test]
fn the_shot_stage_carries_camera_openings_and_rings_as_rift_has_them() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let shot = root().join("examples/shots/portal_pair.toml");
    fx_frames(d, &shot, &["--format", "usd"]);
    let shot = shot.to_str().unwrap();
    for frame in ["1001", "1002", "1003"] {
        let out = format!("r.{frame}.exr");
        let args = [
            "render", shot, "--frame", frame, "--res", "16", "9", "--spp", "1", "-o", &out,
        ];
        let r = rift(d, &args);
        assert!(r.status.success(), "{}", stderr(&r));
    }
    // portal_pair's shutter opens a quarter frame early; the EXR holds the camera then.
    let args = [
        "o/portal_pair.usda",
        "r.{frame}.exr",
        "-0.25",
        "1001",
        "1002",
        "1003",
    ];
    let report = python("usd_stage_check.py", &args, d);
    assert_eq!(report.matches("camera differs").count(), 3, "{report}");
}

#[test]
fn blender_plays_the_shot_stage_as_moving_curves() {
    let probe = python_command("python3")
        .args(["-c", "import sys, bpy; print(sys.version_info[:2])"])
        .output()
        .unwrap();
    if !probe.status.success() {
        let version = python_command("python3")
            .args(["-c", "import sys; print(sys.version_info[:2] == (3, 11))"])
            .output()
            .unwrap();
        // bpy 4.5 is built for Python 3.11 only (tests/requirements.txt).
        assert!(
            String::from_utf8_lossy(&version.stdout).trim() != "True",
            "Blender's Python module is needed: tests/setup.sh installs tests/requirements.txt"
        );
        eprintln!("skipped: bpy 4.5 needs Python 3.11, which this machine's python3 is not");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fx_frames(
        d,
        &root().join("examples/shots/portal_pair.toml"),
        &["--format", "usd"],
    );
    let report = python(
        "blender_import.py",
        &["o/portal_pair.usda", "1001", "1002", "1003"],
        d,
    );
    // Both openings' rings, at each of the three frames.
    assert_eq!(report.matches(" points in ").count(), 6, "{report}");
}

#[test]
fn the_shot_stage_carries_the_character_and_its_copy_as_time_sampled_meshes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let shot = root().join("examples/shots/showcase.toml");
    let args = [
        "fx",
        shot.to_str().unwrap(),
        "--frames",
        "11-13",
        "--format",
        "usd",
        "-o",
        "o",
    ];
    let out = rift(d, &args);
    assert!(out.status.success(), "{}", stderr(&out));
    let ply = root().join("examples/assets/mannequin/walker.0012.ply");
    // The showcase's pair carries the back opening's here side 5.94 m along +z.
    let args = [
        "o/showcase.usda",
        "walker",
        "walker_there",
        "12",
        ply.to_str().unwrap(),
        "0",
        "0",
        "5.94",
    ];
    let report = python("usd_character_check.py", &args, d);
    assert!(report.contains("4284 triangles at 9 times"), "{report}");
    // And every registered validator passes the stage.
    let check = python_command("python3")
        .arg(root().join("tests/support/usd_validate.py"))
        .arg(d.join("o/showcase.usda"))
        .output()
        .unwrap();
    assert!(
        check.status.success(),
        "{}{}",
        String::from_utf8_lossy(&check.stdout),
        String::from_utf8_lossy(&check.stderr)
    );
}
