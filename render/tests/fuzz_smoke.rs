//! A short coverage-guided run of every fuzz target, where the nightly toolchain is installed.
//! Long campaigns are run by hand with cargo-fuzz: `cd fuzz && cargo +nightly fuzz run -O -a
//! TARGET`. Anything it finds is a failure; the input that found it goes into
//! `fuzz/regressions/TARGET/` once fixed.
//!
//! The build is the long part: `fuzz/build_smoke.sh` makes it (cargo-fuzz's instrumentation
//! without cargo-fuzz, whose own build a fresh machine would add), and `tests/setup.sh` starts it
//! in the background at the lowest priority, so that it takes the processor time the main build
//! and the earlier tests leave idle (the browser tests leave much); this test, among the last the
//! test command runs, runs the same script, which then waits for that build (cargo's lock on the
//! build folder) instead of building from scratch.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Seconds each target runs for.
const SECONDS: u32 = 4;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

#[test]
fn each_fuzz_target_runs_briefly_without_a_finding() {
    let nightly = Command::new("cargo")
        .args(["+nightly", "--version"])
        .output();
    if !nightly.is_ok_and(|o| o.status.success()) {
        eprintln!("skipped: no nightly toolchain (libFuzzer's instrumentation needs one)");
        return;
    }
    let fuzz = root().join("fuzz");
    // Building needs what libFuzzer needs (a C++ compiler); a machine without it skips, while
    // the targets' code itself is built and tested on stable by the other tests.
    let build = Command::new(fuzz.join("build_smoke.sh")).output().unwrap();
    if !build.status.success() {
        let log = String::from_utf8_lossy(&build.stderr);
        let tail: Vec<&str> = log.lines().rev().take(15).collect();
        eprintln!(
            "skipped: the fuzz targets do not build here:\n{}",
            tail.join("\n")
        );
        return;
    }
    let built = PathBuf::from(String::from_utf8_lossy(&build.stdout).trim());
    let work = tempfile::tempdir().unwrap();
    // The targets run on every core at once (two on the CI machines): each libFuzzer run is
    // one process on one core.
    let targets: Vec<&str> = rift_render::untrusted::TARGETS
        .iter()
        .map(|t| t.0)
        .collect();
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let next = AtomicUsize::new(0);
    let outcomes = Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..cores.min(targets.len()) {
            scope.spawn(|| {
                while let Some(&target) = targets.get(next.fetch_add(1, Ordering::Relaxed)) {
                    let outcome = fuzz_briefly(&fuzz, &built, work.path(), target);
                    outcomes.lock().unwrap().push((target, outcome));
                }
            });
        }
    });
    let mut outcomes = outcomes.into_inner().unwrap();
    outcomes.sort_by_key(|(target, _)| *target);
    let mut findings = Vec::new();
    for (target, outcome) in outcomes {
        match outcome {
            Ok(runs) => eprintln!("{target}: {runs} runs in {SECONDS} s, no finding"),
            Err(tail) => findings.push(format!("fuzz target {target} found something:\n{tail}")),
        }
    }
    assert!(findings.is_empty(), "{}", findings.join("\n\n"));
}

/// Runs `target` (its binary in `built`) for [`SECONDS`] from its committed corpus and
/// regressions, new inputs going to a scratch folder under `work`: the number of runs, or what
/// its log says it found, with how to reproduce it.
fn fuzz_briefly(fuzz: &Path, built: &Path, work: &Path, target: &str) -> Result<String, String> {
    // New inputs go to a scratch folder; the committed seed corpus stays as it is.
    let scratch = work.join(target);
    std::fs::create_dir(&scratch).unwrap();
    // Findings are kept (fuzz/artifacts is not committed) to be reproduced and fixed.
    let artifacts = fuzz.join("artifacts").join(target);
    std::fs::create_dir_all(&artifacts).unwrap();
    // The inputs that once crashed a target run here too.
    let regressions = Some(fuzz.join("regressions").join(target)).filter(|d| d.is_dir());
    let out = Command::new(built.join(target))
        .arg(&scratch)
        .arg(fuzz.join("corpus").join(target))
        .args(regressions)
        .args([
            format!("-max_total_time={SECONDS}"),
            "-rss_limit_mb=2048".into(),
            "-malloc_limit_mb=1024".into(),
            "-timeout=10".into(),
            format!("-artifact_prefix={}/", artifacts.display()),
        ])
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        return Err(format!(
            "{}\nreproduce: cd fuzz && cargo +nightly fuzz run {target} <the input written above>",
            what_it_found(&log)
        ));
    }
    let runs = log
        .lines()
        .rev()
        .find_map(|l| l.strip_prefix("Done ").and_then(|r| r.split(' ').next()))
        .unwrap_or("?");
    Ok(runs.to_owned())
}

/// The lines of a failed run's log that say what happened: the panic and its message,
/// libFuzzer's and the sanitizer's verdicts, and how to reproduce it (the input's own dump,
/// one line of up to megabytes, left out); the log's last lines when none of them is there.
fn what_it_found(log: &str) -> String {
    const MARKS: [&str; 4] = ["panicked at", "ERROR:", "SUMMARY:", "Test unit written to"];
    let lines: Vec<&str> = log.lines().collect();
    let mut kept = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        if MARKS.iter().any(|m| line.contains(m)) {
            kept.push(*line);
            if line.contains("panicked at") {
                kept.extend(lines.get(i + 1));
            }
        }
    }
    if kept.is_empty() {
        kept = lines[lines.len().saturating_sub(30)..].to_vec();
    }
    kept.iter()
        .map(|l| l.chars().take(300).collect::<String>())
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn a_finding_is_reported_by_its_panic_and_how_to_reproduce_it() {
    let dump = format!("\t[{}]", vec!["0"; 50_000].join(", "));
    let log = [
        "INFO: Running with entropic power schedule",
        "thread '<unnamed>' (22747) panicked at render/src/vdb/tree.rs:99:43:",
        "attempt to multiply with overflow",
        "==22747== ERROR: libFuzzer: deadly signal",
        "    #0 0x55a60c09cd91 in __sanitizer_print_stack_trace",
        "SUMMARY: libFuzzer: deadly signal",
        "MS: 1 ChangeByte-; base unit: 5a1b",
        &dump,
        "artifact_prefix='fuzz/artifacts/vdb/'; Test unit written to fuzz/artifacts/vdb/crash-68a4",
        "Base64: AAAA",
    ]
    .join("\n");
    let found = what_it_found(&log);
    assert_eq!(
        found.lines().collect::<Vec<_>>(),
        [
            "thread '<unnamed>' (22747) panicked at render/src/vdb/tree.rs:99:43:",
            "attempt to multiply with overflow",
            "==22747== ERROR: libFuzzer: deadly signal",
            "SUMMARY: libFuzzer: deadly signal",
            "artifact_prefix='fuzz/artifacts/vdb/'; Test unit written to fuzz/artifacts/vdb/crash-68a4",
        ]
    );
    // A log without any of those ends in its last lines, each cut short.
    let other = what_it_found(&format!("one\ntwo\n{dump}"));
    assert!(
        other.starts_with("one\ntwo\n\t[0, 0") && other.len() < 320,
        "{other}"
    );
}
