//! `rift layout`: its API and what it refuses (answered by a real server on a free loopback
//! port), and the page in headless Chromium (skipped, saying so, where Chromium or the test's
//! Node packages are missing; tests/setup.sh installs both).

use crate::common;

use common::root;
use rift_render::frame::film::{read_exr_layer, relative_mse};
use std::collections::HashMap;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::Sender;
use std::sync::{Arc, Mutex, OnceLock};

/// A running `rift layout` and its port; stopped with SIGINT when dropped.
struct Layout {
    child: Child,
    port: u16,
}

/// The port in the URL a starting `rift layout` prints on its first line, or that line.
fn read_port(child: &mut Child) -> Result<u16, String> {
    let mut line = String::new();
    BufReader::new(child.stdout.as_mut().unwrap())
        .read_line(&mut line)
        .unwrap();
    line.split("127.0.0.1:")
        .nth(1)
        .and_then(|rest| rest.split('/').next())
        .and_then(|p| p.parse().ok())
        .ok_or(line)
}

impl Layout {
    fn start(shot: &Path, extra: &[&str]) -> Self {
        Self::start_env(shot, extra, &[])
    }

    /// As [`Layout::start`], with `env` added to the server's environment.
    fn start_env(shot: &Path, extra: &[&str], env: &[(&str, &Path)]) -> Self {
        let mut child = Command::new(env!("CARGO_BIN_EXE_rift"))
            .arg("layout")
            .arg(shot)
            .args(["--port", "0", "--no-browser"])
            .args(extra)
            .envs(env.iter().copied())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let port = read_port(&mut child).unwrap_or_else(|line| panic!("no URL in {line:?}"));
        Self { child, port }
    }

    /// Sends `request` (raw bytes) and returns the status code and body.
    fn raw(&self, request: &str) -> (u16, String) {
        let (status, _, body) = self.exchange(request);
        (status, String::from_utf8_lossy(&body).into_owned())
    }

    /// Sends `request` and returns the status code, the headers (lower-cased names) and the
    /// body's bytes.
    fn exchange(&self, request: &str) -> (u16, Vec<(String, String)>, Vec<u8>) {
        let mut stream = TcpStream::connect(("127.0.0.1", self.port)).unwrap();
        stream.write_all(request.as_bytes()).unwrap();
        let mut bytes = Vec::new();
        stream.read_to_end(&mut bytes).unwrap();
        let split = bytes
            .windows(4)
            .position(|w| w == b"\r\n\r\n")
            .map_or(bytes.len(), |at| at + 4);
        let head = String::from_utf8_lossy(&bytes[..split]).into_owned();
        let status = head
            .split_whitespace()
            .nth(1)
            .and_then(|s| s.parse().ok())
            .unwrap_or(0);
        let headers = head
            .lines()
            .skip(1)
            .filter_map(|line| line.split_once(':'))
            .map(|(k, v)| (k.trim().to_ascii_lowercase(), v.trim().to_owned()))
            .collect();
        (status, headers, bytes[split..].to_vec())
    }

    /// POST `body` to `path`; returns the status code and body.
    fn post(&self, path: &str, body: &str) -> (u16, String) {
        self.raw(&format!(
            "POST {path} HTTP/1.0\r\nHost: 127.0.0.1:{}\r\nContent-Length: {}\r\n\r\n{body}",
            self.port,
            body.len()
        ))
    }

    /// GET `path` with the server's own Host and `headers`.
    fn get(&self, path: &str, headers: &str) -> (u16, String) {
        self.raw(&format!(
            "GET {path} HTTP/1.0\r\nHost: 127.0.0.1:{}\r\n{headers}\r\n",
            self.port
        ))
    }

    fn url(&self) -> String {
        format!("http://127.0.0.1:{}/", self.port)
    }
}

impl Drop for Layout {
    fn drop(&mut self) {
        // Only a child not yet reaped is signalled: a reaped one's PID may already belong to
        // another test's server.
        if let Ok(None) = self.child.try_wait() {
            let _ = Command::new("kill")
                .args(["-INT", &self.child.id().to_string()])
                .status();
            let _ = self.child.wait();
        }
    }
}

#[test]
fn the_api_serves_the_scene_and_refuses_what_it_should() {
    let shot = root().join("examples/shots/showcase.toml");
    let layout = Layout::start(&shot, &[]);
    let (status, page) = layout.get("/", "");
    assert_eq!(status, 200);
    assert!(page.contains("importmap") && page.contains("/app.js"));
    for path in [
        "/app.js",
        "/vendor/three.module.js",
        "/vendor/OrbitControls.js",
    ] {
        assert_eq!(layout.get(path, "").0, 200, "{path}");
    }
    let (status, body) = layout.get("/api/scene?frame=12", "");
    assert_eq!(status, 200, "{body}");
    let scene: serde_json::Value = serde_json::from_str(&body).unwrap();
    assert_eq!(scene["frame"], 12);
    let names: Vec<&str> = scene["objects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|o| o["name"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        [
            "room",
            "pillar",
            "walker",
            "walker_there",
            "walker_reach",
            "orb",
            "orb_pillar",
            "orb_there"
        ]
    );
    for o in scene["objects"].as_array().unwrap() {
        let n = o["positions"].as_array().unwrap().len();
        assert!(n > 0 && n % 9 == 0, "{}: {n} coordinates", o["name"]);
    }
    // The character deforms: the page gets its shape at the frame asked for, and its copy
    // (through an opening without a time offset) the same shape.
    let shape = |scene: &serde_json::Value, name: &str| -> Vec<f64> {
        let object = scene["objects"]
            .as_array()
            .unwrap()
            .iter()
            .find(|o| o["name"] == name)
            .unwrap();
        let positions = object["positions"].as_array().unwrap();
        positions.iter().map(|x| x.as_f64().unwrap()).collect()
    };
    let (_, earlier) = layout.get("/api/scene?frame=6", "");
    let earlier: serde_json::Value = serde_json::from_str(&earlier).unwrap();
    let moved = shape(&earlier, "walker")
        .iter()
        .zip(shape(&scene, "walker"))
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(
        moved > 0.3,
        "the character's shape moved {moved} m from frame 6 to 12"
    );
    assert_eq!(shape(&scene, "walker"), shape(&scene, "walker_there"));
    assert_eq!(shape(&scene, "walker"), shape(&scene, "walker_reach"));
    assert_eq!(scene["openings"].as_array().unwrap().len(), 4);
    let rings = scene["rings"].as_array().unwrap();
    assert_eq!(rings.len(), 4, "one ring per opening");
    for ring in rings {
        assert!(ring["opening"].is_u64());
        assert!(ring["points"].as_array().unwrap().len() > 1000);
    }
    // Bad requests: 4xx, and the server goes on.
    for (path, headers, want) in [
        ("/api/scene?frame=abc", "", 400),
        ("/api/scene?frame=100000", "", 400),
        ("/nothing/here", "", 404),
        ("/", "Origin: http://evil.example\r\n", 403),
        ("/", "Origin: http://127.0.0.1:1\r\n", 403),
    ] {
        assert_eq!(layout.get(path, headers).0, want, "{path} {headers}");
    }
    let (status, _) = layout.raw("GET / HTTP/1.0\r\nHost: evil.example\r\n\r\n");
    assert_eq!(status, 403, "a foreign Host (DNS rebinding)");
    assert_eq!(layout.post("/api/scene", "").0, 405);
    let (status, _) = layout.raw(&format!(
        "DELETE / HTTP/1.0\r\nHost: 127.0.0.1:{}\r\n\r\n",
        layout.port
    ));
    assert_eq!(status, 405);
    let big = "x".repeat(100 << 10);
    assert_eq!(
        layout.post("/api/edit", &big).0,
        413,
        "a body far larger than an edit"
    );
    let (status, _) = layout.raw("THIS IS NOT HTTP\r\n\r\n");
    assert!(
        (400..500).contains(&status) || status == 0,
        "garbage: {status}"
    );
    assert_eq!(layout.get("/api/scene", "").0, 200, "still serving");
}

