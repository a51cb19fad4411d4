//! `rift render`: render frames of a shot to EXR (both eyes of a stereo shot).

use crate::cli::{parse_res, prepare_output_dir};
use crate::progress::Progress;
use anyhow::bail;
use clap::{Args, ValueEnum};
use rift_fx::{FrameRange, Shot};
use rift_render::Scene;
use rift_render::camera::Eye;
use rift_render::frame::checkpoint::{Checkpoint, Key};
use rift_render::frame::film::Image;
use rift_render::frame::film::Window;
use rift_render::frame::passes::{Checkpointing, RenderOptions, Sums};
use rift_render::lights::emitters::LightSelection;
use rift_render::prepare::Prepared;
use rift_render::scene::rings::frame_path;
use rift_render::scene::{Overrides, Settings};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

/// Arguments of `rift render`.
#[derive(Args)]
pub struct RenderArgs {
    /// The shot file (TOML).
    shot: PathBuf,
    /// One frame (default: the shot's first).
    #[arg(long, conflicts_with = "frames")]
    frame: Option<i64>,
    /// A range of frames, `1001-1010`.
    #[arg(long)]
    frames: Option<String>,
    /// Output path; `#`s become the (zero-padded) frame number. Default: `[render] output`.
    #[arg(short, long)]
    output: Option<String>,
    /// Samples per pixel (overrides the shot).
    #[arg(long)]
    spp: Option<u32>,
    /// Seed (overrides the shot).
    #[arg(long)]
    seed: Option<u32>,
    /// Render only the sample indices A ≤ i < B of every pixel, `A-B` (B is then the spp),
    /// with the seeds a whole render uses: a part for `rift merge` (farm tasks split a frame
    /// this way). Not with --target-error or --time-limit, which decide sample counts as they go.
    #[arg(long, value_name = "A-B", conflicts_with = "spp")]
    samples: Option<String>,
    /// Teleports allowed in a row before the next scattering event (overrides
    /// `[render] max_portal_depth`); an opening met past the limit shows black.
    #[arg(long, value_name = "N")]
    max_portal_depth: Option<u32>,
    /// Light sampling does not look through openings (overrides `[render]
    /// light_through_openings`): light through them is found by BSDF sampling alone.
    #[arg(long)]
    no_light_through_openings: bool,
    /// Bounces are aimed at openings where light comes through them after bouncing beyond
    /// (overrides `[render] guide_through_openings`).
    #[arg(long, conflicts_with = "no_guide_through_openings")]
    guide_through_openings: bool,
    /// Bounces are not aimed at openings (overrides `[render] guide_through_openings`): light
    /// that comes through them after bouncing beyond is found by BSDF sampling alone.
    #[arg(long)]
    no_guide_through_openings: bool,
    /// Worker threads (default: all cores). The image is identical for any count.
    #[arg(long)]
    threads: Option<usize>,
    /// Image size in pixels, overriding the shot (the vertical field of view is kept).
    #[arg(long, num_args = 2, value_names = ["W", "H"], action = clap::ArgAction::Set)]
    res: Option<Vec<u32>>,
    /// Render only a window, as fractions of the frame `x0,x1,y0,y1` (0 to 1, y down); the EXR
    /// keeps the full frame as its display window.
    #[arg(long, value_name = "X0,X1,Y0,Y1")]
    crop: Option<String>,
    /// Stop sampling each pixel once the estimated relative error of its 3×3 neighbourhood falls
    /// below this (adaptive sampling; --spp is then the most a pixel takes).
    #[arg(long, value_name = "E")]
    target_error: Option<f32>,
    /// Wall-clock seconds per frame, after which no new samples start (every pixel still gets
    /// its first few).
    #[arg(long, value_name = "S")]
    time_limit: Option<f64>,
    /// The most memory the render may take, such as `8G` (default: what the system has
    /// available); a frame whose film needs more is refused before anything is allocated.
    #[arg(long, value_name = "SIZE", value_parser = crate::memory::parse_size)]
    max_memory: Option<u64>,
    /// Save the render's state every S seconds (and when SIGINT or SIGTERM stops it) to
    /// `<output>.checkpoint.exr`, a partial image any viewer opens; removed once the frame is
    /// written. A second signal ends the process at once.
    #[arg(long, value_name = "S")]
    checkpoint: Option<f64>,
    /// Continue from the frame's checkpoint when there is one (otherwise start afresh): the
    /// finished frame equals an uninterrupted render. A checkpoint of another shot, shot file,
    /// build or settings is refused.
    #[arg(long)]
    resume: bool,
    /// Also write an sRGB PNG preview beside each EXR.
    #[arg(long)]
    png: bool,
    /// Add Cryptomatte object-ID layers (`CryptoObject00`…, with the manifest in the header)
    /// for compositors: the objects and rings each pixel's camera samples see first, through
    /// openings included.
    #[arg(long)]
    cryptomatte: bool,
    /// Ring caches written by `rift fx` (`#`s become the frame number), or its PLY point clouds
    /// (a pattern ending in `.ply`, `%o` becoming each opening's name), replacing `[render]
    /// rings`; without either the rings are generated in memory.
    #[arg(long, value_name = "PATTERN")]
    rings: Option<PathBuf>,
    /// How light sampling picks emitters: `learned` (the default: `tree`, with its first two
    /// choices reweighed per region of the scene by what a few training paths, traced before
    /// the render, saw each branch bring there, shadow rays included), `tree` (by what each can
    /// send to the shaded point, strands also by how much of their light gets out of the rings,
    /// and the sky against them the same way) or `power` (by power alone, the sky half the
    /// time). `tree` and `power` are for comparison.
    #[arg(long, value_enum)]
    light_selection: Option<SelectionArg>,
    /// Render only this eye of a stereo shot (`[camera.stereo]`); by default both are
    /// rendered, named by `%v` in the output (or `.left` / `.right` before the frame number).
    #[arg(long, value_enum)]
    eye: Option<EyeArg>,
    #[command(flatten)]
    denoise: crate::cli::DenoiseArgs,
}

