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

/// `--denoise` and its quality, for `rift render` and `rift merge`.
#[derive(clap::Args, Clone, Copy)]
pub struct DenoiseArgs {
    /// Denoise the finished frame with Intel Open Image Denoise (its ray-tracing filter, the
    /// albedo and normal AOVs cleaned first and used as guides); the noisy beauty is kept as
    /// the EXR layer `noisy`, and light groups and the through-openings layers still sum to
    /// the beauty. Needs OIDN 2 (`python3 -m pip install pyoidn`, or RIFT_OIDN_LIBRARY).
    #[arg(long)]
    pub denoise: bool,
    /// OIDN's quality: `high` for final frames, `balanced`, `fast` for previews.
    #[arg(long, value_enum, default_value_t = DenoiseQuality::High)]
    pub denoise_quality: DenoiseQuality,
}

/// `--denoise-quality`.
#[derive(Clone, Copy, clap::ValueEnum)]
pub enum DenoiseQuality {
    High,
    Balanced,
    Fast,
}

impl From<DenoiseQuality> for rift_render::platform::oidn::Quality {
    fn from(q: DenoiseQuality) -> Self {
        use rift_render::platform::oidn::Quality;
        match q {
            DenoiseQuality::High => Quality::High,
            DenoiseQuality::Balanced => Quality::Balanced,
            DenoiseQuality::Fast => Quality::Fast,
        }
    }
}

/// Refuses to start work that would end in denoising where Open Image Denoise cannot be
/// loaded: before anything is rendered or written.
pub fn ensure_denoiser() -> anyhow::Result<()> {
    rift_render::platform::oidn::ensure_loaded().map_err(|e| anyhow::anyhow!("--denoise: {e}"))
}

/// Denoises `image` at `quality` on `threads` threads (all by default), saying how long it
/// took under `label`.
pub fn denoise_frame(
    image: &mut rift_render::frame::Image,
    quality: DenoiseQuality,
    threads: Option<usize>,
    label: &str,
) -> anyhow::Result<()> {
    let done = rift_render::frame::denoise::denoise(image, quality.into(), threads.unwrap_or(0))
        .map_err(|e| anyhow::anyhow!("{label}: denoising: {e}"))?;
    eprintln!(
        "{label}: denoised in {:.2} s ({} filter runs)",
        done.seconds, done.runs
    );
    Ok(())
}