#[test]
fn a_port_in_use_a_bad_shot_and_ctrl_c() {
    // A port another program holds.
    let held = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = held.local_addr().unwrap().port().to_string();
    let shot = root().join("examples/shots/showcase.toml");
    let out = Command::new(env!("CARGO_BIN_EXE_rift"))
        .args([
            "layout",
            shot.to_str().unwrap(),
            "--no-browser",
            "--port",
            &port,
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("cannot listen") && err.contains(&port),
        "{err}"
    );
    // A shot whose scene fails to build: the API answers 422 with the file and the key.
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(&shot)
        .unwrap()
        .replace(
            "../assets/",
            &format!("{}/", root().join("examples/assets").display()),
        )
        .replace("mesh = \"", "mesh = \"missing_");
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, text).unwrap();
    let mut layout = Layout::start(&bad, &[]);
    let (status, body) = layout.get("/api/scene", "");
    assert_eq!(status, 422, "{body}");
    assert!(
        body.contains("missing_") && body.contains("error"),
        "{body}"
    );
    // Ctrl-C stops it cleanly.
    common::signal(&layout.child, "INT");
    let status = layout.child.wait().unwrap();
    assert!(status.success(), "{status:?}");
}

/// Visits `url` with `args` (the options of tests/browser/layout.mjs) in the tests' headless
/// Chromium and returns what the page reports, or `None` (with a message) where Chromium or the
/// Node packages are missing.
fn run_page(url: &str, args: &[&str]) -> Option<serde_json::Value> {
    let modules = root().join("tests/browser/node_modules/playwright-core");
    if !Path::new("/usr/bin/chromium").exists() || !modules.exists() {
        eprintln!("skipped: Chromium or tests/browser/node_modules missing (run tests/setup.sh)");
        return None;
    }
    let argv: Vec<&str> = std::iter::once(url).chain(args.iter().copied()).collect();
    let answer = Browser::shared().visit(&argv);
    if let Some(error) = answer.get("error") {
        panic!("{url} {args:?}: {error}");
    }
    Some(answer["result"].clone())
}

/// One headless Chromium for every test of this binary (`layout.mjs --serve`), started at the
/// first visit: a browser's start and its software-GL shader compilations cost about 6 s of
/// processor time a visit, twice what each further visit in the same browser costs. Each visit
/// has a fresh browser context; visits from tests running at once run at once.
struct Browser {
    /// The service, never waited for: it ends with this process.
    _service: Child,
    /// The service's stdin and the next request's id.
    requests: Mutex<(ChildStdin, u64)>,
    /// Where each request still unanswered wants its answer.
    waiting: Arc<Mutex<HashMap<u64, Sender<serde_json::Value>>>>,
}

impl Browser {
    fn shared() -> &'static Browser {
        static SHARED: OnceLock<Browser> = OnceLock::new();
        SHARED.get_or_init(Browser::start)
    }

    /// Starts the service and the thread that hands its answers out. It ends when this
    /// process does (its stdin closes).
    fn start() -> Browser {
        let mut child = Command::new("node")
            .arg(root().join("tests/browser/layout.mjs"))
            .arg("--serve")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .unwrap();
        let waiting: Arc<Mutex<HashMap<u64, Sender<serde_json::Value>>>> = Arc::default();
        let answers = BufReader::new(child.stdout.take().unwrap());
        let hand_out = Arc::clone(&waiting);
        std::thread::spawn(move || {
            // A line that is not an answer (something the service printed) is passed over;
            // a panic here would leave every waiting test waiting for ever.
            for line in answers.lines().map_while(Result::ok) {
                let answer = serde_json::from_str::<serde_json::Value>(&line).ok();
                let Some(id) = answer.as_ref().and_then(|a| a["id"].as_u64()) else {
                    eprintln!("browser service: not an answer: {line}");
                    continue;
                };
                let answer = answer.unwrap_or_default();
                let to = hand_out
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .remove(&id);
                to.map(|to| to.send(answer));
            }
            // The service ended: every request still waiting fails.
            hand_out.lock().unwrap_or_else(|e| e.into_inner()).clear();
        });
        Browser {
            requests: Mutex::new((child.stdin.take().unwrap(), 0)),
            waiting,
            _service: child,
        }
    }

    /// The service's answer to a visit with `argv` (the URL, then options).
    fn visit(&self, argv: &[&str]) -> serde_json::Value {
        let (to, answer) = std::sync::mpsc::channel();
        {
            let mut requests = self.requests.lock().unwrap_or_else(|e| e.into_inner());
            let id = requests.1;
            requests.1 += 1;
            // Registered before it is sent, so the answer always finds it.
            (self.waiting.lock().unwrap_or_else(|e| e.into_inner())).insert(id, to);
            let line = serde_json::json!({ "id": id, "argv": argv });
            writeln!(requests.0, "{line}").unwrap();
        }
        answer.recv().expect(
            "the browser service (tests/browser/layout.mjs --serve) ended; its errors are above",
        )
    }
}

/// The page's report: its state and how much each view draws.
fn browse(url: &str) -> Option<serde_json::Value> {
    run_page(url, &[])
}