/// `--light-selection`.
#[derive(Clone, Copy, ValueEnum)]
enum SelectionArg {
    Learned,
    Tree,
    Power,
}

impl From<SelectionArg> for LightSelection {
    fn from(s: SelectionArg) -> Self {
        match s {
            SelectionArg::Learned => LightSelection::Learned,
            SelectionArg::Tree => LightSelection::Tree,
            SelectionArg::Power => LightSelection::Power,
        }
    }
}

/// `--eye`.
#[derive(Clone, Copy, ValueEnum)]
enum EyeArg {
    Left,
    Right,
}

impl From<EyeArg> for Eye {
    fn from(e: EyeArg) -> Self {
        match e {
            EyeArg::Left => Eye::Left,
            EyeArg::Right => Eye::Right,
        }
    }
}

/// Runs `rift render`.
pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    let mut shot = crate::cli::load_shot(&args.shot, "render")?;
    if let Some(res) = &args.res {
        shot.camera.projection.resolution = parse_res(res)?;
    }
    let frames = frames(&args, &shot)?;
    let samples = sample_range(&args)?;
    if args.denoise.denoise {
        crate::cli::ensure_denoiser()?;
    }
    let [w, h] = shot.camera.projection.resolution.map(|v| v as usize);
    let crop = match &args.crop {
        Some(text) => {
            Some(Window::from_fractions(text, w, h).map_err(|e| anyhow::anyhow!("--crop: {e}"))?)
        }
        None => None,
    };
    let (film, budget) = ensure_film_fits(&args, &shot, frames, crop)?;
    if let Some(e) = args.target_error
        && !(e.is_finite() && e > 0.0)
    {
        bail!("--target-error: expected a positive relative error such as 0.01, got {e}");
    }
    let time_limit = seconds("--time-limit", args.time_limit)?;
    let checkpoint_every = seconds("--checkpoint", args.checkpoint)?;
    let plan = Plan {
        several_frames: frames.len() > 1,
        part: Part {
            crop,
            first_sample: samples.map_or(0, |[start, _]| start),
            shot_id: shot_id(&shot.name),
        },
        time_limit,
        checkpoint_every,
        stop: match checkpoint_every {
            Some(_) => Some(crate::resume::stop_on_signals()?),
            None => None,
        },
        overrides: Overrides {
            spp: samples.map(|[_, end]| end).or(args.spp),
            seed: args.seed,
            max_portal_depth: args.max_portal_depth,
            light_through_openings: args.no_light_through_openings.then_some(false),
            guide_through_openings: match (
                args.guide_through_openings,
                args.no_guide_through_openings,
            ) {
                (true, _) => Some(true),
                (_, true) => Some(false),
                _ => None,
            },
            rings: args.rings.clone(),
            light_selection: args.light_selection.map(Into::into),
            memory_budget: budget.map(|b| b.saturating_sub(film)),
        },
    };
    for frame in frames.iter() {
        if crate::resume::stop_requested() {
            return Err(crate::resume::Interrupted {
                message: format!("stopped by a signal before frame {frame}"),
            }
            .into());
        }
        render_frame(&args, &shot, frame, &plan)?;
    }
    Ok(())
}

