//! `rift reveal`: what each opening shows over a range of frames, for the set dressers and the
//! lighters who must dress and light it (camera rays only: `rift_render::frame::reveal`).

use rift_fx::{FrameRange, Shot};
use rift_render::Scene;
use rift_render::frame::reveal::{Seen, reveal};
use serde_json::json;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `rift reveal`.
#[derive(clap::Args)]
pub struct RevealArgs {
    /// The shot file (TOML).
    shot: PathBuf,
    /// A range of frames, `1001-1010` (default: the shot's frames).
    #[arg(long)]
    frames: Option<String>,
    /// Every Nth frame of the range (its last always).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    step: u32,
    /// Camera rays across the image (its height follows the film's aspect).
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(8..=4096))]
    width: u32,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

/// What one object shows through one opening (or directly) over the frames.
#[derive(Default)]
struct Shown {
    /// Frames it shows in, first and last.
    frames: Option<(i64, i64)>,
    /// Its share of the image, summed over the frames, and its largest in one frame.
    coverage_sum: f64,
    coverage_max: f64,
}

/// What the camera's rays see over some frames, through each opening and directly; the layout
/// page asks for one frame's ([`Report::json`]).
#[derive(Default)]
pub struct Report {
    /// By (opening name, or "" for the camera's direct view; object name).
    shown: BTreeMap<(String, String), Shown>,
    frames: Vec<i64>,
    /// The ray grid of the last frame.
    size: (u32, u32),
}

impl Report {
    /// Adds what `scene` (the shot's at `frame`) shows to `width` camera rays across.
    pub fn add_frame(&mut self, shot: &Shot, scene: &Scene, frame: i64, width: u32) {
        let aspect = scene.camera.projection.aspect();
        self.size = (width, ((width as f64 / aspect).round() as u32).max(1));
        let revealed = reveal(scene, self.size.0, self.size.1);
        let names = |seen: Seen| {
            seen.map_or("(nothing)".to_owned(), |o| {
                scene.id_names[o as usize].clone()
            })
        };
        for (&(opening, seen), &pixels) in &revealed.counts {
            let opening = opening.map_or(String::new(), |i| shot.rig.openings[i].name.clone());
            let entry = self.shown.entry((opening, names(seen))).or_default();
            let coverage = pixels as f64 / revealed.pixels as f64;
            entry.coverage_sum += coverage;
            entry.coverage_max = entry.coverage_max.max(coverage);
            entry.frames = Some(match entry.frames {
                Some((a, b)) => (a.min(frame), b.max(frame)),
                None => (frame, frame),
            });
        }
        self.frames.push(frame);
    }

    /// One row per object an opening shows: the opening, the object, the frames it shows in,
    /// its mean and largest coverage, and whether the camera sees it only through openings.
    pub fn rows(&self) -> Vec<serde_json::Value> {
        let direct: Vec<&String> = self
            .shown
            .keys()
            .filter(|(opening, _)| opening.is_empty())
            .map(|(_, object)| object)
            .collect();
        self.shown
            .iter()
            .filter(|((opening, object), _)| !opening.is_empty() && object != "(nothing)")
            .map(|((opening, object), s)| {
                let (first, last) = s.frames.unwrap_or_default();
                json!({
                    "opening": opening,
                    "object": object,
                    "frames": [first, last],
                    "mean_coverage": s.coverage_sum / self.frames.len() as f64,
                    "max_coverage": s.coverage_max,
                    "only_through_openings": !direct.contains(&object),
                })
            })
            .collect()
    }

    /// The report as `rift reveal --json` prints it, `range` and `step` as asked.
    pub fn json(&self, range: FrameRange, step: u32) -> serde_json::Value {
        json!({ "frames": [range.first, range.last], "step": step,
                "rays": [self.size.0, self.size.1], "seen": self.rows() })
    }
}

pub fn run(args: RevealArgs) -> anyhow::Result<()> {
    let shot = crate::cli::load_shot(&args.shot, "reveal")?;
    let range = match &args.frames {
        Some(text) => FrameRange::parse(text).map_err(|e| anyhow::anyhow!("--frames: {e}"))?,
        None => shot.frames,
    };
    let mut report = Report::default();
    for frame in range
        .iter()
        .filter(|f| (f - range.first) % args.step as i64 == 0 || *f == range.last)
    {
        let scene = Scene::load(&shot, frame)?;
        report.add_frame(&shot, &scene, frame, args.width);
    }
    let text = match args.json {
        true => serde_json::to_string_pretty(&report.json(range, args.step))? + "\n",
        false => table(&report.rows(), &report.frames, report.size),
    };
    // A reader that stops early (`| head`) is not an error.
    match std::io::stdout().write_all(text.as_bytes()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(e.into()),
        _ => Ok(()),
    }
}

/// The rows as a table, those the camera sees only through openings marked.
fn table(rows: &[serde_json::Value], frames: &[i64], (w, h): (u32, u32)) -> String {
    let mut out = format!(
        "{} frame{} ({}-{}), {w}x{h} camera rays a frame; coverage is the share of the image \
         (mean over these frames, and most in one)\n",
        frames.len(),
        if frames.len() == 1 { "" } else { "s" },
        frames.first().unwrap_or(&0),
        frames.last().unwrap_or(&0),
    );
    if rows.is_empty() {
        return out + "no opening shows anything in these frames\n";
    }
    out += &format!(
        "{:<16} {:<36} {:>11} {:>9} {:>9}  seen\n",
        "opening", "object", "frames", "mean", "max"
    );
    for r in rows {
        let frames = format!("{}-{}", r["frames"][0], r["frames"][1]);
        let only = r["only_through_openings"].as_bool().unwrap_or(false);
        out += &format!(
            "{:<16} {:<36} {:>11} {:>8.2}% {:>8.2}%  {}\n",
            r["opening"].as_str().unwrap_or(""),
            r["object"].as_str().unwrap_or(""),
            frames,
            100.0 * r["mean_coverage"].as_f64().unwrap_or(0.0),
            100.0 * r["max_coverage"].as_f64().unwrap_or(0.0),
            if only {
                "only through openings: dress it"
            } else {
                "also directly"
            }
        );
    }
    out
}