#[test]
fn the_page_draws_the_shot_and_shows_errors() {
    let shot = root().join("examples/shots/showcase.toml");
    let layout = Layout::start(&shot, &["--frame", "12"]);
    let Some(page) = browse(&format!("{}?frame=12", layout.url())) else {
        return;
    };
    eprintln!("layout page: {page}");
    assert_eq!(page["error"], "");
    assert_eq!(page["pageErrors"].as_array().unwrap().len(), 0, "{page}");
    assert_eq!(page["frame"], 12);
    assert_eq!(page["objects"], 8);
    assert_eq!(page["openings"], 4);
    // Both views draw the set over a good part of their area.
    assert!(page["shotCoverage"].as_f64().unwrap() > 0.3, "{page}");
    assert!(page["orbitCoverage"].as_f64().unwrap() > 0.1, "{page}");
    drop(layout);
    // A shot that fails to build shows its error, file and key, on the page.
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(&shot)
        .unwrap()
        .replace(
            "../assets/",
            &format!("{}/", root().join("examples/assets").display()),
        )
        .replace("material = \"chrome\"", "material = \"unobtainium\"");
    std::fs::write(dir.path().join("bad.toml"), text).unwrap();
    let layout = Layout::start(&dir.path().join("bad.toml"), &[]);
    let page = browse(&layout.url()).unwrap();
    assert_eq!(page["errorShown"], true, "{page}");
    let message = page["errorText"].as_str().unwrap();
    assert!(
        message.contains("bad.toml")
            && message.contains(".material")
            && message.contains("unobtainium"),
        "{message}"
    );
}

/// The `[render]` keys of [`still_variant`]: `depth` levels of openings, and no bounces (the
/// object IDs the tests compare are the camera paths' first hits).
fn render_keys(depth: u32) -> String {
    format!("max_portal_depth = {depth}\nmax_bounces = 0\n")
}

/// `example` (under examples/shots) as a still, pinhole, mono shot of `width` x `height` with
/// `depth` levels of openings, its asset paths made absolute, written into `dir`.
fn still_variant(
    dir: &Path,
    example: &str,
    width: u32,
    height: u32,
    depth: u32,
) -> std::path::PathBuf {
    let source = root().join("examples/shots").join(example);
    still_variant_of(dir, &source, example, [width, height], depth)
}

/// [`still_variant`] of the shot file `source`, written into `dir` as `name`.
fn still_variant_of(
    dir: &Path,
    source: &Path,
    name: &str,
    [width, height]: [u32; 2],
    depth: u32,
) -> std::path::PathBuf {
    let text = std::fs::read_to_string(source).unwrap();
    let mut out = String::new();
    let mut skip_section = false;
    for line in text.lines() {
        let trimmed = line.trim_start();
        if trimmed.starts_with('[') {
            skip_section = trimmed.starts_with("[camera.stereo]");
        }
        if skip_section
            || trimmed.starts_with("shutter")
            || trimmed.starts_with("fstop")
            || trimmed.starts_with("max_portal_depth")
            || trimmed.starts_with("max_bounces")
        {
            continue;
        }
        let line = if trimmed.starts_with("resolution") {
            format!("resolution = [{width}, {height}]")
        } else {
            line.replace(
                "../assets/",
                &format!("{}/", root().join("examples/assets").display()),
            )
        };
        out += &line;
        out += "\n";
        if trimmed == "[shot]" {
            out += "shutter = [0.0, 0.0]\n";
        }
        if trimmed == "[render]" {
            out += &render_keys(depth);
        }
    }
    if !out.contains("[render]") {
        out += &format!("[render]\n{}", render_keys(depth));
    }
    let path = dir.join(name);
    std::fs::write(&path, out).unwrap();
    path
}

#[test]
fn the_preview_through_openings_matches_the_path_tracers_object_ids() {
    // For two shots and two camera poses each: the page's ID pass (objects flat-coloured,
    // openings followed as deep as the shot allows: two levels in the showcase, whose openings
    // see each other, one in through_portal) against the path tracer's Cryptomatte at the same
    // frame
    // (the object covering at least half of each pixel). Pixels where a ring's strands show in
    // the render are left out: the preview draws strands as hairlines.
    let (w, h) = (256u32, 144u32);
    let dir = tempfile::tempdir().unwrap();
    for (example, frames, depth) in [
        ("showcase.toml", [6, 18], 2),
        ("through_portal.toml", [4, 16], 1),
        // An opening of opacity 0 (it teleports nothing) and strands the camera cannot see.
        ("ring_on_wall.toml", [1, 1], 1),
        // Doorways in walls, each seeing out of the other.
        ("portal_pair.toml", [1001, 1060], 2),
    ] {
        let shot = still_variant(dir.path(), example, w, h, depth);
        let layout = Layout::start(&shot, &[]);
        for frame in frames {
            let url = format!("{}?frame={frame}&depth={depth}", layout.url());
            let Some(preview) = browse_ids(&url, w, h) else {
                return;
            };
            let layer = render_ids(dir.path(), &shot, frame);
            let scene = scene_names(&layout, frame);
            compare_ids(
                &format!("{example} frame {frame}"),
                &preview,
                &layer,
                &scene,
                &[],
            );
        }
    }
}

#[test]
fn the_page_draws_every_instance_of_an_instanced_usd_prim_where_the_renderer_places_it() {
    // The USD test set's PointInstancer of pebbles (one prototype, an instance hidden by
    // invisibleIds): the server sends each instance's placement, and the page's ID pass, every
    // instance drawn, matches the path tracer's Cryptomatte.
    let dir = tempfile::tempdir().unwrap();
    crate::usd_scenes::make_set(dir.path());
    let (w, h) = (192u32, 128u32);
    let source = dir.path().join("set_usda.toml");
    let shot = still_variant_of(dir.path(), &source, "still_set.toml", [w, h], 1);
    let layout = Layout::start(&shot, &[]);
    let (status, body) = layout.get("/api/scene?frame=1", "");
    assert_eq!(status, 200, "{body}");
    let scene: serde_json::Value = serde_json::from_str(&body).unwrap();
    let instanced: Vec<(&str, usize)> = (scene["objects"].as_array().unwrap().iter())
        .filter_map(|o| {
            let n = o["instances"].as_array().unwrap().len();
            (n > 0).then(|| (o["name"].as_str().unwrap(), n / 8))
        })
        .collect();
    // The two crates are native instances of one prototype; of the pebbles (tests/support/
    // usd_set.py) four show, the moving one an object of its own; of the blocks one is a
    // similarity (the mirrored one is baked as a mesh, and the hidden one left out).
    let expected = [
        ("/World/Crate0/Body", 2),
        ("/World/Pebbles/Pebble", 3),
        ("/World/Pebbles/Block/Body", 1),
        ("/World/Pebbles/Pebble", 1),
    ];
    assert_eq!(instanced, expected);
    let url = format!("{}?frame=1", layout.url());
    let Some(preview) = browse_ids(&url, w, h) else {
        return;
    };
    let layer = render_ids(dir.path(), &shot, 1);
    let instances = instance_ids(&layout, 1);
    let names = scene_names(&layout, 1);
    compare_ids("USD set", &preview, &layer, &names, &instances);
}