/// The frames `--frames` or `--frame` ask for, or the shot's first.
fn frames(args: &RenderArgs, shot: &Shot) -> anyhow::Result<FrameRange> {
    Ok(match (&args.frames, args.frame) {
        (Some(text), _) => FrameRange::parse(text).map_err(|e| anyhow::anyhow!("--frames: {e}"))?,
        (None, Some(f)) => FrameRange { first: f, last: f },
        (None, None) => FrameRange {
            first: shot.frames.first,
            last: shot.frames.first,
        },
    })
}

/// `--samples` checked against `--spp` and the flags that cannot split a render by samples.
fn sample_range(args: &RenderArgs) -> anyhow::Result<Option<[u32; 2]>> {
    if args.spp == Some(0) || args.spp.is_some_and(|s| s > 1 << 16) {
        bail!("--spp: expected 1 to 65536 samples per pixel");
    }
    let samples = args.samples.as_deref().map(parse_samples).transpose()?;
    if samples.is_some() && (args.target_error.is_some() || args.time_limit.is_some()) {
        bail!(
            "--samples: a sample range is a fixed share of a render; --target-error and \
             --time-limit choose sample counts as they go, so they cannot split one"
        );
    }
    if args.denoise.denoise && samples.is_some() {
        bail!(
            "--denoise: a sample range is a part of a frame for rift merge, and parts are never \
             denoised (a denoiser does not add up); denoise the merged frame with `rift merge \
             --denoise`"
        );
    }
    if args.cryptomatte && (samples.is_some() || args.checkpoint.is_some() || args.resume) {
        bail!(
            "--cryptomatte: object IDs are counted over a whole render; they cannot yet be \
             split by --samples or saved in --checkpoint / --resume state"
        );
    }
    Ok(samples)
}

/// What every frame of a `rift render` run shares.
struct Plan {
    several_frames: bool,
    /// The part of each image rendered.
    part: Part,
    time_limit: Option<Duration>,
    checkpoint_every: Option<Duration>,
    stop: Option<&'static AtomicBool>,
    overrides: Overrides,
}

/// Loads, prepares and renders `frame` of `shot`: each eye of a stereo camera, or the one
/// `--eye` names.
fn render_frame(args: &RenderArgs, shot: &Shot, frame: i64, plan: &Plan) -> anyhow::Result<()> {
    let images = frame_images(args, shot, frame, plan)?;
    // Preparing a production set takes minutes: a checkpoint of another render is refused
    // first, from its header (the sums are read once the scene is ready).
    if args.resume {
        for image in &images {
            check_checkpoint_header(image)?;
        }
    }
    let prepared = Prepared::build(shot, frame, &plan.overrides)?;
    for warning in &prepared.scene.warnings {
        eprintln!("rift render: warning: {warning}");
    }
    report_bounce_guide(&prepared, frame);
    let run = Run {
        time_limit: plan.time_limit,
        checkpoint_every: plan.checkpoint_every,
        resume: args.resume,
        stop: plan.stop,
    };
    for target in &images {
        render_one(&prepared, args, target, plan.part, &run, frame)?;
    }
    Ok(())
}

/// One image a frame renders: an eye (or the only view), its output and its checkpoint key.
struct FrameImage {
    eye: Option<Eye>,
    path: PathBuf,
    /// The pixels rendered.
    window: Window,
    /// Present when checkpoints are written or read.
    key: Option<Key>,
}

