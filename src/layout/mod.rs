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
mod scene_json;
mod shot_file;

use anyhow::Context;
use clap::Args;
use rift_render::Scene;
use rift_render::rift_fx::Shot;
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::Duration;
use tiny_http::{Header, Method, Request, Response, Server};

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
const FILES: [(&str, &str, &[u8]); 5] = [
    (
        "/",
        "text/html; charset=utf-8",
        include_bytes!("../../assets/layout/index.html"),
    ),
    (
        "/app.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../../assets/layout/app.js"),
    ),
    (
        "/vendor/three.module.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../../assets/layout/vendor/three.module.js"),
    ),
    (
        "/vendor/three.core.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../../assets/layout/vendor/three.core.js"),
    ),
    (
        "/vendor/OrbitControls.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../../assets/layout/vendor/OrbitControls.js"),
    ),
];

/// Serves the page until Ctrl-C (or SIGTERM).
pub fn run(args: LayoutArgs) -> anyhow::Result<()> {
    let shot = Shot::load(&args.shot)?;
    let frame = args.frame.unwrap_or(shot.frames.first);
    if !(shot.frames.first..=shot.frames.last).contains(&frame) {
        anyhow::bail!(
            "--frame: {frame} is outside the shot's frames {}-{}",
            shot.frames.first,
            shot.frames.last
        );
    }
    let server = Server::http(("127.0.0.1", args.port)).map_err(|e| {
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
    let port = server
        .server_addr()
        .to_ip()
        .map(|a| a.port())
        .context("the server has no IP address")?;
    let url = format!("http://127.0.0.1:{port}/?frame={frame}");
    println!("rift layout: {} at {url} (Ctrl-C stops)", shot.name);
    if !args.no_browser {
        open_browser(&url);
    }
    let stop = crate::resume::stop_on_signals()?;
    let file = shot_file::ShotFile::open(&args.shot).map_err(anyhow::Error::msg)?;
    let mut state = State {
        shot,
        file,
        cached: None,
        check: None,
    };
    while !stop.load(Ordering::SeqCst) {
        match server.recv_timeout(Duration::from_millis(200)) {
            Ok(Some(request)) => state.answer(request, port),
            Ok(None) => {}
            Err(e) => eprintln!("rift layout: {e}"),
        }
    }
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

/// The largest request body read (an edit is a few hundred bytes).
const MAX_BODY: u64 = 64 << 10;

impl State {
    /// Answers one request (errors in the answer are the browser's to see, never fatal).
    fn answer(&mut self, mut request: Request, port: u16) {
        let response = if !loopback(&request, port) {
            text(
                403,
                "rift layout answers only requests to its own loopback address",
            )
        } else if *request.method() == Method::Post {
            let mut body = String::new();
            let reader = std::io::Read::take(request.as_reader(), MAX_BODY);
            match std::io::Read::read_to_string(&mut { reader }, &mut body) {
                Ok(_) => self.post(request.url(), &body),
                Err(_) => text(400, "the body is not UTF-8 text"),
            }
        } else if *request.method() != Method::Get {
            text(405, "only GET and POST are served")
        } else {
            self.route(request.url())
        };
        // The browser may have gone; nothing to do then.
        let _ = request.respond(response);
    }

    fn route(&mut self, url: &str) -> Response<std::io::Cursor<Vec<u8>>> {
        let (path, query) = url.split_once('?').unwrap_or((url, ""));
        if path == "/api/scene" {
            return match frame_param(query, &self.shot) {
                Ok(frame) => self.scene(frame),
                Err(message) => text(400, &message),
            };
        }
        if path == "/api/render" {
            return match check::Request::parse(query, &self.shot) {
                Ok(request) => match check::render(&self.shot, &request, &mut self.check) {
                    Ok(png) => with_type(Response::from_data(png), "image/png"),
                    Err(message) => json_error(422, &message),
                },
                Err(message) => text(400, &message),
            };
        }
        match FILES.iter().find(|(p, _, _)| *p == path) {
            Some((_, kind, bytes)) => with_type(Response::from_data(bytes.to_vec()), kind),
            None => text(404, &format!("{path}: not found")),
        }
    }

    /// The scene JSON at `frame` (a shot that fails to build answers 422 with the error, file
    /// and key included).
    fn scene(&mut self, frame: i64) -> Response<std::io::Cursor<Vec<u8>>> {
        if let Some((f, json)) = &self.cached
            && *f == frame
        {
            return with_type(Response::from_string(json.clone()), "application/json");
        }
        match Scene::build(&self.shot, frame) {
            Ok(scene) => {
                let json = scene_json::scene(&self.shot, &scene, frame, &self.file).to_string();
                self.cached = Some((frame, json.clone()));
                with_type(Response::from_string(json), "application/json")
            }
            Err(e) => json_error(422, &e.to_string()),
        }
    }
}

impl State {
    /// Answers a POST: an edit, a save or a revert.
    fn post(&mut self, url: &str, body: &str) -> Response<std::io::Cursor<Vec<u8>>> {
        match url {
            "/api/edit" => self.edit(body),
            "/api/save" => match self.file.save() {
                Ok(()) => {
                    let saved = self.file.path().display().to_string();
                    self.cached = None;
                    json(&serde_json::json!({ "saved": saved }))
                }
                Err(message) => json_error(422, &message),
            },
            "/api/revert" => match self.file.revert() {
                Ok(shot) => {
                    self.shot = shot;
                    self.cached = None;
                    self.check = None;
                    json(&serde_json::json!({ "reverted": true }))
                }
                Err(message) => json_error(422, &message),
            },
            _ => text(405, "POST goes to /api/edit, /api/save or /api/revert"),
        }
    }

    /// Applies an edit (a JSON [`edit::Edit`]) once the edited shot builds at the edit's frame
    /// and places what was moved where it was asked: 200 with that frame's scene, 400 for a
    /// malformed body, 422 (with the reason, file and key) otherwise, the shot unchanged.
    fn edit(&mut self, body: &str) -> Response<std::io::Cursor<Vec<u8>>> {
        let edit: edit::Edit = match serde_json::from_str(body) {
            Ok(e) => e,
            Err(e) => return json_error(400, &format!("the edit: {e}")),
        };
        let frame = edit.frame();
        if let Err(message) = frame_param(&format!("frame={frame}"), &self.shot) {
            return json_error(400, &message);
        }
        let checked = self.file.edited(&edit, &self.shot).and_then(|(doc, shot)| {
            let scene = Scene::build(&shot, frame).map_err(|e| e.to_string())?;
            landed(&edit, &shot, &scene, frame)?;
            Ok((doc, shot, scene))
        });
        match checked {
            Ok((doc, shot, scene)) => {
                self.file.keep(doc);
                self.shot = shot;
                self.check = None;
                let json = scene_json::scene(&self.shot, &scene, frame, &self.file).to_string();
                self.cached = Some((frame, json.clone()));
                with_type(Response::from_string(json), "application/json")
            }
            Err(message) => json_error(422, &message),
        }
    }
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
            let o = scene.id_names.iter().position(|n| n == name);
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

fn json(value: &serde_json::Value) -> Response<std::io::Cursor<Vec<u8>>> {
    with_type(Response::from_string(value.to_string()), "application/json")
}

fn json_error(status: u16, message: &str) -> Response<std::io::Cursor<Vec<u8>>> {
    let body = serde_json::json!({ "error": message }).to_string();
    with_type(
        Response::from_string(body).with_status_code(status),
        "application/json",
    )
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

/// True when the request's `Host` (and `Origin`, if any) name this server's loopback address.
fn loopback(request: &Request, port: u16) -> bool {
    let allowed = |authority: &str| {
        ["127.0.0.1", "localhost", "[::1]"]
            .iter()
            .any(|host| authority == format!("{host}:{port}"))
    };
    let header = |name: &str| {
        request
            .headers()
            .iter()
            .find(|h| h.field.as_str().as_str().eq_ignore_ascii_case(name))
            .map(|h| h.value.as_str().to_owned())
    };
    let host_ok = header("Host").is_some_and(|h| allowed(&h));
    let origin_ok = header("Origin").is_none_or(|o| o.strip_prefix("http://").is_some_and(allowed));
    host_ok && origin_ok
}

fn text(status: u16, message: &str) -> Response<std::io::Cursor<Vec<u8>>> {
    with_type(
        Response::from_string(format!("{message}\n")).with_status_code(status),
        "text/plain; charset=utf-8",
    )
}

fn with_type(
    response: Response<std::io::Cursor<Vec<u8>>>,
    kind: &str,
) -> Response<std::io::Cursor<Vec<u8>>> {
    let header = Header::from_bytes("Content-Type", kind).expect("a valid header");
    let nosniff = Header::from_bytes("X-Content-Type-Options", "nosniff").expect("a valid header");
    response.with_header(header).with_header(nosniff)
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