/// Per object of the scene the server builds at `frame`, the Cryptomatte IDs of its instances
/// (each instance of a USD prototype has its own; the page draws them as their object).
fn instance_ids(layout: &Layout, frame: i64) -> Vec<Vec<f32>> {
    use rift_render::frame::cryptomatte::id;
    let (_, body) = layout.get(&format!("/api/scene?frame={frame}"), "");
    let scene: serde_json::Value = serde_json::from_str(&body).unwrap();
    (scene["objects"].as_array().unwrap().iter())
        .map(|o| {
            let names = o["instanceNames"].as_array().unwrap();
            names.iter().map(|n| id(n.as_str().unwrap())).collect()
        })
        .collect()
}

/// The page's ID pass at `w` x `h`, or `None` where the browser tests cannot run.
fn browse_ids(url: &str, w: u32, h: u32) -> Option<Vec<i64>> {
    browse_ids_from(url, w, h, None).map(|(ids, _)| ids)
}

/// [`browse_ids`] after moving the shot camera to `camera` (position, then a point it looks
/// at), with the milliseconds from the move to the redrawn view.
fn browse_ids_from(url: &str, w: u32, h: u32, camera: Option<[f32; 6]>) -> Option<(Vec<i64>, f64)> {
    let (w, h) = (w.to_string(), h.to_string());
    let mut args = vec!["--ids", w.as_str(), h.as_str()];
    let list = camera.map(|c| c.map(|v| v.to_string()).join(","));
    if let Some(list) = &list {
        args.extend(["--camera", list.as_str()]);
    }
    let v = run_page(url, &args)?;
    let errors = v["pageErrors"].as_array().unwrap();
    assert!(errors.is_empty(), "{errors:?}");
    let ids = v["ids"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i.as_i64().unwrap())
        .collect();
    Some((ids, v["dragMs"].as_f64().unwrap_or(0.0)))
}

/// The object names (in ID order) of the scene the server builds at `frame`.
fn scene_names(layout: &Layout, frame: i64) -> Vec<String> {
    let (_, body) = layout.get(&format!("/api/scene?frame={frame}"), "");
    let scene: serde_json::Value = serde_json::from_str(&body).unwrap();
    scene["objects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|o| o["name"].as_str().unwrap().to_owned())
        .collect()
}

/// Per object with enough pixels: IoU of the preview's pixels and the render's (rank-0 ID
/// covering at least half the pixel: the object's, or one of its `instances`' where they have
/// their own), over pixels no ring touches in the render, and how far apart their edges are
/// (95th percentile of each edge pixel's distance to the other's edge).
fn compare_ids(
    what: &str,
    preview: &[i64],
    layer: &rift_render::frame::film::ExrLayer,
    names: &[String],
    instances: &[Vec<f32>],
) {
    use rift_render::frame::cryptomatte::id;
    let ids: Vec<f32> = names.iter().map(|n| id(n)).collect();
    // Each object's IDs in the render: its own, and its instances'.
    let ids_of =
        |o: usize| std::iter::once(ids[o]).chain(instances.get(o).into_iter().flatten().copied());
    let known: Vec<f32> = (0..names.len()).flat_map(ids_of).collect();
    // Whether a render ID belongs to object `o`, or to another of its name (objects of one
    // name are one region to Cryptomatte).
    let of_object = |rendered: f32, o: usize| {
        (0..names.len()).any(|k| names[k] == names[o] && ids_of(k).any(|i| i == rendered))
    };
    let channel = |name: &str| &layer.channels[name];
    let rank_ids: Vec<&Vec<f32>> = (0..3)
        .flat_map(|l| ["R", "B"].map(move |c| format!("CryptoObject{l:02}.{c}")))
        .map(|n| channel(&n))
        .collect();
    let (id0, cover0) = (channel("CryptoObject00.R"), channel("CryptoObject00.G"));
    let ring = |p: usize| {
        rank_ids
            .iter()
            .any(|r| r[p] != 0.0 && !known.contains(&r[p]))
    };
    assert_eq!(preview.len(), id0.len(), "{what}: image sizes");
    let mut checked = 0;
    // Cryptomatte knows objects by name: objects of one name (the parts of a USD prim that
    // rift splits, say) are one region in both.
    let named = |index: i64, o: usize| index >= 0 && names[index as usize] == names[o];
    // Each object, then "nothing" (−1): where the openings' depth ends, the sky, and so on.
    let labels = names.iter().map(String::as_str).chain(["nothing"]);
    for (o, name) in labels.enumerate() {
        if o < names.len() && names[..o].contains(&names[o]) {
            continue;
        }
        let (mut both, mut either) = (0usize, 0usize);
        for p in 0..preview.len() {
            if ring(p) {
                continue;
            }
            let (in_preview, in_render) = if o < names.len() {
                (
                    named(preview[p], o),
                    of_object(id0[p], o) && cover0[p] >= 0.5,
                )
            } else {
                (preview[p] == -1, cover0[p] < 0.5)
            };
            both += (in_preview && in_render) as usize;
            either += (in_preview || in_render) as usize;
        }
        // Regions too small to judge (a hundred pixels is mostly edge) are left out.
        let smallest = if o < names.len() { 100 } else { 500 };
        if either < smallest {
            continue;
        }
        let iou = both as f64 / either as f64;
        let inside_preview = |p: usize| {
            if o < names.len() {
                named(preview[p], o)
            } else {
                preview[p] == -1
            }
        };
        let inside_render = |p: usize| {
            if o < names.len() {
                of_object(id0[p], o) && cover0[p] >= 0.5
            } else {
                cover0[p] < 0.5
            }
        };
        let (w, h) = layer.size;
        let edges = edge_distances(w, h, &inside_preview, &inside_render, &ring);
        let p95 = edges.get(edges.len() * 95 / 100).copied().unwrap_or(0.0);
        eprintln!(
            "{what}: {name}: IoU {iou:.4} over {either} pixels; edges within {p95:.2} px \
             (95%, {} edge pixels)",
            edges.len()
        );
        // IoU judges regions that are mostly inside; a sliver (an object half through an
        // opening, say) is mostly edge, and its edges are judged instead.
        if edges.len() * 2 <= either {
            assert!(iou >= 0.97, "{what}: {name}: IoU {iou:.4}");
        }
        assert!(p95 <= 1.5, "{what}: {name}: edges {p95:.2} px apart");
        checked += 1;
    }
    assert!(checked >= 1, "{what}: no object large enough to compare");
}

/// A shot `name` of frames `frames`, its camera at the origin looking down −Z at `w` x `h`,
/// following `depth` levels of openings, with a glowing grey wall (`wall.obj`, which the test
/// writes) and nothing else yet: tests add their objects and openings.
fn glowing_wall_shot(name: &str, frames: [i64; 2], w: u32, h: u32, depth: u32) -> String {
    format!(
        r#"
[shot]
name = "{name}"
fps = 24.0
frames = [{}, {}]
shutter = [0.0, 0.0]
[camera]
resolution = [{w}, {h}]
fov_degrees = 40.0
[camera.transform]
position = [0.0, 0.0, 0.0]
[render]
max_portal_depth = {depth}
[[material]]
name = "grey"
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]
emission = [1.0, 1.0, 1.0]
[[object]]
name = "wall"
mesh = "wall.obj"
material = "grey"
"#,
        frames[0], frames[1]
    )
}

