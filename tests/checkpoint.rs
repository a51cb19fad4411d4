//! Renders that survive being killed: `rift render --checkpoint S` and `--resume`. A render
//! killed with SIGKILL at random moments and resumed, or stopped by SIGTERM / SIGINT and
//! resumed, finishes with exactly the pixels of an uninterrupted render; checkpoints of
//! anything else are refused; a full disk leaves no partial image.

use crate::common;

use common::{files_in, largest_difference, rift, root, signal, start, stderr, wait_for_progress};
use rift_render::frame::film::read_exr_layer;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

const SPP: &str = "64";

/// `lit_through` (with `extra` appended) as `shot.toml` in `dir`, its meshes read through a
/// link `dir/assets` to the examples' assets (made if missing).
fn shot_in(dir: &Path, extra: &str) -> PathBuf {
    let assets = dir.join("assets");
    if !assets.exists() {
        std::os::unix::fs::symlink(root().join("examples/assets"), &assets).unwrap();
    }
    let text = std::fs::read_to_string(root().join("examples/shots/lit_through.toml"))
        .unwrap()
        .replace("../assets/", "assets/");
    let path = dir.join("shot.toml");
    std::fs::write(&path, text + extra).unwrap();
    path
}

fn render_args<'a>(shot: &'a Path, out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec!["render", shot.to_str().unwrap(), "-o", out, "--spp", SPP];
    if !extra.contains(&"--res") {
        args.extend(["--res", "96", "54"]);
    }
    args.extend_from_slice(extra);
    args
}

/// Mean samples per pixel a checkpoint holds (it is a readable image with an `spp` channel).
fn checkpoint_spp(path: &Path) -> f64 {
    let layer = read_exr_layer(path).unwrap();
    for c in ["R", "G", "B", "A", "spp"] {
        assert!(layer.channels.contains_key(c), "checkpoint lacks {c}");
    }
    let spp = &layer.channels["spp"];
    spp.iter().map(|&v| v as f64).sum::<f64>() / spp.len() as f64
}

/// Every channel of two EXRs holds the same bits.
fn assert_identical(a: &Path, b: &Path) {
    let worst = largest_difference(a, b);
    assert!(
        worst == 0.0,
        "{} differs from {} by {worst:e}",
        b.display(),
        a.display()
    );
}

/// A seed for the kill moments that differs run to run, printed so a failure can be replayed.
fn random_seed() -> u64 {
    std::env::var("RIFT_TEST_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .unwrap()
                .subsec_nanos() as u64
        })
}

#[test]
fn killed_three_times_at_random_and_resumed_equals_one_render() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let shot = shot_in(d, "");
    let begun = Instant::now();
    let whole = rift(d, &render_args(&shot, "whole.exr", &[]));
    assert!(whole.status.success(), "{}", stderr(&whole));
    let whole_seconds = begun.elapsed().as_secs_f64();
    let seed = random_seed();
    let mut state = seed | 1;
    let mut uniform = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let resumable = render_args(&shot, "out.exr", &["--checkpoint", "0.05", "--resume"]);
    let mut progress = Vec::new();
    for _ in 0..3 {
        // A random moment once the render is under way (setting up takes longer on a busy
        // machine than the whole render's share suggests).
        let wait = whole_seconds * (0.05 + 0.2 * uniform());
        let mut child = start(d, &resumable);
        let _rest = wait_for_progress(&mut child);
        std::thread::sleep(Duration::from_secs_f64(wait));
        signal(&child, "KILL");
        child.wait().unwrap();
        let checkpoint = d.join("out.checkpoint.exr");
        progress.push((
            wait,
            checkpoint.exists().then(|| checkpoint_spp(&checkpoint)),
        ));
    }
    let saved: Vec<f64> = progress.iter().filter_map(|p| p.1).collect();
    assert!(
        saved.len() >= 2 && saved.iter().all(|&s| s > 0.0 && s < 64.0),
        "seed {seed}: the kills should land mid-render with a checkpoint saved: {progress:?}"
    );
    assert!(
        !d.join("out.exr").exists(),
        "a killed render wrote its image"
    );
    let last = rift(d, &resumable);
    assert!(last.status.success(), "{}", stderr(&last));
    assert!(
        !d.join("out.checkpoint.exr").exists(),
        "the checkpoint outlived its frame"
    );
    assert_identical(&d.join("whole.exr"), &d.join("out.exr"));
}

