//! The USD that `rift fx` writes opens in Pixar's usd-core and passes every registered
//! `UsdValidation` validator, plus rift's own checks of what it promises to author
//! (tests/support/usd_validate.py). usd-core comes from tests/requirements.txt, which the test
//! command installs; without it this test fails rather than skipping.

mod common;

use common::{fx_frames, root};
use std::process::Command;

#[test]
fn example_shot_usd_passes_usd_core_validators() {
    let dir = tempfile::tempdir().unwrap();
    let shot = root().join("examples/shots/portal_pair.toml");
    let usda: Vec<String> = fx_frames(dir.path(), &shot, &["--format", "usd"])
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    assert_eq!(usda.len(), 3);

    let probe = Command::new("python3")
        .args(["-c", "import pxr.UsdValidation"])
        .output();
    let ready = probe.as_ref().is_ok_and(|o| o.status.success());
    assert!(
        ready,
        "Pixar's usd-core is needed: python3 -m pip install -r tests/requirements.txt ({:?})",
        probe.map(|o| String::from_utf8_lossy(&o.stderr).into_owned())
    );
    let script = root().join("tests/support/usd_validate.py");
    let check = Command::new("python3")
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
    assert_eq!(report.matches(": ok").count(), 3, "{report}");
}