#[test]
fn the_preview_follows_exactly_the_shots_levels_of_openings() {
    // An opening 3 m ahead whose there side is 1 m behind the camera, facing the same way:
    // each level of it shows the next, smaller, until the shot's portal depth ends the paths.
    // For depths 1 to 3, the region that shows nothing must be the same disk in the preview as
    // in the path tracer, and shrink level by level.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("wall.obj"),
        "v -30 -30 -6\nv 30 -30 -6\nv 30 30 -6\nv -30 30 -6\nf 1 2 3 4\n",
    )
    .unwrap();
    let (w, h) = (256u32, 144u32);
    let mut areas = Vec::new();
    for depth in 1..=3 {
        let shot = dir.path().join(format!("regress{depth}.toml"));
        std::fs::write(
            &shot,
            glowing_wall_shot("regress", [1, 1], w, h, depth)
                + r#"[[portal]]
name = "A"
here = { position = [0.0, 0.0, -3.0] }
there = { position = [0.0, 0.0, 1.0] }
[portal.surface]
radius = 1.0
"#,
        )
        .unwrap();
        let layout = Layout::start(&shot, &[]);
        let Some(preview) = browse_ids(&format!("{}?depth={depth}", layout.url()), w, h) else {
            return;
        };
        let layer = render_ids(dir.path(), &shot, 1);
        let cover0 = &layer.channels["CryptoObject00.G"];
        let (mut both, mut either, mut area) = (0, 0, 0);
        for p in 0..preview.len() {
            let (a, b) = (preview[p] == -1, cover0[p] < 0.5);
            both += (a && b) as usize;
            either += (a || b) as usize;
            area += a as usize;
        }
        let iou = both as f64 / either.max(1) as f64;
        eprintln!("depth {depth}: nothing over {area} preview pixels, IoU {iou:.4}");
        assert!(
            iou > 0.95 && area > 200,
            "depth {depth}: IoU {iou:.4} over {area} pixels"
        );
        areas.push(area);
    }
    assert!(areas[0] > areas[1] && areas[1] > areas[2], "{areas:?}");
}

#[test]
fn moving_the_camera_moves_the_preview_through_openings_with_it() {
    // The shot camera dragged (through the page's API) to a new pose: the preview's IDs, seen
    // through both openings of the showcase, match a render from that pose.
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (256u32, 144u32);
    let shot = still_variant(dir.path(), "showcase.toml", w, h, 2);
    let pose = [0.9f32, 1.4, 0.6, -0.4, 1.45, -3.0];
    let layout = Layout::start(&shot, &[]);
    let url = format!("{}?frame=12&depth=2", layout.url());
    let Some((preview, drag_ms)) = browse_ids_from(&url, w, h, Some(pose)) else {
        return;
    };
    eprintln!("drag to redrawn preview: {drag_ms:.0} ms");
    // The same pose as a still camera in the shot, rendered by the path tracer.
    let text = std::fs::read_to_string(&shot).unwrap();
    let start = text.find("[camera.transform]").unwrap();
    let end = text[start..].find("\n]\n").map(|e| start + e + 3).unwrap();
    let moved = format!(
        "{}[camera.transform]\nposition = [{}, {}, {}]\nlook_at = [{}, {}, {}]\n{}",
        &text[..start],
        pose[0],
        pose[1],
        pose[2],
        pose[3],
        pose[4],
        pose[5],
        &text[end..]
    );
    let moved_shot = dir.path().join("moved.toml");
    std::fs::write(&moved_shot, moved).unwrap();
    let layer = render_ids(dir.path(), &moved_shot, 12);
    let names = scene_names(&layout, 12);
    compare_ids("showcase, camera moved", &preview, &layer, &names, &[]);
}

/// Runs the page's save of the shot camera after moving it to `camera`: the server's answer
/// and the error the page shows, or `None` where the browser tests cannot run.
fn browse_save(url: &str, camera: [f32; 6]) -> Option<(serde_json::Value, String)> {
    let list = camera.map(|v| v.to_string()).join(",");
    let v = run_page(url, &["--camera", &list, "--save"])?;
    Some((
        v["saved"].clone(),
        v["shown"].as_str().unwrap_or("").to_owned(),
    ))
}

#[test]
fn a_camera_saved_from_the_page_round_trips_and_a_bad_one_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let shot = dir.path().join("showcase.toml");
    let original = std::fs::read_to_string(root().join("examples/shots/showcase.toml"))
        .unwrap()
        .replace(
            "../assets/",
            &format!("{}/", root().join("examples/assets").display()),
        );
    std::fs::write(&shot, &original).unwrap();
    let layout = Layout::start(&shot, &[]);
    let pose = [0.5f32, 1.5, 1.0, 0.0, 1.4, -3.0];
    let url = format!("{}?frame=12", layout.url());
    let Some((answer, shown)) = browse_save(&url, pose) else {
        return;
    };
    assert!(answer["saved"].is_string(), "{answer} {shown}");
    // One line added, every comment kept; the previous file kept beside it.
    let saved = std::fs::read_to_string(&shot).unwrap();
    let added: Vec<&str> = saved
        .lines()
        .filter(|l| !original.lines().any(|o| o == *l))
        .collect();
    assert_eq!(
        added,
        ["  { frame = 12, position = [0.5, 1.5, 1.0], look_at = [0.0, 1.4, -3.0] },"],
        "{saved}"
    );
    assert_eq!(original.lines().count() + 1, saved.lines().count());
    assert_eq!(
        std::fs::read_to_string(dir.path().join("showcase.toml.bak")).unwrap(),
        original
    );
    // The server and `rift render` both use the new pose.
    let (_, body) = layout.get("/api/scene?frame=12", "");
    let scene: serde_json::Value = serde_json::from_str(&body).unwrap();
    let position: Vec<f64> = scene["camera"]["position"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert!(
        (position[0] - 0.5).abs() < 1e-5 && (position[2] - 1.0).abs() < 1e-5,
        "{position:?}"
    );
    let exr = dir.path().join("saved.exr");
    let out = common::rift(
        dir.path(),
        &[
            "render",
            shot.to_str().unwrap(),
            "--frame",
            "12",
            "--res",
            "64",
            "36",
            "--spp",
            "1",
            "-o",
            exr.to_str().unwrap(),
        ],
    );
    assert!(out.status.success(), "{}", common::stderr(&out));
    let m = read_exr_layer(&exr).unwrap().world_to_camera.unwrap();
    // Imath's row-vector layout read as columns is the column-vector matrix; the camera sits
    // at the origin of camera space.
    let world_to_camera = glam::Mat4::from_cols_array(&m);
    let eye = world_to_camera.inverse().transform_point3(glam::Vec3::ZERO);
    // (at the shutter's opening, a quarter frame before the key, the smooth keys have moved
    // it by millimetres; the old path passed 1.4 m away)
    assert!(
        (eye - glam::Vec3::new(0.5, 1.5, 1.0)).length() < 0.02,
        "rendered from {eye}"
    );
    // A pose the shot cannot load (looking at its own position) is refused, on the page too,
    // and the file stays as it was.
    let before = std::fs::read_to_string(&shot).unwrap();
    let (answer, shown) = browse_save(&url, [0.5, 1.5, 1.0, 0.5, 1.5, 1.0]).unwrap();
    assert!(answer["error"].is_string(), "{answer}");
    assert!(
        shown.contains("showcase.toml") && shown.contains("look_at"),
        "{shown}"
    );
    assert_eq!(std::fs::read_to_string(&shot).unwrap(), before);
}