#[test]
fn sigterm_and_sigint_stop_cleanly_and_the_render_resumes_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let shot = shot_in(d, "");
    // Adaptive sampling too: which pixels stop depends on passes that a resume must continue;
    // and bounces aimed at openings, whose guide the resumed render learns again.
    let flags = ["--target-error", "0.02", "--guide-through-openings"];
    let whole = rift(d, &render_args(&shot, "whole.exr", &flags));
    assert!(whole.status.success(), "{}", stderr(&whole));
    let mut args = render_args(&shot, "out.exr", &flags);
    args.extend(["--checkpoint", "60", "--resume"]);
    for (name, code) in [("TERM", 143), ("INT", 130)] {
        let mut child = start(d, &args);
        let rest = wait_for_progress(&mut child);
        signal(&child, name);
        let status = child.wait().unwrap();
        let msg = rest.join().unwrap();
        assert_eq!(status.code(), Some(code), "SIG{name}: {msg}");
        assert!(
            msg.contains("--resume") && !msg.contains("panicked"),
            "{msg}"
        );
        let saved = checkpoint_spp(&d.join("out.checkpoint.exr"));
        assert!(saved > 0.0 && saved < 64.0, "SIG{name}: {saved} spp saved");
        assert!(!d.join("out.exr").exists());
    }
    let last = rift(d, &args);
    assert!(last.status.success(), "{}", stderr(&last));
    assert_identical(&d.join("whole.exr"), &d.join("out.exr"));
}

/// Stops a render of `shot` with SIGTERM so that `out.checkpoint.exr` is left in `dir`.
fn leave_checkpoint(dir: &Path, shot: &Path) {
    let mut child = start(dir, &render_args(shot, "out.exr", &["--checkpoint", "60"]));
    wait_for_progress(&mut child);
    signal(&child, "TERM");
    assert_eq!(child.wait().unwrap().code(), Some(143));
}

/// A resume that must be refused: exit 1, the checkpoint named, `expect` in the message, the
/// checkpoint kept and no image written.
fn expect_refused(dir: &Path, program: &Path, args: &[&str], expect: &str) {
    let out = Command::new(program)
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap();
    let msg = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{args:?}: {msg}");
    assert!(
        msg.contains("out.checkpoint.exr") && msg.contains(expect),
        "{args:?}: {msg:?} lacks {expect:?}"
    );
    assert!(dir.join("out.checkpoint.exr").exists());
    assert!(!dir.join("out.exr").exists());
}

