//! `rift layout`: a local web server for staging a shot in a browser. It serves one page (and
//! the three.js it draws with, vendored in `assets/layout/vendor` with its licence, so it works
//! with no network) and a JSON API with the shot's scene at any frame, built by the renderer.
//!
//! Edits from the page (`POST /api/edit`: a pose at a frame, a key deleted, a copy placed by the
//! inverse solver) change the shot as the server holds it once the edited shot builds; `POST
//! /api/save` writes them into the shot file, `POST /api/revert` drops them.
//!
//! It listens on 127.0.0.1 only and answers only requests whose `Host` (and `Origin`, when
//! sent) name the loopback address, so another site open in the same browser cannot read the
//! shot (DNS rebinding). Bad requests get a 4xx and the server goes on; Ctrl-C stops it.

mod check;
mod edit;
mod http;
mod scene_json;
mod shot_file;

use clap::Args;
use http::{Incoming, Reply};
use rift_render::Scene;
use rift_render::rift_fx::Shot;
use std::net::TcpListener;
use std::path::PathBuf;

/// Arguments of `rift layout`.
#[derive(Args)]
pub struct LayoutArgs {
    /// The shot to stage.
    shot: PathBuf,
    /// The frame the page opens at (default: the shot's first).
    #[arg(long)]
    frame: Option<i64>,
    /// The port to listen on (0: any free port; the URL is printed).
    #[arg(long, default_value_t = 8642)]
    port: u16,
    /// Do not open a browser (the URL is printed either way).
    #[arg(long)]
    no_browser: bool,
}

/// The page and the scripts it loads, by path.
const FILES: [(&str, &[u8]); 9] = [
    ("/", include_bytes!("../../assets/layout/index.html")),
    ("/app.js", include_bytes!("../../assets/layout/app.js")),
    ("/model.js", include_bytes!("../../assets/layout/model.js")),
    (
        "/preview.js",
        include_bytes!("../../assets/layout/preview.js"),
    ),
    ("/edit.js", include_bytes!("../../assets/layout/edit.js")),
    (
        "/vendor/three.module.js",
        include_bytes!("../../assets/layout/vendor/three.module.js"),
    ),
    (
        "/vendor/three.core.js",
        include_bytes!("../../assets/layout/vendor/three.core.js"),
    ),
    (
        "/vendor/OrbitControls.js",
        include_bytes!("../../assets/layout/vendor/OrbitControls.js"),
    ),
    (
        "/vendor/TransformControls.js",
        include_bytes!("../../assets/layout/vendor/TransformControls.js"),
    ),
];

/// Serves the page until Ctrl-C (or SIGTERM).
pub fn run(args: LayoutArgs) -> anyhow::Result<()> {
    let shot = crate::cli::load_shot(&args.shot, "layout")?;
    let frame = args.frame.unwrap_or(shot.frames.first);
    if !(shot.frames.first..=shot.frames.last).contains(&frame) {
        anyhow::bail!(
            "--frame: {frame} is outside the shot's frames {}-{}",
            shot.frames.first,
            shot.frames.last
        );
    }
    let file = shot_file::ShotFile::open(&args.shot).map_err(anyhow::Error::msg)?;
    let listener = TcpListener::bind(("127.0.0.1", args.port)).map_err(|e| {
        anyhow::anyhow!(
            "cannot listen on 127.0.0.1:{}: {e}{}",
            args.port,
            if args.port != 0 {
                " (is another `rift layout` running? give --port)"
            } else {
                ""
            }
        )
    })?;
    let port = listener.local_addr()?.port();
    let url = format!("http://127.0.0.1:{port}/?frame={frame}");
    println!("rift layout: {} at {url} (Ctrl-C stops)", shot.name);
    if !args.no_browser {
        open_browser(&url);
    }
    let stop = crate::resume::stop_on_signals()?;
    let mut state = State {
        shot,
        file,
        cached: None,
        check: None,
    };
    http::serve(listener, port, stop, move |request| state.answer(request))?;
    println!("rift layout: stopped");
    Ok(())
}

