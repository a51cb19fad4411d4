//! `rift farm`: a shot as a farm job. The frames are split into sample chunks, one task each
//! (`rift render --samples A-B`, checkpointed and resumable, so a preempted or retried task
//! loses little), then each frame's chunks are merged (`rift merge`) into exactly the image one
//! render makes. When the shot's rings are generated, a `rift fx` task per frame bakes them to
//! ring caches first and the render tasks read them. The same plan is written as an Open Job
//! Description template (`openjd.rs`) or a Slurm submission script (`slurm.rs`).

mod openjd;
mod slurm;
mod yaml;

use anyhow::{Context, bail};
use clap::{Args, Subcommand};
use rift_fx::FrameRange;
use rift_render::scene::{Overrides, Settings};
use std::path::{Path, PathBuf};

/// `rift farm …`.
#[derive(Subcommand)]
pub enum FarmCommand {
    /// An Open Job Description job template (jobtemplate-2023-09): `openjd run` runs it
    /// locally, AWS Deadline Cloud and other OpenJD schedulers on a farm.
    Openjd(FarmArgs),
    /// A Slurm submission script: job arrays for ring baking, rendering and merging, chained
    /// with --dependency=afterok.
    Slurm(SlurmArgs),
}

/// What every farm job takes.
#[derive(Args)]
pub struct FarmArgs {
    /// The shot file (TOML).
    shot: PathBuf,
    /// Frames, `1001-1010` (default: the shot's range).
    #[arg(long)]
    frames: Option<String>,
    /// Tasks each frame is split into, by sample range; their merge equals one render.
    #[arg(long, default_value_t = 1, value_name = "N")]
    sample_chunks: u32,
    /// Samples per pixel (default: the shot's).
    #[arg(long)]
    spp: Option<u32>,
    /// Image size in pixels, overriding the shot.
    #[arg(long, num_args = 2, value_names = ["W", "H"], action = clap::ArgAction::Set)]
    res: Option<Vec<u32>>,
    /// Where the finished frames go; `#`s become the frame number (default: `[render] output`,
    /// relative to the current directory).
    #[arg(long, value_name = "PATTERN")]
    output: Option<String>,
    /// Where parts, ring caches, checkpoints and logs go (default: `<shot>.farm` beside the
    /// finished frames).
    #[arg(long, value_name = "DIR")]
    work_dir: Option<PathBuf>,
    /// Seconds between a render task's checkpoints (a retried task resumes from its last).
    #[arg(long, default_value_t = 60, value_name = "S")]
    checkpoint: u32,
    /// Denoise each finished frame in its merge step (as `[render] denoise = true` asks too);
    /// the render tasks' sample-range parts never are. The merge machines need Open Image
    /// Denoise (see `rift render --denoise`).
    #[arg(long)]
    denoise: bool,
    /// The rift program the farm runs (default: this one).
    #[arg(long, value_name = "PATH")]
    rift: Option<PathBuf>,
    /// The file to write.
    #[arg(short = 'o', long = "out", value_name = "FILE")]
    job_file: PathBuf,
}

/// `rift farm slurm`: the common options and Slurm's own.
#[derive(Args)]
pub struct SlurmArgs {
    #[command(flatten)]
    common: FarmArgs,
    /// The partition (queue) to submit to (default: the cluster's).
    #[arg(long)]
    partition: Option<String>,
    /// CPUs each render task asks for (default: the cluster's).
    #[arg(long, value_name = "N")]
    cpus_per_task: Option<u32>,
    /// Wall-clock limit of each render task, as sbatch takes it (`HH:MM:SS`); Slurm asks the
    /// task to stop two minutes before it, and the task saves its checkpoint.
    #[arg(long, value_name = "TIME")]
    time: Option<String>,
}