#[test]
fn checkpoints_of_anything_else_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let shot = shot_in(d, "");
    leave_checkpoint(d, &shot);
    let rift_exe = PathBuf::from(env!("CARGO_BIN_EXE_rift"));
    // A checkpoint's header is checked before the scene is prepared (minutes on a production
    // set): with the shot's meshes gone, each refusal still names the checkpoint.
    let hide_assets = || std::fs::remove_file(d.join("assets")).unwrap();
    hide_assets();
    for (extra, expect) in [
        (&["--seed", "9"][..], "seed 0 (now 9)"),
        (&["--res", "80", "54"][..], "res 96x54 (now 80x54)"),
        (&["--max-portal-depth", "1"][..], "max_portal_depth"),
        (
            &["--guide-through-openings"][..],
            "guide_through_openings false (now true)",
        ),
    ] {
        let mut extra = extra.to_vec();
        extra.push("--resume");
        expect_refused(d, &rift_exe, &render_args(&shot, "out.exr", &extra), expect);
    }
    // Another shot, and this shot edited since the checkpoint.
    let other = root().join("examples/shots/portal_pair.toml");
    let args = render_args(&other, "out.exr", &["--resume"]);
    expect_refused(d, &rift_exe, &args, "belongs to shot `lit_through`");
    shot_in(d, "\n# edited\n");
    hide_assets();
    let args = render_args(&shot, "out.exr", &["--resume"]);
    expect_refused(d, &rift_exe, &args, "has changed");
    shot_in(d, "");
    hide_assets();
    // Another build of rift: the same program with one byte more.
    let mut exe = std::fs::read(&rift_exe).unwrap();
    exe.push(0);
    let other_build = d.join("rift-other");
    std::fs::write(&other_build, exe).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&other_build, std::fs::Permissions::from_mode(0o755)).unwrap();
    expect_refused(d, &other_build, &args, "another build");
    // The rest are refused once the scene is ready, as the sums are read.
    shot_in(d, "");
    // A truncated checkpoint, and an image that is not a checkpoint.
    let checkpoint = d.join("out.checkpoint.exr");
    let bytes = std::fs::read(&checkpoint).unwrap();
    std::fs::write(&checkpoint, &bytes[..bytes.len() / 2]).unwrap();
    expect_refused(d, &rift_exe, &args, "cannot read");
    let plain = rift(d, &render_args(&shot, "plain.exr", &[]));
    assert!(plain.status.success(), "{}", stderr(&plain));
    std::fs::rename(d.join("plain.exr"), &checkpoint).unwrap();
    expect_refused(d, &rift_exe, &args, "not a checkpoint");
    // A FIFO in the checkpoint's place is refused at once, not read for ever.
    std::fs::remove_file(&checkpoint).unwrap();
    assert!(
        sh(&format!("mkfifo '{}'", checkpoint.display()))
            .status
            .success()
    );
    expect_refused(d, &rift_exe, &args, "not a regular file");
}

/// Runs `script` (sh) and returns its output.
fn sh(script: &str) -> std::process::Output {
    Command::new("sh").args(["-c", script]).output().unwrap()
}

#[test]
fn a_write_that_fails_halfway_leaves_no_partial_image() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let shot = shot_in(d, "");
    let exe = env!("CARGO_BIN_EXE_rift");
    let render = format!(
        "{exe} render {} -o {}/out/x.exr --res 96 54 --spp 2 --checkpoint 0.01",
        shot.display(),
        d.display()
    );
    // Files larger than 40 KiB cannot be written (the signal that would kill the process is
    // ignored, so the write fails with an error instead).
    let out = sh(&format!("trap '' XFSZ; ulimit -f 40; exec {render}"));
    let msg = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{msg}");
    assert!(
        msg.contains("x.exr") && msg.contains("cannot write"),
        "{msg}"
    );
    assert!(!msg.contains("panicked"), "{msg}");
    assert!(
        files_in(&d.join("out")).is_empty(),
        "{:?}",
        files_in(&d.join("out"))
    );

    // A real full disk: a 64 KiB tmpfs in a mount namespace of its own, where the machine
    // lets the test mount one (as root).
    let full = d.join("full");
    std::fs::create_dir(&full).unwrap();
    let script = format!(
        "mount -t tmpfs -o size=64k tmpfs {f} || exit 77; {exe} render {} -o {f}/x.exr --res 96 54 \
         --spp 2 --checkpoint 0.01; echo \"exit $?\"; ls -a {f}",
        shot.display(),
        f = full.display()
    );
    let out = Command::new("unshare")
        .args(["-m", "sh", "-c", &script])
        .output();
    match out {
        Ok(out) if out.status.code() != Some(77) && out.status.success() => {
            let listing = String::from_utf8_lossy(&out.stdout);
            let msg = stderr(&out);
            assert!(listing.contains("exit 1"), "{listing} {msg}");
            assert!(
                msg.contains("x.exr") && msg.contains("No space left"),
                "{msg}"
            );
            let files: Vec<&str> = listing
                .lines()
                .skip(1)
                .filter(|l| !l.starts_with('.'))
                .collect();
            assert!(files.is_empty(), "left on the full disk: {files:?}");
            assert!(
                !listing.contains(".tmp"),
                "a temporary file was left: {listing}"
            );
        }
        _ => eprintln!("skipped the full-disk half: this machine cannot mount a tmpfs here"),
    }
}