/// The images `frame` renders, worked out from the shot and the flags alone (before the scene
/// is prepared): one, or each eye of a stereo camera, or the one `--eye` names.
fn frame_images(
    args: &RenderArgs,
    shot: &Shot,
    frame: i64,
    plan: &Plan,
) -> anyhow::Result<Vec<FrameImage>> {
    let settings = Settings::read(shot, &plan.overrides)?;
    let stereo =
        rift_render::scene::camera::stereo(&shot.source, shot.render.camera_stereo.as_ref())?;
    let eyes: Vec<Option<Eye>> = match (stereo, args.eye) {
        (None, Some(_)) => bail!("--eye: {} has no [camera.stereo]", args.shot.display()),
        (None, None) => vec![None],
        (Some(_), Some(eye)) => vec![Some(eye.into())],
        (Some(_), None) => Eye::BOTH.map(Some).to_vec(),
    };
    let pattern = args
        .output
        .clone()
        .unwrap_or_else(|| settings.output.clone());
    if plan.several_frames && !pattern.contains('#') {
        bail!("{pattern}: several frames need a `#` frame token in the output name");
    }
    let [w, h] = shot.camera.projection.resolution.map(|v| v as usize);
    let window = plan.part.crop.unwrap_or(Window::full(w, h));
    let image = |eye: Option<Eye>| {
        let pattern = match eye {
            Some(eye) => eye_path(&pattern, eye.name()),
            None => pattern.clone(),
        };
        // Hashing the shot file and the program is done only where a checkpoint is written
        // or read.
        let key = match plan.checkpoint_every.is_some() || args.resume {
            true => Some(checkpoint_key(
                args, shot, frame, &settings, plan, eye, window,
            )?),
            false => None,
        };
        anyhow::Ok(FrameImage {
            eye,
            path: PathBuf::from(frame_path(&pattern, frame)),
            window,
            key,
        })
    };
    eyes.into_iter().map(image).collect()
}

/// Refuses to resume `image` from a checkpoint another render wrote, by its header.
fn check_checkpoint_header(image: &FrameImage) -> anyhow::Result<()> {
    let (Some(key), file) = (&image.key, crate::resume::checkpoint_path(&image.path)) else {
        return Ok(());
    };
    if !file.exists() {
        return Ok(());
    }
    let (written, window) = Checkpoint::read_key(&file)?;
    refuse_foreign(&file, &written, window, key, image.window)
}

/// Refuses a frame whose film (with its generated rings and checkpoints) cannot fit in memory;
/// returns the film's bytes and the memory budget.
fn ensure_film_fits(
    args: &RenderArgs,
    shot: &Shot,
    frames: FrameRange,
    crop: Option<Window>,
) -> anyhow::Result<(u64, Option<u64>)> {
    let [w, h] = shot.camera.projection.resolution.map(|v| v as usize);
    let pixels = crop.map_or(w * h, |c| c.area());
    // Generated rings are held as curves and again as the renderer's strands.
    let rings = match args.rings {
        None => 2 * rift_fx::ring::RingGenerator::new(shot, frames).frame_bytes_bound(frames),
        Some(_) => 0,
    };
    let checkpoints = match args.checkpoint {
        Some(_) => rift_render::frame::checkpoint::checkpoint_bytes(pixels),
        None => 0,
    };
    let film = rift_render::frame::passes::film_bytes(pixels)
        .saturating_add(rings)
        .saturating_add(checkpoints);
    let budget = crate::memory::budget(args.max_memory);
    crate::memory::ensure_fits(
        &format!("a {w}x{h} frame ({pixels} pixels rendered) with its rings and checkpoints"),
        film,
        budget,
        "lower --res (or the shot's resolution), render a window of the frame at a time with \
         --crop, or lower fx.max_segments or [portal.ring] strands",
    )?;
    Ok((film, budget))
}

/// An optional positive number of seconds given to `flag`.
fn seconds(flag: &str, value: Option<f64>) -> anyhow::Result<Option<Duration>> {
    match value {
        Some(s) if s.is_finite() && s > 0.0 => Ok(Some(Duration::from_secs_f64(s))),
        Some(s) => bail!("{flag}: expected a positive number of seconds, got {s}"),
        None => Ok(None),
    }
}

