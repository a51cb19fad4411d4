//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Runs the `rift` binary with `args` in `cwd`.
pub fn rift(cwd: &Path, args: &[&str]) -> Output {
    rift_env(cwd, args, &[])
}

/// [`rift`] with the environment variables `env` set.
pub fn rift_env(cwd: &Path, args: &[&str], env: &[(&str, &Path)]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rift"))
        .args(args)
        .current_dir(cwd)
        .envs(env.iter().copied())
        .output()
        .expect("the rift binary runs")
}

/// Standard error as text.
pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Every file below `dir`, sorted.
pub fn files_in(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    if let Ok(entries) = std::fs::read_dir(dir) {
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                out.extend(files_in(&p));
            } else {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// Copies the Cornell example (its shot, edited by `edit`, as `shot.toml`, and its meshes) into a
/// temporary directory.
pub fn cornell_dir(edit: impl Fn(String) -> String) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for f in ["cornell.obj", "cornell.mtl"] {
        std::fs::copy(root().join("examples").join(f), dir.path().join(f)).unwrap();
    }
    let text = std::fs::read_to_string(root().join("examples/cornell.toml")).unwrap();
    std::fs::write(dir.path().join("shot.toml"), edit(text)).unwrap();
    dir
}

/// Runs `rift fx SHOT --frames 1001-1003 -o o` plus `extra` in `dir`, asserts success and returns
/// the files written.
pub fn fx_frames(dir: &Path, shot: &Path, extra: &[&str]) -> Vec<PathBuf> {
    let mut args = vec![
        "fx",
        shot.to_str().unwrap(),
        "--frames",
        "1001-1003",
        "-o",
        "o",
    ];
    args.extend_from_slice(extra);
    let out = rift(dir, &args);
    assert!(out.status.success(), "{}", stderr(&out));
    files_in(&dir.join("o"))
}

/// Largest difference between two EXRs over every channel, relative to max(|value|, 1e-3).
pub fn largest_difference(a: &Path, b: &Path) -> f64 {
    let read = |p: &Path| rift_render::frame::film::read_exr_layer(p).unwrap();
    let (a, b) = (read(a), read(b));
    assert_eq!((a.position, a.size), (b.position, b.size), "data windows");
    assert_eq!(
        a.channels.keys().collect::<Vec<_>>(),
        b.channels.keys().collect::<Vec<_>>()
    );
    let mut worst = 0.0f64;
    for (name, x) in &a.channels {
        for (u, v) in x.iter().zip(&b.channels[name]) {
            let d = (*u as f64 - *v as f64).abs() / (u.abs() as f64).max(1e-3);
            worst = worst.max(d);
        }
    }
    worst
}

/// Starts rift with `args` in `dir`, its standard error piped.
pub fn start(dir: &Path, args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_rift"))
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Waits until a render started by `start` reports progress (a line with `%`), so that it is
/// past setting up and has samples to save; the rest of its standard error is collected.
pub fn wait_for_progress(child: &mut Child) -> std::thread::JoinHandle<String> {
    use std::io::BufRead;
    let stderr = child.stderr.take().unwrap();
    let mut lines = std::io::BufReader::new(stderr).lines();
    let seen = lines
        .by_ref()
        .map_while(Result::ok)
        .any(|l| l.contains('%'));
    assert!(seen, "the render ended without reporting progress");
    std::thread::spawn(move || lines.map_while(Result::ok).collect::<Vec<_>>().join("\n"))
}

/// Sends `signal` (by name) to a child process.
pub fn signal(child: &Child, signal: &str) {
    let ok = Command::new("kill")
        .args([&format!("-{signal}"), &child.id().to_string()])
        .status()
        .unwrap();
    assert!(ok.success());
}

/// The test suite's own Python environment, which `tests/setup.sh` makes from
/// `tests/requirements.txt` alone.
pub fn python_env() -> PathBuf {
    root().join("tests/.venv")
}

/// A command of the suite's Python environment (`python3`, or a console script such as
/// `openjd`), never one from the machine's PATH: a package installed there by hand must not
/// hide a line missing from `tests/requirements.txt`. Panics with how to make the environment
/// when it is missing.
pub fn python_command(program: &str) -> Command {
    let path = python_env().join("bin").join(program);
    assert!(
        path.exists(),
        "{} is missing: run tests/setup.sh, which makes the suite's Python environment from \
         tests/requirements.txt",
        path.display()
    );
    Command::new(path)
}