/// The shot being staged (as edited), its file, and the last frame's scene JSON.
struct State {
    shot: Shot,
    file: shot_file::ShotFile,
    cached: Option<(i64, String)>,
    /// The last check render's scene.
    check: Option<check::Built>,
}

impl State {
    /// Answers one request (errors in the answer are the browser's to see, never fatal).
    fn answer(&mut self, request: Incoming) -> Reply {
        if request.post {
            return self.post(&request.url, &request.body);
        }
        let url = request.url.as_str();
        let (path, query) = url.split_once('?').unwrap_or((url, ""));
        if path == "/api/scene" {
            return match frame_param(query, &self.shot) {
                Ok(frame) => self.scene(frame),
                Err(message) => Reply::text(400, &message),
            };
        }
        if path == "/api/reveal" {
            return match frame_param(query, &self.shot) {
                Ok(frame) => self.reveal(frame),
                Err(message) => Reply::text(400, &message),
            };
        }
        if path == "/api/render" {
            return match check::Request::parse(query, &self.shot) {
                Ok(request) => match check::render(&self.shot, &request, &mut self.check) {
                    Ok((png, denoised)) => {
                        Reply::bytes("image/png", png).with_header("x-rift-denoised", denoised)
                    }
                    Err(message) => Reply::error(422, &message),
                },
                Err(message) => Reply::text(400, &message),
            };
        }
        match FILES.iter().find(|(p, _)| *p == path) {
            Some((_, bytes)) => {
                let kind = if path == "/" {
                    "text/html; charset=utf-8"
                } else {
                    "text/javascript; charset=utf-8"
                };
                Reply::bytes(kind, bytes.to_vec())
            }
            None => Reply::text(404, &format!("{path}: not found")),
        }
    }

    /// The scene JSON at `frame` (a shot that fails to build answers 422 with the error, file
    /// and key included).
    fn scene(&mut self, frame: i64) -> Reply {
        if let Some((f, json)) = &self.cached
            && *f == frame
        {
            return Reply::json_text(json.clone());
        }
        match staged_scene(&self.shot, frame) {
            Ok(scene) => self.answer_scene(&scene, frame),
            Err(e) => Reply::error(422, &e.to_string()),
        }
    }

    /// What the camera sees through each opening at `frame`, as `rift reveal --json` gives it
    /// for that frame (the shot as edited; 128 rays across).
    fn reveal(&mut self, frame: i64) -> Reply {
        const RAYS_ACROSS: u32 = 128;
        match staged_scene(&self.shot, frame) {
            Ok(scene) => {
                let mut report = crate::reveal_cmd::Report::default();
                report.add_frame(&self.shot, &scene, frame, RAYS_ACROSS);
                let range = rift_fx::FrameRange {
                    first: frame,
                    last: frame,
                };
                Reply::json(&report.json(range, 1))
            }
            Err(e) => Reply::error(422, &e.to_string()),
        }
    }

    /// `scene` (the shot's at `frame`) as the page's JSON, kept for the next request of it.
    fn answer_scene(&mut self, scene: &Scene, frame: i64) -> Reply {
        let json = scene_json::scene(&self.shot, scene, frame, &self.file).to_string();
        self.cached = Some((frame, json.clone()));
        Reply::json_text(json)
    }

    /// Answers a POST: an edit, a save or a revert.
    fn post(&mut self, url: &str, body: &str) -> Reply {
        match url {
            "/api/edit" => self.edit(body),
            "/api/save" => match self.file.save() {
                Ok(()) => {
                    let saved = self.file.path().display().to_string();
                    self.cached = None;
                    Reply::json(&serde_json::json!({ "saved": saved }))
                }
                Err(message) => Reply::error(422, &message),
            },
            "/api/revert" => match self.file.revert() {
                Ok(shot) => {
                    self.shot = shot;
                    self.cached = None;
                    self.check = None;
                    Reply::json(&serde_json::json!({ "reverted": true }))
                }
                Err(message) => Reply::error(422, &message),
            },
            _ => Reply::text(405, "POST goes to /api/edit, /api/save or /api/revert"),
        }
    }

