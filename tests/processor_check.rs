//! `tests/processor_check.sh`, which `tests/setup.sh` runs so that a processor older than the
//! optimised builds' target (x86-64-v3) gets a clear refusal rather than test binaries dying
//! with SIGILL: fed `cpuinfo` files lacking one feature each, it must name that feature and the
//! build for any x86-64; it passes this machine, and any processor when RUSTFLAGS picks the
//! target.

use crate::common;

use common::{root, stderr};
use std::path::Path;
use std::process::{Command, Output};

/// What x86-64-v3 needs, by Linux's names, among a few features it does not.
const V3_FEATURES: [&str; 11] = [
    "avx", "avx2", "bmi1", "bmi2", "fma", "f16c", "movbe", "abm", "popcnt", "sse4_2", "xsave",
];

/// The check run on `cpuinfo` (this machine's when `None`), with `rustflags` as RUSTFLAGS.
fn run(cpuinfo: Option<&Path>, rustflags: Option<&str>) -> Output {
    let mut command = Command::new(root().join("tests/processor_check.sh"));
    command
        .args(cpuinfo)
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_ENCODED_RUSTFLAGS");
    if let Some(rustflags) = rustflags {
        command.env("RUSTFLAGS", rustflags);
    }
    command.output().expect("run tests/processor_check.sh")
}

/// The check run on a `cpuinfo` file holding `text`, with `rustflags` as RUSTFLAGS.
fn run_on(text: &str, rustflags: Option<&str>) -> Output {
    let dir = tempfile::tempdir().unwrap();
    let cpuinfo = dir.path().join("cpuinfo");
    std::fs::write(&cpuinfo, text).unwrap();
    run(Some(&cpuinfo), rustflags)
}

/// The check run on a `cpuinfo` file whose flags are `flags`, with `rustflags` as RUSTFLAGS.
fn check(flags: &[&str], rustflags: Option<&str>) -> Output {
    let text = format!(
        "processor\t: 0\nflags\t\t: fpu sse sse2 {} hypervisor\n",
        flags.join(" ")
    );
    run_on(&text, rustflags)
}

#[test]
fn a_processor_lacking_a_feature_is_refused_by_name() {
    assert!(check(&V3_FEATURES, None).status.success());
    for missing in V3_FEATURES {
        let flags: Vec<&str> = V3_FEATURES.into_iter().filter(|&f| f != missing).collect();
        let out = check(&flags, None);
        let said = stderr(&out);
        if cfg!(target_arch = "x86_64") {
            assert_eq!(out.status.code(), Some(1), "without {missing}: {said}");
            assert!(
                said.contains(&format!("lacks {missing},"))
                    && said.contains("RUSTFLAGS=\"-C target-cpu=x86-64\""),
                "without {missing}: {said}"
            );
        } else {
            assert!(out.status.success(), "not x86-64: the check passes");
        }
    }
}

#[test]
fn rustflags_choosing_the_target_pass_any_processor() {
    let old = check(&["sse4_2", "popcnt"], Some("-C target-cpu=x86-64"));
    assert!(old.status.success(), "{}", stderr(&old));
}

/// A cpuinfo without a flags line gives nothing to judge by: the check passes, as it does
/// without the file, rather than stopping the test command with no word.
#[test]
fn a_cpuinfo_without_flags_passes() {
    let out = run_on("processor\t: 0\nmodel name\t: unknown\n", None);
    assert!(out.status.success(), "{}", stderr(&out));
}

/// A test binary built for x86-64-v3 is running here, so this processor has what the check
/// asks for. (A baseline build, for an older processor, has nothing to check this way.)
#[test]
fn this_machine_passes() {
    if !cfg!(target_feature = "avx2") {
        eprintln!("skipped: this build targets the x86-64 baseline");
        return;
    }
    let out = run(None, None);
    assert!(out.status.success(), "{}", stderr(&out));
}
