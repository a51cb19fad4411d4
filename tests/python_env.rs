//! The suite's Python environment holds what its scripts import, and only because
//! `tests/requirements.txt` says so: every module a script of `tests/support` imports comes
//! from Python itself or from a distribution a requirement line names
//! (`tests/support/requirements_check.py`). A package that arrived as another's dependency, or
//! was installed by hand, does not count, so a fresh machine gets everything the scripts need.

use crate::common;

use common::{python_command, root};
use std::path::{Path, PathBuf};
use std::process::Output;

/// The Python scripts the tests run, the checker itself aside.
fn support_scripts() -> Vec<PathBuf> {
    let mut scripts: Vec<PathBuf> = std::fs::read_dir(root().join("tests/support"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "py"))
        .filter(|p| !p.ends_with("requirements_check.py"))
        .collect();
    scripts.sort();
    scripts
}

/// The checker run on `requirements` and `scripts`.
fn check(requirements: &Path, scripts: &[PathBuf]) -> Output {
    python_command("python3")
        .arg(root().join("tests/support/requirements_check.py"))
        .arg(requirements)
        .args(scripts)
        .output()
        .unwrap()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

#[test]
fn every_module_the_test_scripts_import_has_its_requirement_line() {
    let scripts = support_scripts();
    assert!(scripts.len() >= 3, "{scripts:?}");
    let out = check(&root().join("tests/requirements.txt"), &scripts);
    let report = text(&out.stdout);
    assert!(out.status.success(), "{report}{}", text(&out.stderr));
    // The modules the scripts need beyond Python's own, each from the line that provides it.
    for provided in [
        "usd_validate.py: pxr: usd-core",
        "usd_stage_check.py: OpenEXR: openexr",
        "usd_stage_check.py: numpy: numpy",
        "usd_stage_check.py: pxr: usd-core",
    ] {
        assert!(report.contains(provided), "{provided:?} in\n{report}");
    }
}

#[test]
fn a_module_without_its_requirement_line_is_named() {
    let dir = tempfile::tempdir().unwrap();
    // The requirements without OpenEXR's line: the state in which the shot stage check once
    // passed only where someone had installed OpenEXR by hand.
    let full = std::fs::read_to_string(root().join("tests/requirements.txt")).unwrap();
    let without: String = full
        .lines()
        .filter(|l| !l.starts_with("OpenEXR"))
        .map(|l| format!("{l}\n"))
        .collect();
    assert!(without.len() < full.len(), "OpenEXR's line was not found");
    let requirements = dir.path().join("requirements.txt");
    std::fs::write(&requirements, without).unwrap();
    let stage_check = root().join("tests/support/usd_stage_check.py");
    let out = check(&requirements, &[stage_check]);
    assert!(!out.status.success());
    let errors = text(&out.stderr);
    assert!(
        errors.contains("module OpenEXR is installed by openexr, which no line names"),
        "{errors}"
    );

    // A module that another package brings along (PyYAML, for the OpenJD CLI) is refused too,
    // and so is one installed by nothing.
    let script = dir.path().join("script.py");
    std::fs::write(
        &script,
        "import os\nimport yaml\nfrom rift_no_such_module import x\n",
    )
    .unwrap();
    let out = check(&root().join("tests/requirements.txt"), &[script]);
    assert!(!out.status.success());
    let errors = text(&out.stderr);
    assert!(
        errors.contains("module yaml is installed by pyyaml"),
        "{errors}"
    );
    assert!(
        errors.contains("module rift_no_such_module is not installed"),
        "{errors}"
    );
    assert!(!errors.contains("module os "), "{errors}");
}