/// `--samples A-B` as [A, B]: 0 ≤ A < B ≤ 65536.
fn parse_samples(text: &str) -> anyhow::Result<[u32; 2]> {
    let range = text
        .split_once('-')
        .and_then(|(a, b)| Some([a.trim().parse::<u32>().ok()?, b.trim().parse::<u32>().ok()?]));
    match range {
        Some([a, b]) if a < b && b <= 1 << 16 => Ok([a, b]),
        _ => bail!(
            "--samples: expected a range of sample indices A-B with 0 ≤ A < B ≤ 65536, such as \
             0-64, got {text:?}"
        ),
    }
}

/// FNV-1a of the shot's name: parts of different shots carry different ids.
fn shot_id(name: &str) -> u32 {
    name.bytes().fold(0x811c_9dc5u32, |h, b| {
        (h ^ b as u32).wrapping_mul(0x0100_0193)
    })
}

/// Which share of the frame one render covers: a window and the first sample index.
#[derive(Clone, Copy)]
struct Part {
    crop: Option<Window>,
    first_sample: u32,
    shot_id: u32,
}

/// How each image is run: its time limit and its checkpoints.
struct Run {
    time_limit: Option<Duration>,
    checkpoint_every: Option<Duration>,
    resume: bool,
    stop: Option<&'static AtomicBool>,
}

/// The key tying a checkpoint to this image: the shot file, and every setting that decides
/// its pixels.
fn checkpoint_key(
    args: &RenderArgs,
    shot: &Shot,
    frame: i64,
    s: &Settings,
    plan: &Plan,
    eye: Option<Eye>,
    window: Window,
) -> anyhow::Result<Key> {
    let [w, h] = shot.camera.projection.resolution;
    let (part, overrides) = (plan.part, &plan.overrides);
    let settings = [
        ("frame", frame.to_string()),
        ("eye", eye.map_or("-", |e| e.name()).to_owned()),
        ("res", format!("{w}x{h}")),
        (
            "window",
            format!("{}-{},{}-{}", window.x0, window.x1, window.y0, window.y1),
        ),
        ("samples", format!("{}-{}", part.first_sample, s.spp)),
        ("seed", s.seed.to_string()),
        ("target_error", format!("{:?}", args.target_error)),
        ("max_bounces", format!("{:?}", s.max_bounces)),
        ("max_portal_depth", s.max_portal_depth.to_string()),
        (
            "light_through_openings",
            s.light_through_openings.to_string(),
        ),
        (
            "guide_through_openings",
            s.guide_through_openings.to_string(),
        ),
        (
            "light_selection",
            format!("{:?}", overrides.light_selection),
        ),
        ("rings", format!("{:?}", overrides.rings)),
    ];
    let settings = settings
        .into_iter()
        .map(|(k, v)| (k.to_owned(), v))
        .collect();
    crate::resume::key(&args.shot, &shot.name, settings)
}