#[test]
fn a_save_to_a_read_only_shot_is_refused_with_its_reason() {
    // The shot on a file system mounted read-only, in a mount namespace of the test's own
    // (where the machine lets it mount, as root; skipped otherwise).
    let dir = tempfile::tempdir().unwrap();
    let ro = dir.path().join("ro");
    std::fs::create_dir(&ro).unwrap();
    let text = std::fs::read_to_string(root().join("examples/shots/showcase.toml"))
        .unwrap()
        .replace(
            "../assets/",
            &format!("{}/", root().join("examples/assets").display()),
        );
    std::fs::write(dir.path().join("showcase.toml"), text).unwrap();
    let script = format!(
        "mount -t tmpfs tmpfs {ro} && cp {src} {ro}/ && mount -o remount,ro {ro} || exit 77; \
         exec {exe} layout {ro}/showcase.toml --port 0 --no-browser",
        ro = ro.display(),
        src = dir.path().join("showcase.toml").display(),
        exe = env!("CARGO_BIN_EXE_rift"),
    );
    let mut child = Command::new("unshare")
        .args(["-m", "sh", "-c", &script])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let Ok(port) = read_port(&mut child) else {
        let _ = child.wait();
        eprintln!("skipped: this machine cannot mount a read-only file system here");
        return;
    };
    let layout = Layout { child, port };
    // The edit is taken (the shot as the server holds it changes); writing it is refused.
    let edit = r#"{"op": "pose", "target": {"kind": "camera"}, "frame": 12,
        "position": [0.5, 1.5, 1.0], "look_at": [0.0, 1.4, -3.0]}"#;
    let (status, answer) = layout.post("/api/edit", edit);
    assert_eq!(status, 200, "{answer}");
    let (status, answer) = layout.post("/api/save", "");
    assert_eq!(status, 422, "{answer}");
    assert!(answer.contains("Read-only file system"), "{answer}");
    // Malformed edits are 400s.
    for bad in [
        "{",
        r#"{"op": "pose", "frame": 12}"#,
        r#"{"op": "pose", "target": {"kind": "camera"}, "frame": 999, "position": [0, 0, 0],
            "rotation": [0, 0, 0, 1]}"#,
        r#"{"op": "teleport"}"#,
        r#"{"op": "delete_key", "target": {"kind": "wall"}, "frame": 12}"#,
    ] {
        assert_eq!(layout.post("/api/edit", bad).0, 400, "{bad}");
    }
    assert_eq!(layout.post("/api/nothing", "").0, 405);
}

/// The path tracer's render of `shot` at `frame` with Cryptomatte layers, 16 spp.
fn render_ids(dir: &Path, shot: &Path, frame: i64) -> rift_render::frame::film::ExrLayer {
    let exr = dir.join(format!(
        "{}.{frame}.ids.exr",
        shot.file_stem().unwrap().to_string_lossy()
    ));
    let out = common::rift(
        dir,
        &[
            "render",
            shot.to_str().unwrap(),
            "--frame",
            &frame.to_string(),
            "--spp",
            "16",
            "--cryptomatte",
            "-o",
            exr.to_str().unwrap(),
        ],
    );
    assert!(out.status.success(), "{}", common::stderr(&out));
    read_exr_layer(&exr).unwrap()
}

#[test]
fn the_check_render_path_traces_the_view_the_page_shows() {
    let shot = root().join("examples/shots/showcase.toml");
    let layout = Layout::start(&shot, &[]);
    // The API: a PNG of the asked size, from a pose the page gives; bad requests are 400s.
    let (status, body) = layout.get(
        "/api/render?frame=12&width=64&height=36&spp=1&position=0.9,1.4,0.6&look_at=-0.4,1.45,-3",
        "",
    );
    assert_eq!(status, 200);
    assert!(
        body.starts_with("\u{fffd}PNG") || body.contains("PNG"),
        "not a PNG"
    );
    for bad in [
        "/api/render?width=0",
        "/api/render?width=100000&height=100000",
        "/api/render?spp=100000",
        "/api/render?position=1,2",
        "/api/render?position=1,2,3",
        "/api/render?frame=0",
    ] {
        assert_eq!(layout.get(bad, "").0, 400, "{bad}");
    }
    // The page's button: the image over the shot view, at the film's aspect.
    let Some(page) = run_page(&format!("{}?frame=12", layout.url()), &["--check"]) else {
        return;
    };
    assert_eq!(page["size"], serde_json::json!([480, 270]), "{page}");
    assert!(page["pageErrors"].as_array().unwrap().is_empty(), "{page}");
}

/// A check render of the showcase's frame 12 at 96x54 from `layout`: what the server says of
/// denoising, and the image as linear RGB.
fn check_render(layout: &Layout, spp: u32, denoise: u8) -> (String, Vec<glam::Vec3>) {
    let url = format!("/api/render?frame=12&width=96&height=54&spp={spp}&denoise={denoise}");
    let (status, headers, body) = layout.exchange(&format!(
        "GET {url} HTTP/1.0\r\nHost: 127.0.0.1:{}\r\n\r\n",
        layout.port
    ));
    assert_eq!(status, 200, "{}", String::from_utf8_lossy(&body));
    let said = headers
        .iter()
        .find(|(k, _)| k == "x-rift-denoised")
        .map(|(_, v)| v.clone())
        .unwrap_or_default();
    let mut reader = png::Decoder::new(std::io::Cursor::new(body))
        .read_info()
        .unwrap();
    let mut bytes = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut bytes).unwrap();
    assert_eq!((info.width, info.height), (96, 54));
    let linear = |v: u8| {
        let c = v as f32 / 255.0;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    };
    let channels = info.color_type.samples();
    let pixels = bytes[..info.buffer_size()]
        .chunks(channels)
        .map(|p| glam::Vec3::new(linear(p[0]), linear(p[1]), linear(p[2])))
        .collect();
    (said, pixels)
}

