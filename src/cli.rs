//! What the commands share: checked option values, the output directory made ready before
//! any work starts, and the thread pool a command runs on.

use anyhow::{Context, bail};
use std::path::Path;

/// `--res W H`, checked.
pub fn parse_res(res: &[u32]) -> anyhow::Result<[u32; 2]> {
    match res {
        &[w, h] if (1..=65536).contains(&w) && (1..=65536).contains(&h) => Ok([w, h]),
        _ => bail!("--res: expected a width and height from 1 to 65536 pixels"),
    }
}

/// Creates `dir` and checks that files can be created in it, before any work starts.
pub fn prepare_output_dir(dir: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("{}: cannot create the output directory", dir.display()))?;
    let probe = dir.join(format!(".rift-write-test-{}", std::process::id()));
    std::fs::write(&probe, b"")
        .with_context(|| format!("{}: the output directory is not writable", dir.display()))?;
    let _ = std::fs::remove_file(probe);
    Ok(())
}

/// Runs `f` on a rayon pool of `threads` threads (all cores when `None`).
pub fn with_threads<T: Send>(
    threads: Option<usize>,
    f: impl FnOnce() -> T + Send,
) -> anyhow::Result<T> {
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = threads {
        anyhow::ensure!(n > 0, "--threads: expected a positive number");
        builder = builder.num_threads(n);
    }
    Ok(builder.build()?.install(f))
}

/// Reads and checks the shot file at `path`, with its USD camera read where `[camera] usd`
/// names one (what is read otherwise than USD says goes to standard error under `command`).
pub fn load_shot(path: &std::path::Path, command: &str) -> anyhow::Result<rift_fx::Shot> {
    with_usd_camera(rift_fx::Shot::load(path)?, command)
}

/// `shot` with the USD camera its `[camera] usd` names read in (a shot with a camera of its own
/// as it is).
pub fn with_usd_camera(mut shot: rift_fx::Shot, command: &str) -> anyhow::Result<rift_fx::Shot> {
    let budget = crate::memory::budget(None);
    for warning in rift_render::scene::usd::camera::read_camera(&mut shot, budget)? {
        eprintln!("rift {command}: warning: {warning}");
    }
    Ok(shot)
}