/// Renders `target`, one image of the prepared scene (one eye, if it names one), to its output.
fn render_one(
    prepared: &Prepared,
    args: &RenderArgs,
    target: &FrameImage,
    part: Part,
    run: &Run,
    frame: i64,
) -> anyhow::Result<()> {
    let FrameImage {
        eye,
        path,
        window,
        key,
    } = target;
    let (eye, window, crop) = (*eye, *window, part.crop);
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        prepare_output_dir(dir)?;
    }
    let started = Instant::now();
    let scene = &prepared.scene;
    let spp = scene.settings.spp;
    let label = match eye {
        Some(eye) => format!("frame {frame} {}", eye.name()),
        None => format!("frame {frame}"),
    };
    let denoise = denoises(args, scene, &label)?;
    let checkpoint_file = crate::resume::checkpoint_path(path);
    let resumed = match (run.resume, key) {
        (true, Some(key)) => load_checkpoint(&checkpoint_file, key, window)?,
        _ => None,
    };
    let progress = Progress::new(&label, window.area() * (spp - part.first_sample) as usize);
    if let Some(checkpoint) = &resumed {
        progress.advance(checkpoint.samples_taken(part.first_sample));
    }
    let advance = |n: u64| progress.advance(n);
    let save_error = Mutex::new(None);
    let save = |image: &Image, sums: Sums| {
        let Some(key) = key else {
            return;
        };
        let checkpoint = Checkpoint {
            key: key.clone(),
            window,
            sums,
        };
        let result = checkpoint.write(image, &checkpoint_file);
        if let Err(e) = &result {
            eprintln!("rift render: warning: {e}");
        }
        *save_error.lock().unwrap_or_else(|e| e.into_inner()) = result.err();
    };
    let options = RenderOptions {
        spp,
        first_sample: part.first_sample,
        crop,
        target_error: args.target_error,
        time_limit: run.time_limit,
        progress: Some(&advance),
        eye,
        resume: resumed.as_ref().map(|c| &c.sums),
        checkpoint: run
            .checkpoint_every
            .map(|every| Checkpointing { every, save: &save }),
        stop: run.stop,
        cryptomatte: args.cryptomatte,
    };
    let rendered = crate::cli::with_threads(args.threads, || {
        rift_render::frame::render_resumable(prepared, &options)
    })?;
    progress.finish();
    if !rendered.complete {
        let failed = save_error.into_inner().unwrap_or_else(|e| e.into_inner());
        return Err(stopped(&label, failed, &checkpoint_file));
    }
    let mut image = rendered.image;
    image.metadata.shot_id = part.shot_id;
    let seconds = started.elapsed().as_secs_f64();
    if denoise {
        let quality = args.denoise.denoise_quality;
        crate::cli::denoise_frame(&mut image, quality, args.threads, &label)?;
    }
    image.write_exr(path)?;
    if args.png {
        image.write_png(&path.with_extension("png"))?;
    }
    if run.checkpoint_every.is_some() || resumed.is_some() {
        remove_checkpoint(&checkpoint_file)?;
    }
    report(&image, &label, spp, seconds, path);
    Ok(())
}

/// Whether the frame is denoised: `--denoise` or `[render] denoise`, except in a sample-range
/// part (the shot's setting is then left to `rift merge --denoise`, and said).
/// Checked before the frame is rendered, so a missing denoiser costs no render.
fn denoises(args: &RenderArgs, scene: &Scene, label: &str) -> anyhow::Result<bool> {
    if !(args.denoise.denoise || scene.settings.denoise) {
        return Ok(false);
    }
    if args.samples.is_some() {
        eprintln!(
            "{label}: not denoised: a sample-range part never is (`rift merge --denoise` \
             denoises the merged frame)"
        );
        return Ok(false);
    }
    crate::cli::ensure_denoiser()?;
    Ok(true)
}

/// The error of a render a signal stopped: where its state was saved, or why it was not.
fn stopped(
    label: &str,
    checkpoint_failed: Option<rift_render::RenderError>,
    checkpoint_file: &Path,
) -> anyhow::Error {
    let message = match checkpoint_failed {
        None => format!(
            "{label}: stopped by a signal; its state is saved in {} (a partial image); run the \
             same command with --resume to finish it",
            checkpoint_file.display()
        ),
        Some(e) => format!("{label}: stopped by a signal, and its checkpoint failed: {e}"),
    };
    crate::resume::Interrupted { message }.into()
}

/// Says what the bounce guide learned, when one was asked for: a lighter sees whether aiming
/// at openings does anything in this shot.
fn report_bounce_guide(prepared: &Prepared, frame: i64) {
    if !prepared.scene.settings.guide_through_openings {
        return;
    }
    if let Some(guide) = &prepared.bounce_guide {
        eprintln!(
            "rift render: frame {frame}: bounce guide: {} (training {:.2} s)",
            guide.summary(),
            prepared.training_seconds
        );
        return;
    }
    // The same test that decides whether training looks for a guide at all.
    let why_not = if prepared.scene.guide_through_openings_possible() {
        "no training path bounced through one"
    } else {
        "the scene has no openings and lights for light to come through"
    };
    eprintln!("rift render: frame {frame}: bounces are not aimed at openings: {why_not}");
}