#[test]
fn the_check_render_denoises_where_open_image_denoise_loads_and_says_so() {
    let shot = root().join("examples/shots/showcase.toml");
    let library = crate::denoise::oidn_library();
    let layout = Layout::start_env(&shot, &[], &[("RIFT_OIDN_LIBRARY", &library)]);
    let (said, denoised) = check_render(&layout, 4, 1);
    assert_eq!(said, "fast");
    let (said, noisy) = check_render(&layout, 4, 0);
    assert_eq!(said, "off");
    let (_, reference) = check_render(&layout, 128, 0);
    let error = |image: &[glam::Vec3]| relative_mse(image, &reference);
    assert!(
        error(&denoised) < 0.5 * error(&noisy),
        "denoised relMSE {} against noisy {}",
        error(&denoised),
        error(&noisy)
    );
    // A server that cannot load the library renders noisy and says why.
    let missing = Path::new("/nonexistent/libOpenImageDenoise.so.2");
    let layout = Layout::start_env(&shot, &[], &[("RIFT_OIDN_LIBRARY", missing)]);
    let (said, _) = check_render(&layout, 1, 1);
    assert!(said.starts_with("unavailable: "), "{said}");
}

#[test]
fn the_page_tints_what_the_openings_reveal_as_rift_reveal_finds_it() {
    let shot = root().join("examples/shots/showcase.toml");
    let layout = Layout::start(&shot, &[]);
    let (status, body) = layout.get("/api/reveal?frame=12", "");
    assert_eq!(status, 200, "{body}");
    let served: serde_json::Value = serde_json::from_str(&body).unwrap();
    // The server's answer is `rift reveal`'s for that frame, with as many rays.
    let out = Command::new(env!("CARGO_BIN_EXE_rift"))
        .args([
            "reveal",
            shot.to_str().unwrap(),
            "--frames",
            "12",
            "--width",
            "128",
        ])
        .arg("--json")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let printed: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(served["seen"], printed["seen"]);
    let seen = served["seen"].as_array().unwrap();
    let only: Vec<&str> = seen
        .iter()
        .filter(|r| r["only_through_openings"] == true)
        .map(|r| r["object"].as_str().unwrap())
        .collect();
    assert!(
        !only.is_empty(),
        "the showcase's openings show something only they show: {served}"
    );
    for bad in ["/api/reveal?frame=0", "/api/reveal?frame=x"] {
        assert_eq!(layout.get(bad, "").0, 400, "{bad}");
    }
    // The page's button: every object an opening shows tinted, those seen only through
    // openings orange; cleared again.
    let steps = r#"[["reveal"], ["highlighted"], ["clearReveal"], ["highlighted"]]"#;
    let Some(page) = run_page(&format!("{}?frame=12", layout.url()), &["--steps", steps]) else {
        return;
    };
    assert!(page["pageErrors"].as_array().unwrap().is_empty(), "{page}");
    let results = page["results"].as_array().unwrap();
    assert_eq!(
        results[0], served["seen"],
        "the page shows what the server found"
    );
    let mut tinted: Vec<(&str, &str)> = results[1]
        .as_array()
        .unwrap()
        .iter()
        .map(|h| (h["name"].as_str().unwrap(), h["tint"].as_str().unwrap()))
        .collect();
    tinted.sort();
    // Of what the openings show, the page draws the objects (not the rings).
    let objects = scene_names(&layout, 12);
    let mut expected: Vec<(&str, &str)> = seen
        .iter()
        .map(|r| r["object"].as_str().unwrap())
        .filter(|o| objects.iter().any(|name| name == o))
        .map(|o| {
            (
                o,
                if only.contains(&o) {
                    "ff7a1a"
                } else {
                    "2a4f80"
                },
            )
        })
        .collect();
    expected.sort();
    expected.dedup();
    assert_eq!(tinted, expected);
    assert_eq!(results[3], serde_json::json!([]), "{page}");
}

