//! Renders that survive being killed: where a frame's checkpoint lives, the key that ties it
//! to one build, shot and set of settings, and the stop that SIGINT / SIGTERM ask for.
//!
//! A farm task is killed without warning (SIGKILL on preemption) or asked to stop (SIGTERM,
//! Ctrl-C). With `--checkpoint S` the render's sums are saved every S seconds and when a stop
//! is asked for; `--resume` continues from them, and the finished frame has exactly the pixels
//! of an uninterrupted render.

use rift_fx::export::cache::fnv1a;
use rift_render::frame::checkpoint::Key;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// Set by the first SIGINT or SIGTERM; a second one ends the process at once.
static STOP: AtomicBool = AtomicBool::new(false);
/// The signal that set `STOP`.
static SIGNAL: AtomicUsize = AtomicUsize::new(0);

/// Asks SIGINT and SIGTERM to stop the render cleanly (its checkpoint written) instead of
/// killing the process; a second signal kills it (exit 128 + signal). Returns the stop flag.
pub fn stop_on_signals() -> anyhow::Result<&'static AtomicBool> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    use signal_hook::flag;
    for signal in [SIGINT, SIGTERM] {
        // The order matters: the exit is armed only once an earlier signal set the flag.
        flag::register_conditional_shutdown(signal, 128 + signal, &STOP)?;
        flag::register_usize(signal, &SIGNAL, signal as usize)?;
        flag::register(signal, &STOP)?;
    }
    Ok(&STOP)
}

/// Whether a stop was asked for.
pub fn stop_requested() -> bool {
    STOP.load(Ordering::SeqCst)
}

/// A render ended early by a signal, after saving its checkpoint; the process exits with
/// 128 + the signal, as a shell reports a signal's end.
#[derive(Debug)]
pub struct Interrupted {
    pub message: String,
}

impl Interrupted {
    pub fn exit_code(&self) -> u8 {
        (128 + SIGNAL.load(Ordering::SeqCst)).min(255) as u8
    }
}

impl std::fmt::Display for Interrupted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Interrupted {}

/// The checkpoint of the image `output`: `a.0001.exr` → `a.0001.checkpoint.exr`.
pub fn checkpoint_path(output: &Path) -> PathBuf {
    let name = output
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let stem = name.strip_suffix(".exr").unwrap_or(&name);
    output.with_file_name(format!("{stem}.checkpoint.exr"))
}

/// The key of a render of `shot_file` (named `shot`) with `settings`.
pub fn key(shot_file: &Path, shot: &str, settings: Vec<(String, String)>) -> anyhow::Result<Key> {
    let bytes = rift_fx::io::read(shot_file)?;
    Ok(Key {
        build: build_id().to_owned(),
        shot: shot.to_owned(),
        shot_hash: format!("{:016x}", fnv1a(&bytes)),
        settings,
    })
}

/// This program: its version and a hash of its executable, read once.
fn build_id() -> &'static str {
    static ID: OnceLock<String> = OnceLock::new();
    ID.get_or_init(|| {
        let exe = std::env::current_exe().map(|path| rift_fx::io::read(&path));
        let hash = match exe {
            Ok(Ok(bytes)) => format!("{:016x}", fnv1a(&bytes)),
            _ => "unknown".to_owned(),
        };
        format!("rift {} {hash}", env!("CARGO_PKG_VERSION"))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checkpoints_sit_beside_their_image() {
        assert_eq!(
            checkpoint_path(Path::new("out/a.0001.exr")),
            Path::new("out/a.0001.checkpoint.exr")
        );
        assert_eq!(
            checkpoint_path(Path::new("a")),
            Path::new("a.checkpoint.exr")
        );
    }
}