/// Prints what was rendered: size, samples, time, speed and where it went.
fn report(image: &Image, label: &str, spp: u32, seconds: f64, path: &Path) {
    let samples: u64 = image.spp.iter().map(|&n| n as u64).sum();
    // The rendered frame's noise (an estimate that takes the samples as independent, so about
    // 1.5 times what stratified samples have); a denoised frame's is that of its noisy frame.
    let noise = image.noise.map_or(String::new(), |n| {
        let before = if image.noisy.is_some() {
            " before denoising"
        } else {
            ""
        };
        format!(", noise {:.1}%{before}", 100.0 * n)
    });
    eprintln!(
        "rift render: {label}: {}x{} at {:.1} spp (mean; at most {spp}) in {seconds:.2} s ({:.2} Mpaths/s{noise}) -> {}{}",
        image.window.width(),
        image.window.height(),
        samples as f64 / image.spp.len() as f64,
        samples as f64 / seconds / 1e6,
        path.display(),
        if image.discarded > 0 {
            format!(" ({} non-finite samples discarded)", image.discarded)
        } else {
            String::new()
        }
    );
}

/// The checkpoint at `file` when there is one that continues this render (`key`, `window`);
/// one of anything else is an error naming the difference.
fn load_checkpoint(file: &Path, key: &Key, window: Window) -> anyhow::Result<Option<Checkpoint>> {
    if !file.exists() {
        eprintln!(
            "rift render: no checkpoint at {}; starting from the first sample",
            file.display()
        );
        return Ok(None);
    }
    let checkpoint = Checkpoint::read(file)?;
    refuse_foreign(file, &checkpoint.key, checkpoint.window, key, window)?;
    Ok(Some(checkpoint))
}

/// Refuses a checkpoint (`file`) written with key `written` over `written_window` for a render
/// whose own key and window these are not.
fn refuse_foreign(
    file: &Path,
    written: &Key,
    written_window: Window,
    key: &Key,
    window: Window,
) -> anyhow::Result<()> {
    let refusal = written.refusal(key).or_else(|| {
        (written_window != window).then(|| "its pixel window differs from this render's".into())
    });
    match refusal {
        Some(why) => bail!(
            "{}: cannot resume from this checkpoint: {why}; delete it to render afresh",
            file.display()
        ),
        None => Ok(()),
    }
}

/// Removes a finished frame's checkpoint (there may be none).
fn remove_checkpoint(file: &Path) -> anyhow::Result<()> {
    match std::fs::remove_file(file) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            bail!(
                "{}: cannot remove the finished frame's checkpoint: {e}",
                file.display()
            )
        }
        _ => Ok(()),
    }
}

/// The output pattern of one stereo eye: `%v` becomes the eye's name; without one, `.<name>`
/// goes before the frame token (or, without a frame token, before the extension).
pub fn eye_path(pattern: &str, name: &str) -> String {
    if pattern.contains("%v") {
        return pattern.replace("%v", name);
    }
    let file_start = pattern.rfind('/').map_or(0, |i| i + 1);
    let file = &pattern[file_start..];
    match (file.find('#'), file.rfind('.')) {
        (Some(i), _) => format!("{}{name}.{}", &pattern[..file_start + i], &file[i..]),
        (None, Some(i)) if i > 0 => format!("{}.{name}{}", &pattern[..file_start + i], &file[i..]),
        _ => format!("{pattern}.{name}"),
    }
}

#[cfg(test)]
mod tests {
    use super::{eye_path, frame_path};

    #[test]
    fn frame_tokens() {
        assert_eq!(frame_path("out/a.####.exr", 7), "out/a.0007.exr");
        assert_eq!(frame_path("out/a.#.exr", 1001), "out/a.1001.exr");
        assert_eq!(frame_path("out/a.exr", 3), "out/a.exr");
    }

    #[test]
    fn eye_tokens() {
        assert_eq!(eye_path("out/a.####.exr", "left"), "out/a.left.####.exr");
        assert_eq!(eye_path("out/%v/a.#.exr", "right"), "out/right/a.#.exr");
        assert_eq!(eye_path("out.d/a.exr", "left"), "out.d/a.left.exr");
        assert_eq!(eye_path("out/a", "right"), "out/a.right");
    }
}