    /// Applies an edit (a JSON [`edit::Edit`]) once the edited shot builds at the edit's frame
    /// and places what was moved where it was asked: 200 with that frame's scene, 400 for a
    /// malformed body, 422 (with the reason, file and key) otherwise, the shot unchanged.
    fn edit(&mut self, body: &str) -> Reply {
        let edit: edit::Edit = match serde_json::from_str(body) {
            Ok(e) => e,
            Err(e) => return Reply::error(400, &format!("the edit: {e}")),
        };
        let frame = edit.frame();
        if let Err(message) = frame_param(&format!("frame={frame}"), &self.shot) {
            return Reply::error(400, &message);
        }
        let checked = self.file.edited(&edit, &self.shot).and_then(|(doc, shot)| {
            let scene = staged_scene(&shot, frame).map_err(|e| e.to_string())?;
            landed(&edit, &shot, &scene, frame)?;
            Ok((doc, shot, scene))
        });
        match checked {
            Ok((doc, shot, scene)) => {
                self.file.keep(doc);
                self.shot = shot;
                self.check = None;
                self.answer_scene(&scene, frame)
            }
            Err(message) => Reply::error(422, &message),
        }
    }
}

/// The scene the page shows and edits are checked on: the renderer's own as loaded, without
/// what only rendering needs: the preparing passes ([`rift_render::prepare`]) and the strands'
/// exposure the light tree weighs them by (power alone picks lights here); the check render
/// loads and prepares its scene whole.
fn staged_scene(shot: &Shot, frame: i64) -> Result<Scene, rift_render::RenderError> {
    let overrides = rift_render::scene::Overrides {
        light_selection: Some(rift_render::lights::LightSelection::Power),
        ..Default::default()
    };
    Scene::load_with(shot, frame, &overrides)
}

/// Checks that a pose edit places its target where it asked at `frame` in the edited `scene`
/// (positions written to micrometres), as a guard against writing it somewhere else.
fn landed(edit: &edit::Edit, shot: &Shot, scene: &Scene, frame: i64) -> Result<(), String> {
    let Some((target, asked)) = edit.asked_pose() else {
        return Ok(());
    };
    let time = shot.time_of(frame as f64);
    let opening = |name: &str| shot.rig.find(name).ok_or("no such opening");
    let placed = match target {
        edit::Target::Camera => rift_render::camera::Lens::at(&scene.camera, time)
            .position
            .as_dvec3(),
        edit::Target::Opening { name, side } => {
            let i = opening(name)?;
            match side {
                edit::Side::Here => scene.portals.here(i, time).translation,
                edit::Side::There => scene.portals.there(i, time).translation,
            }
        }
        edit::Target::Object { name } => {
            let objects = &scene.id_names[..scene.object_count as usize];
            let o = objects.iter().position(|n| n == name);
            let o = o.ok_or("no such object")?;
            scene.object_placement[o].at(time).translation
        }
    };
    let tolerance = 1e-4 * asked.abs().max_element().max(1.0);
    if placed.distance(asked) > tolerance {
        return Err(format!(
            "{}: the edit would place {} at {placed:.4} instead of {asked:.4}",
            shot.source.display(),
            edit.what()
        ));
    }
    Ok(())
}

/// The `frame` query parameter, checked against the shot's range (the first frame without).
fn frame_param(query: &str, shot: &Shot) -> Result<i64, String> {
    let Some(value) = query
        .split('&')
        .find_map(|kv| kv.strip_prefix("frame="))
        .filter(|v| !v.is_empty())
    else {
        return Ok(shot.frames.first);
    };
    let frame: i64 = value
        .parse()
        .map_err(|_| format!("frame: expected a whole number, got {value:?}"))?;
    if !(shot.frames.first..=shot.frames.last).contains(&frame) {
        return Err(format!(
            "frame: {frame} is outside the shot's frames {}-{}",
            shot.frames.first, shot.frames.last
        ));
    }
    Ok(frame)
}

/// Opens `url` in the desktop's browser, if there is one (best effort).
fn open_browser(url: &str) {
    for opener in ["xdg-open", "open"] {
        if std::process::Command::new(opener)
            .arg(url)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .is_ok()
        {
            return;
        }
    }
}