pub fn run(command: FarmCommand) -> anyhow::Result<()> {
    let (args, text) = match command {
        FarmCommand::Openjd(args) => {
            let plan = Plan::new(&args)?;
            let cwd = std::env::current_dir().context("the current directory")?;
            let job_dir = cwd.join(&args.job_file);
            let job_dir = job_dir.parent().unwrap_or(&cwd);
            let template = openjd::template(&plan, job_dir)?;
            if !template.run_here.is_empty() {
                eprintln!(
                    "rift farm: paths outside the template's directory are job parameters \
                     without defaults; run it here with: openjd run {}{} --step Merge \
                     --run-dependencies",
                    args.job_file.display(),
                    template.run_here
                );
            }
            (args, template.text)
        }
        FarmCommand::Slurm(slurm) => {
            let plan = Plan::new(&slurm.common)?;
            let text = slurm::script(&plan, &slurm)?;
            (slurm.common, text)
        }
    };
    if let Some(dir) = args.job_file.parent().filter(|d| !d.as_os_str().is_empty()) {
        crate::cli::prepare_output_dir(dir)?;
    }
    rift_fx::export::atomic::write(&args.job_file, |out| out.write_all(text.as_bytes()))?;
    if matches!(args.job_file.extension(), Some(e) if e == "sh") {
        make_executable(&args.job_file)?;
    }
    eprintln!("rift farm: wrote {}", args.job_file.display());
    Ok(())
}

fn make_executable(path: &Path) -> anyhow::Result<()> {
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755))
        .with_context(|| format!("{}: cannot make it executable", path.display()))
}

/// A shot's farm job: which tasks run which commands.
pub struct Plan {
    /// The rift program, the shot file, the finished-frame pattern and the work directory,
    /// all absolute (farm tasks run in directories of their own).
    rift: String,
    shot_file: String,
    output: String,
    work_dir: String,
    shot_name: String,
    frames: FrameRange,
    /// Sample ranges `A-B`, one task each per frame.
    chunks: Vec<String>,
    res: Option<[u32; 2]>,
    /// Whether a `rift fx` step bakes the rings into caches first.
    bake_rings: bool,
    checkpoint: u32,
    /// Whether the merge step denoises.
    denoise: bool,
}

/// A value in a task's command line: text, or something the job system fills in.
#[derive(Clone, Debug, PartialEq)]
pub enum Piece {
    Text(String),
    Rift,
    ShotFile,
    Output,
    WorkDir,
    Frame,
    Samples,
}

/// One argument, as pieces joined together.
pub type Arg = Vec<Piece>;

fn text(s: &str) -> Arg {
    vec![Piece::Text(s.to_owned())]
}

impl Plan {
    fn new(args: &FarmArgs) -> anyhow::Result<Self> {
        let shot = crate::cli::load_shot(&args.shot, "farm")?;
        let frames = match &args.frames {
            Some(t) => FrameRange::parse(t).map_err(|e| anyhow::anyhow!("--frames: {e}"))?,
            None => shot.frames,
        };
        if args.spp == Some(0) || args.spp.is_some_and(|s| s > 1 << 16) {
            bail!("--spp: expected 1 to 65536 samples per pixel");
        }
        let overrides = Overrides {
            spp: args.spp,
            ..Overrides::default()
        };
        let settings = Settings::read(&shot, &overrides)?;
        let chunks = sample_chunks(settings.spp, args.sample_chunks)?;
        let res = args.res.as_deref().map(crate::cli::parse_res).transpose()?;
        if args.checkpoint == 0 {
            bail!("--checkpoint: expected a positive number of seconds");
        }
        let cwd = std::env::current_dir().context("the current directory")?;
        let output = cwd.join(args.output.as_deref().unwrap_or(&settings.output));
        if frames.len() > 1 && !output.to_string_lossy().contains('#') {
            bail!(
                "{}: several frames need a `#` frame token in the output name",
                output.display()
            );
        }
        let work_dir = match &args.work_dir {
            Some(dir) => cwd.join(dir),
            None => output
                .parent()
                .unwrap_or(&cwd)
                .join(format!("{}.farm", shot.name)),
        };
        let rift = match &args.rift {
            Some(path) => cwd.join(path),
            None => std::env::current_exe().context("finding this program")?,
        };
        Ok(Self {
            rift: rift.to_string_lossy().into_owned(),
            shot_file: cwd.join(&args.shot).to_string_lossy().into_owned(),
            output: output.to_string_lossy().into_owned(),
            work_dir: work_dir.to_string_lossy().into_owned(),
            shot_name: shot.name.clone(),
            frames,
            chunks,
            res,
            bake_rings: shot.rings.iter().any(Option::is_some) && settings.rings.is_none(),
            checkpoint: args.checkpoint,
            denoise: args.denoise || settings.denoise,
        })
    }