/// A similarity from the scene JSON as a matrix.
fn similarity(v: &serde_json::Value) -> glam::DMat4 {
    let f = |k: &str| -> Vec<f64> {
        v[k].as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let scale = v["scale"].as_f64().unwrap();
    glam::DMat4::from_scale_rotation_translation(
        glam::DVec3::splat(scale),
        glam::DQuat::from_slice(&f("rotation")),
        glam::DVec3::from_slice(&f("position")),
    )
}

/// The translation of a column-major matrix the page reports.
fn translation(v: &serde_json::Value) -> glam::DVec3 {
    let m: Vec<f64> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    glam::DVec3::new(m[12], m[13], m[14])
}

#[test]
fn edits_made_in_the_page_follow_the_solver_and_round_trip_through_the_shot_file() {
    let (w, h) = (256u32, 144u32);
    let dir = tempfile::tempdir().unwrap();
    let shot = still_variant(dir.path(), "showcase.toml", w, h, 2);
    let original = std::fs::read_to_string(&shot).unwrap();
    let layout = Layout::start(&shot, &[]);
    let url = format!("{}?frame=12&depth=2", layout.url());
    // The orb is keyed (the character is a mesh sequence); its copy is carried through.
    let orb = r#"{"kind": "object", "name": "orb"}"#;
    let pillar = r#"{"kind": "object", "name": "pillar"}"#;
    let back_there = r#"{"kind": "opening", "name": "back", "side": "there"}"#;
    let steps = format!(
        r#"[
        ["select", {orb}],
        ["move", {{"position": [0.8, 0.6, -1.0], "rotation": [0, 0, 0, 1], "scale": 1}}],
        ["placement", "orb_there"],
        ["select", {pillar}],
        ["placement", "pillar"],
        ["drag", 80, 0],
        ["placement", "pillar"],
        ["select", {back_there}],
        ["move", {{"position": [0.3, 1.5, 2.97], "rotation": [0, 0, 0, 1], "scale": 1}}],
        ["select", {pillar}],
        ["copyBack", "back"],
        ["placement", "pillar_here"],
        ["move", {{"position": [0, 0.4, 0], "rotation": [0, 0, 0, 1], "scale": -1}}],
        ["error"],
        ["select", {{"kind": "camera"}}],
        ["deleteKey"],
        ["error"],
        ["save"]
    ]"#
    );
    let Some(v) = run_page(&url, &["--steps", &steps]) else {
        return;
    };
    assert!(v["pageErrors"].as_array().unwrap().is_empty(), "{v}");
    let r = &v["results"];
    let (_, body) = layout.get("/api/scene?frame=12", "");
    let scene: serde_json::Value = serde_json::from_str(&body).unwrap();
    let frames = &scene["openings"][0];
    let teleport = similarity(&frames["there"]) * similarity(&frames["here"]).inverse();
    // The copy followed its source live, through the opening as it was then (before the
    // opening moved 0.3 m).
    let moved = r[1]["drawMs"].as_f64().unwrap();
    let answered = r[1]["answerMs"].as_f64().unwrap();
    eprintln!(
        "a move shows through the openings in {moved:.0} ms; the server answers in {answered:.0} ms"
    );
    let before_opening = glam::DMat4::from_translation(glam::DVec3::new(-0.3, 0.0, 0.0)) * teleport;
    let expected = before_opening.transform_point3(glam::DVec3::new(0.8, 0.6, -1.0));
    assert!(
        (translation(&r[2]) - expected).length() < 1e-6,
        "orb_there at {} not {expected}",
        translation(&r[2])
    );
    // The mouse dragged the pillar.
    let dragged = translation(&r[6]) - translation(&r[4]);
    assert!(
        dragged.length() > 0.05,
        "the drag moved the pillar by {dragged}"
    );
    assert!(r[5]["error"].is_null(), "{}", r[5]);
    // The inverse solver's copy is where carrying it through the opening lands on the pillar.
    let pillar_now = translation(&r[6]);
    let here_copy = translation(&r[11]);
    assert!(
        (teleport.transform_point3(here_copy) - pillar_now).length() < 1e-6,
        "{here_copy} carried through is not the pillar at {pillar_now}"
    );
    // A bad edit and a key that is not there are refused, with the file, key and reason shown.
    let shown = r[13].as_str().unwrap();
    assert!(
        shown.contains("showcase.toml") && shown.contains("scale"),
        "{shown}"
    );
    let shown = r[16].as_str().unwrap();
    assert!(shown.contains("no key at frame 12"), "{shown}");
    assert!(r[17]["saved"].is_string(), "{}", r[17]);
    // The file keeps every comment and line it had but those edited.
    let saved = std::fs::read_to_string(&shot).unwrap();
    for line in original.lines().filter(|l| l.trim_start().starts_with('#')) {
        assert!(saved.contains(line), "lost {line:?}");
    }
    assert!(
        saved.contains("{ frame = 12, position = [0.8, 0.6, -1.0]"),
        "{saved}"
    );
    assert!(saved.contains("back_through = \"back\""), "{saved}");
    assert!(
        saved.contains("here = { position = [0.3, 1.5, 2.97]"),
        "{saved}"
    );
    assert_eq!(
        std::fs::read_to_string(shot.with_extension("toml.bak")).unwrap(),
        original
    );
    // What the page shows now matches what `rift render` renders from the saved file.
    let Some(preview) = browse_ids(&url, w, h) else {
        return;
    };
    let layer = render_ids(dir.path(), &shot, 12);
    compare_ids(
        "edited showcase",
        &preview,
        &layer,
        &scene_names(&layout, 12),
        &[],
    );
}

#[test]
fn an_opening_with_a_time_offset_shows_the_there_side_later_as_the_path_tracer_does() {
    // Through an opening whose rays see the there side 6 frames later, a box crossing the
    // view beyond it shows 1 m further on than it is at the frame.
    let (w, h) = (256u32, 144u32);
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("wall.obj"),
        "v -40 -30 -8\nv 40 -30 -8\nv 40 30 -8\nv -40 30 -8\nf 1 2 3 4\n",
    )
    .unwrap();
    let cube = root().join("examples/assets/cube.obj");
    let shot = dir.path().join("delay.toml");
    std::fs::write(
        &shot,
        glowing_wall_shot("delay", [1, 24], w, h, 1)
            + &format!(
                r#"
[[object]]
name = "box"
mesh = "{cube}"
material = "grey"
transform = {{ interpolation = "linear", keys = [
  {{ frame = 1, position = [17.0, 0.0, -3.0], scale = 0.8 }},
  {{ frame = 24, position = [23.0, 0.0, -3.0], scale = 0.8 }},
] }}
[[portal]]
name = "A"
here = {{ position = [0.0, 0.0, -4.0] }}
there = {{ position = [20.0, 0.0, -0.5] }}
[portal.surface]
radius = 1.4
time_offset = 6.0
"#,
                cube = cube.display()
            ),
    )
    .unwrap();
    let layout = Layout::start(&shot, &[]);
    let url = format!("{}?frame=8&depth=1", layout.url());
    let Some(preview) = browse_ids(&url, w, h) else {
        return;
    };
    let layer = render_ids(dir.path(), &shot, 8);
    let names = scene_names(&layout, 8);
    // The box is in view through the opening (at the frame itself it would be 1.6 m to the
    // left, mostly outside the opening).
    let box_pixels = preview.iter().filter(|&&i| i == 1).count();
    assert!(box_pixels > 300, "{box_pixels} pixels of the box");
    compare_ids("delayed", &preview, &layer, &names, &[]);
}

/// For each edge pixel of either region (a pixel inside it with a 4-neighbour outside), the
/// distance to the nearest edge pixel of the other, sorted; pixels `skip` names (rings) and
/// those next to them are left out.
fn edge_distances(
    w: usize,
    h: usize,
    a: &dyn Fn(usize) -> bool,
    b: &dyn Fn(usize) -> bool,
    skip: &dyn Fn(usize) -> bool,
) -> Vec<f64> {
    let edge = |inside: &dyn Fn(usize) -> bool| -> Vec<(i64, i64)> {
        let mut out = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let p = y * w + x;
                let neighbours = [(x > 0, p.wrapping_sub(1)), (x + 1 < w, p + 1)]
                    .into_iter()
                    .chain([(y > 0, p.wrapping_sub(w)), (y + 1 < h, p + w)]);
                let near: Vec<usize> = neighbours.filter(|(ok, _)| *ok).map(|(_, q)| q).collect();
                if skip(p) || near.iter().any(|&q| skip(q)) {
                    continue;
                }
                if inside(p) && near.iter().any(|&q| !inside(q)) {
                    out.push((x as i64, y as i64));
                }
            }
        }
        out
    };
    let (ea, eb) = (edge(a), edge(b));
    let nearest = |from: &[(i64, i64)], to: &[(i64, i64)]| -> Vec<f64> {
        from.iter()
            .map(|&(x, y)| {
                to.iter()
                    .map(|&(u, v)| (((x - u).pow(2) + (y - v).pow(2)) as f64).sqrt())
                    .fold(f64::INFINITY, f64::min)
            })
            .collect()
    };
    let mut all = nearest(&ea, &eb);
    all.extend(nearest(&eb, &ea));
    all.sort_by(f64::total_cmp);
    all
}
