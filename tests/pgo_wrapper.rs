//! The rustc wrapper that gives optimised builds the training profile (`pgo/rustc-wrapper`,
//! named by `.cargo/config.toml`): which compilations get `-Cprofile-use`, and that the path it
//! adds is absolute and names the committed profile. `echo` stands in for rustc, so the test
//! reads the command line the wrapper would run.

use crate::common;

use common::root;
use std::process::Command;

/// The arguments the wrapper passes on to "rustc" (`echo`) for `args`.
fn passed_on(args: &[&str]) -> Vec<String> {
    let out = Command::new(root().join("pgo/rustc-wrapper"))
        .arg("echo")
        .args(args)
        .output()
        .expect("run pgo/rustc-wrapper");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout)
        .unwrap()
        .split_whitespace()
        .map(str::to_owned)
        .collect()
}

fn profile_flag(args: &[String]) -> Option<&str> {
    args.iter().find_map(|a| a.strip_prefix("-Cprofile-use="))
}

#[test]
fn cargo_runs_rustc_through_the_wrapper() {
    let config = std::fs::read_to_string(root().join(".cargo/config.toml")).unwrap();
    assert!(
        config.contains("rustc-wrapper = \"pgo/rustc-wrapper\""),
        "{config}"
    );
}

#[test]
fn optimised_compilations_get_the_committed_profile_by_absolute_path() {
    for level in [["-C", "opt-level=3"].as_slice(), &["-Copt-level=2"]] {
        let mut args = vec!["--crate-name", "rift_render", "render/src/lib.rs"];
        args.extend_from_slice(level);
        let passed = passed_on(&args);
        let profile = profile_flag(&passed).unwrap_or_else(|| panic!("{level:?}: {passed:?}"));
        let path = std::path::Path::new(profile);
        assert!(path.is_absolute(), "{profile}");
        assert_eq!(
            path.canonicalize().unwrap(),
            root().join("pgo/rift.profdata").canonicalize().unwrap()
        );
        assert!(
            passed
                .iter()
                .any(|a| a == "-Cllvm-args=-no-pgo-warn-mismatch")
        );
        // The compilation's own arguments come first, unchanged.
        assert_eq!(&passed[..args.len()], args.as_slice());
    }
}

#[test]
fn other_compilations_are_passed_on_unchanged() {
    let cases: [&[&str]; 4] = [
        // Unoptimised.
        &["--crate-name", "rift", "-C", "opt-level=0", "src/main.rs"],
        // The training build itself.
        &[
            "-C",
            "opt-level=3",
            "-Cprofile-generate=/tmp/raw",
            "src/main.rs",
        ],
        // Nightly builds with -Z flags (the fuzz targets' sanitizers).
        &["-C", "opt-level=3", "-Zsanitizer=address", "fuzz/a.rs"],
        // A query, not a compilation.
        &["-", "--print=cfg"],
    ];
    for args in cases {
        assert_eq!(passed_on(args), args, "{args:?}");
    }
}