    /// `--res W H` when the job overrides the shot's size (ring tessellation follows it).
    fn res_args(&self) -> Vec<Arg> {
        match self.res {
            Some([w, h]) => vec![text("--res"), text(&w.to_string()), text(&h.to_string())],
            None => Vec::new(),
        }
    }

    /// `rift fx` baking one frame's ring caches.
    fn fx_args(&self) -> Vec<Arg> {
        let mut args = vec![
            text("fx"),
            vec![Piece::ShotFile],
            text("--frames"),
            vec![Piece::Frame],
            text("--format"),
            text("cache"),
            text("-o"),
            vec![Piece::WorkDir, Piece::Text("/rings".into())],
        ];
        args.extend(self.res_args());
        args
    }

    /// `rift render` of one frame's sample chunk, checkpointed and resumable.
    fn render_args(&self) -> Vec<Arg> {
        let mut args = vec![
            text("render"),
            vec![Piece::ShotFile],
            text("--frame"),
            vec![Piece::Frame],
            text("--samples"),
            vec![Piece::Samples],
            text("-o"),
            self.part(Piece::Samples),
            text("--checkpoint"),
            text(&self.checkpoint.to_string()),
            text("--resume"),
        ];
        args.extend(self.res_args());
        if self.bake_rings {
            args.extend([
                text("--rings"),
                vec![
                    Piece::WorkDir,
                    Piece::Text(format!("/rings/{}.####.ringcache", self.shot_name)),
                ],
            ]);
        }
        args
    }

    /// `rift merge` of one frame's chunks into the finished frame.
    fn merge_args(&self) -> Vec<Arg> {
        let mut args = vec![
            text("merge"),
            text("--frame"),
            vec![Piece::Frame],
            vec![Piece::Output],
        ];
        for chunk in &self.chunks {
            args.push(self.part(Piece::Text(chunk.clone())));
        }
        if self.denoise {
            args.push(text("--denoise"));
        }
        args
    }

    /// A chunk's part file: `<work>/parts/<shot>.s<A-B>.####.exr`.
    fn part(&self, samples: Piece) -> Arg {
        vec![
            Piece::WorkDir,
            Piece::Text(format!("/parts/{}.s", self.shot_name)),
            samples,
            Piece::Text(".####.exr".into()),
        ]
    }
}

/// `n` sample ranges covering 0..spp as evenly as whole samples allow.
fn sample_chunks(spp: u32, n: u32) -> anyhow::Result<Vec<String>> {
    if n == 0 || n > spp {
        bail!("--sample-chunks: expected 1 to {spp} (the samples per pixel), got {n}");
    }
    let edge = |k: u32| (k as u64 * spp as u64 / n as u64) as u32;
    Ok((0..n)
        .map(|k| format!("{}-{}", edge(k), edge(k + 1)))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::sample_chunks;

    #[test]
    fn chunks_cover_the_samples_without_gaps() {
        assert_eq!(sample_chunks(64, 1).unwrap(), ["0-64"]);
        assert_eq!(sample_chunks(10, 3).unwrap(), ["0-3", "3-6", "6-10"]);
        assert!(sample_chunks(4, 5).is_err());
        assert!(sample_chunks(4, 0).is_err());
    }
}
