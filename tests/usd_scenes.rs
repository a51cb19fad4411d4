//! Shots that read the pipeline's USD (`[[usd]]`): a set written with Pixar's usd-core
//! (tests/support/usd_set.py) renders alike from its usda, usdc and usdz, and as the same set
//! written as rift's own shot file, OBJs and PNG; shot-file sections change USD prims by path;
//! and bad layers are refused with a message naming the file and the prim or key.

use crate::common;

use common::{largest_difference, python_command, rift, root, stderr};
use std::path::Path;

/// Writes the set into `dir` (see tests/support/usd_set.py).
pub(crate) fn make_set(dir: &Path) {
    let out = python_command("python3")
        .arg(root().join("tests/support/usd_set.py"))
        .arg(dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "usd_set.py (usd-core comes from tests/requirements.txt): {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Renders frame 1 of `shot` in `dir` to `image` at 16 samples a pixel; rift's standard error.
fn render(dir: &Path, shot: &str, image: &str) -> String {
    let out = rift(
        dir,
        &["render", shot, "-o", image, "--frames", "1", "--spp", "16"],
    );
    assert!(out.status.success(), "{shot}: {}", stderr(&out));
    stderr(&out)
}

/// Mean R, G, B of an EXR's beauty over each third of its width.
fn third_means(path: &Path) -> Vec<[f64; 3]> {
    let layer = rift_render::frame::film::read_exr_layer(path).unwrap();
    let (w, h) = (layer.size.0, layer.size.1);
    (0..3)
        .map(|third| {
            let mut sum = [0.0f64; 3];
            let columns = third * w / 3..(third + 1) * w / 3;
            for (c, name) in ["R", "G", "B"].iter().enumerate() {
                let values = &layer.channels[*name];
                for y in 0..h {
                    for x in columns.clone() {
                        sum[c] += values[y * w + x] as f64;
                    }
                }
                sum[c] /= (columns.len() * h) as f64;
            }
            sum
        })
        .collect()
}

/// Asserts two renders' means agree within `tolerance` (relative) in every third and channel.
fn assert_means_agree(a: &Path, b: &Path, tolerance: f64) {
    let (ma, mb) = (third_means(a), third_means(b));
    for (third, (x, y)) in ma.iter().zip(&mb).enumerate() {
        for c in 0..3 {
            let d = (x[c] - y[c]).abs() / y[c].max(1e-3);
            assert!(
                d < tolerance,
                "third {third}, channel {c}: {x:?} against {y:?}"
            );
        }
    }
}

/// Asserts two renders' means differ by more than `least` (relative) in some third and channel.
fn assert_means_differ(a: &Path, b: &Path, least: f64) {
    let (ma, mb) = (third_means(a), third_means(b));
    let most = (0..3)
        .flat_map(|t| (0..3).map(move |c| (t, c)))
        .map(|(t, c)| (ma[t][c] - mb[t][c]).abs() / mb[t][c])
        .fold(0.0, f64::max);
    assert!(most > least, "{ma:?} against {mb:?}");
}

#[test]
fn a_stage_renders_alike_in_every_encoding_and_as_its_shot_file() {
    let dir = tempfile::tempdir().unwrap();
    make_set(dir.path());
    let said = render(dir.path(), "set_usda.toml", "usda.exr");
    render(dir.path(), "set_usdc.toml", "usdc.exr");
    render(dir.path(), "set_usdz.toml", "usdz.exr");
    render(dir.path(), "set_toml.toml", "toml.exr");
    let p = |name: &str| dir.path().join(name);
    // One scene in three encodings (the usdz packs its texture): the same image, bit for bit.
    assert_eq!(largest_difference(&p("usda.exr"), &p("usdc.exr")), 0.0);
    assert_eq!(largest_difference(&p("usda.exr"), &p("usdz.exr")), 0.0);
    // The set as a sublayer of a root layer in another folder: its texture, authored relative
    // to the set's layer, is found beside that layer.
    std::fs::create_dir(p("stack")).unwrap();
    std::fs::write(
        p("stack/root.usda"),
        "#usda 1.0\n(\n    defaultPrim = \"World\"\n    upAxis = \"Y\"\n    \
         timeCodesPerSecond = 24\n    startTimeCode = 1\n    endTimeCode = 2\n    \
         subLayers = [@../set.usda@]\n)\n",
    )
    .unwrap();
    let shot = std::fs::read_to_string(p("set_usda.toml")).unwrap();
    let stacked = shot.replace("file = \"set.usda\"", "file = \"stack/root.usda\"");
    std::fs::write(p("set_stack.toml"), stacked).unwrap();
    render(dir.path(), "set_stack.toml", "stack.exr");
    assert_eq!(largest_difference(&p("usda.exr"), &p("stack.exr")), 0.0);
    // The same set as a shot file, OBJs and a PNG: walls from subsets, a box under a
    // non-uniformly scaled parent, a moving ball and a deforming mesh (frame 1 blurs both),
    // three lights and an emissive panel. The proxy and the invisible mesh, in view, are left
    // out (the shot file has neither). Same samples: only the BVH's ties differ.
    assert_means_agree(&p("usda.exr"), &p("toml.exr"), 2e-3);
    // What rift does not read is said once, naming the layer and the prim.
    assert_eq!(
        said.matches("</World/Camera> is a Camera").count(),
        1,
        "{said}"
    );
    assert!(
        !said.contains("Proxy") && !said.contains("Hidden"),
        "{said}"
    );
    // And so is an input of a UsdPreviewSurface rift does not read.
    assert_eq!(
        (said.matches("</World/Looks/Red/Surface>: inputs occlusion: not read by rift")).count(),
        1,
        "{said}"
    );
}

#[test]
fn a_usd_camera_frames_the_shot_as_the_same_camera_written_in_the_shot_file() {
    let dir = tempfile::tempdir().unwrap();
    make_set(dir.path());
    // Moving during the shutter (blur), a 35 mm lens at f/2.8 focused at 3 m (depth of field),
    // a clipping range: from the stage, and as the shot file's own [camera].
    render(dir.path(), "cam_usda.toml", "usda.exr");
    render(dir.path(), "cam_toml.toml", "toml.exr");
    let p = |name: &str| dir.path().join(name);
    assert_means_agree(&p("usda.exr"), &p("toml.exr"), 2e-3);
    // It frames the shot otherwise than the set's default camera.
    render(dir.path(), "set_usda.toml", "plain.exr");
    assert_means_differ(&p("usda.exr"), &p("plain.exr"), 0.03);
}

#[test]
fn a_zooming_usd_camera_renders_each_frame_with_its_lens_at_that_time() {
    let dir = tempfile::tempdir().unwrap();
    make_set(dir.path());
    // Focal length 35 to 70 mm and focus 2 to 4 m keyed at time codes 0 and 2: frame 1
    // renders as the shot file's camera at 52.5 mm focused at 3 m.
    let said = render(dir.path(), "zoom_usda.toml", "zoom.exr");
    render(dir.path(), "zoom_toml.toml", "toml.exr");
    render(dir.path(), "cam_usda.toml", "fixed.exr");
    let p = |name: &str| dir.path().join(name);
    assert_means_agree(&p("zoom.exr"), &p("toml.exr"), 2e-3);
    assert!(!said.contains("changes over the shot"), "{said}");
    // Against the camera that stays at 35 mm, the zoom shows.
    assert_means_differ(&p("zoom.exr"), &p("fixed.exr"), 0.03);
    // `rift fx`'s shot stage samples the lens as the transform: the horizontal field of view
    // and the focus distance at frames 1 and 2 are the zooming camera's.
    let shot = std::fs::read_to_string(p("zoom_usda.toml")).unwrap()
        + "\n[[portal]]\nname = \"door\"\nhere = { position = [0.0, 1.2, -3.9] }\n\
           there = { position = [0.0, 1.2, 20.0] }\n[portal.ring]\nradius = 0.5\npreset = \"calm\"\n";
    std::fs::write(p("zoom_fx.toml"), shot).unwrap();
    let out = rift(
        dir.path(),
        &["fx", "zoom_fx.toml", "-o", "fx_out", "--format", "usd"],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let check = "import sys, math\nfrom pxr import Usd\n\
        stage = Usd.Stage.Open(sys.argv[1])\n\
        cam = stage.GetPrimAtPath('/usd_set/camera')\n\
        get = lambda name, f: cam.GetAttribute(name).Get(f)\n\
        fov = lambda f: math.degrees(2 * math.atan(get('horizontalAperture', f) / 2 / get('focalLength', f)))\n\
        print(*[f'{fov(f):.4f} {get(\"focusDistance\", f):.4f}' for f in (1.0, 2.0)])\n";
    let out = python_command("python3")
        .args(["-c", check])
        .arg(dir.path().join("fx_out/usd_set.usda"))
        .output()
        .unwrap();
    // 0.36 across at 0.525 and 0.7 (USD's linear interpolation of the stage's keys).
    let fov = |focal: f64| (2.0 * (0.18 / focal).atan()).to_degrees();
    let expected = format!("{:.4} 3.0000 {:.4} 4.0000", fov(0.525), fov(0.7));
    assert_eq!(
        String::from_utf8_lossy(&out.stdout).trim(),
        expected,
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn the_fx_stage_holds_the_set_beneath_camera_and_rings() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    make_set(d);
    // The set's shot with an opening and its ring, its layer offset by two frames.
    let shot = std::fs::read_to_string(d.join("set_usda.toml")).unwrap()
        + "time_offset = 2.0\n\n[[portal]]\nname = \"door\"\n\
           here = { position = [0.0, 1.2, -3.9] }\nthere = { position = [0.0, 1.2, 20.0] }\n\
           [portal.ring]\nradius = 0.5\npreset = \"calm\"\n";
    std::fs::write(d.join("fx.toml"), shot).unwrap();
    let out = rift(d, &["fx", "fx.toml", "-o", "fx_out", "--format", "usd"]);
    assert!(out.status.success(), "{}", stderr(&out));
    // One stage opens set, camera and rings together, the set's animation two frames later.
    let check = "import sys\nfrom pxr import Usd, UsdGeom\n\
        s = Usd.Stage.Open(sys.argv[1])\n\
        ball = UsdGeom.Xformable(s.GetPrimAtPath('/World/Ball'))\n\
        at = lambda f: ball.ComputeLocalToWorldTransform(f).ExtractTranslation()[0]\n\
        print(s.GetPrimAtPath('/usd_set/camera').IsValid(), s.GetPrimAtPath('/usd_set/door').IsValid(), round(at(3.0), 6), round(at(4.0), 6))\n";
    let out = python_command("python3")
        .args(["-c", check])
        .arg(d.join("fx_out/usd_set.usda"))
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&out.stdout);
    // The ball is keyed at x = 0.6 (frame 1) and 0.9 (frame 2): offset by 2, frames 3 and 4.
    assert_eq!(
        said.trim(),
        "True True 0.6 0.9",
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn bad_usd_cameras_are_refused_naming_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    make_set(d);
    let text = std::fs::read_to_string(d.join("cam_usda.toml")).unwrap();
    for (from, to, expected) in [
        (
            "/World/ShotCam",
            "/World/Nothing",
            vec!["camera.usd", "/World/Nothing"],
        ),
        // A prim that is not a camera.
        (
            "/World/ShotCam",
            "/World/Ball",
            vec!["camera.usd", "/World/Ball"],
        ),
        (
            "/World/ShotCam",
            "World/ShotCam",
            vec!["camera.usd", "absolute"],
        ),
        (
            "usd = ",
            "fov_degrees = 40.0\nusd = ",
            vec!["camera.fov_degrees", "/World/ShotCam"],
        ),
        (
            "[[usd]]\nfile = \"set.usda\"\n",
            "",
            vec!["camera.usd", "/World/ShotCam"],
        ),
    ] {
        let e = refused(d, &text.replace(from, to));
        for part in &expected {
            assert!(e.contains("bad.toml") && e.contains(part), "{to}: {e}");
        }
    }
}

#[test]
fn shot_file_sections_change_usd_prims_by_path() {
    let dir = tempfile::tempdir().unwrap();
    make_set(dir.path());
    // The ball hidden from the camera, and a copy of the box moved beside it, named by path:
    // in the USD shot by sections of their own, in the shot file's by its sections' keys.
    let hide = "\n[[object]]\nname = \"/World/Ball\"\nvisibility = { camera = false }\n";
    let copy = "\n[[object]]\nname = \"box_copy\"\ncopy_of = \"/World/Props/Box\"\n\
                transform = { position = [1.2, 0.0, 0.3] }\n";
    let read = |shot: &str| std::fs::read_to_string(dir.path().join(shot)).unwrap();
    let usd = read("set_usda.toml") + hide + copy;
    let own = read("set_toml.toml").replace(
        "mesh = \"ball.obj\"\n",
        "mesh = \"ball.obj\"\nvisibility = { camera = false }\n",
    ) + copy;
    // Both boxes stand in world space (the stage's baked at load): their copies move alike.
    std::fs::write(dir.path().join("changed_set_usda.toml"), usd).unwrap();
    std::fs::write(dir.path().join("changed_set_toml.toml"), own).unwrap();
    render(dir.path(), "changed_set_usda.toml", "usda.exr");
    render(dir.path(), "changed_set_toml.toml", "toml.exr");
    render(dir.path(), "set_usda.toml", "plain.exr");
    let p = |name: &str| dir.path().join(name);
    assert_means_agree(&p("usda.exr"), &p("toml.exr"), 2e-3);
    // And the changes show: the right third (the ball, the copied box) differs from the plain set.
    let (changed, plain) = (third_means(&p("usda.exr")), third_means(&p("plain.exr")));
    let d = (changed[2][0] - plain[2][0]).abs() / plain[2][0];
    assert!(
        d > 0.02,
        "the right third barely changed: {changed:?} against {plain:?}"
    );
}

/// Renders `shot` (text) in `dir` and returns rift's standard error, asserting it failed
/// without writing the image.
fn refused(dir: &Path, shot: &str) -> String {
    std::fs::write(dir.join("bad.toml"), shot).unwrap();
    let out = rift(
        dir,
        &["render", "bad.toml", "-o", "bad.exr", "--frames", "1"],
    );
    assert!(!out.status.success(), "rendered a bad shot:\n{shot}");
    assert!(
        !dir.join("bad.exr").exists(),
        "wrote an image for a bad shot"
    );
    stderr(&out)
}

/// The set's shot header with `usd` as its layer section.
fn shot_with(usd: &str) -> String {
    let header = std::fs::read_to_string(root().join("tests/data/usd_shot_header.toml")).unwrap();
    format!("{header}\n[[usd]]\n{usd}\n")
}

#[test]
fn bad_layers_are_refused_naming_the_file_and_the_prim() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    make_set(d);
    // A layer that is not there.
    let e = refused(d, &shot_with("file = \"missing.usda\""));
    assert!(
        e.contains("usd[0].file") && e.contains("missing.usda"),
        "{e}"
    );
    // A binary layer cut short, and a package that is not a zip.
    let usdc = std::fs::read(d.join("set.usdc")).unwrap();
    std::fs::write(d.join("short.usdc"), &usdc[..usdc.len() / 2]).unwrap();
    let e = refused(d, &shot_with("file = \"short.usdc\""));
    assert!(e.contains("usd[0].file") && e.contains("short.usdc"), "{e}");
    std::fs::write(d.join("junk.usdz"), b"not a zip at all").unwrap();
    let e = refused(d, &shot_with("file = \"junk.usdz\""));
    assert!(e.contains("junk.usdz"), "{e}");
    // 10^9 points declared where 86 are stored (the ball's): refused before it is read.
    let count = 86u64.to_le_bytes();
    let first_point: Vec<u8> = [0.0f32, 0.35, 0.0]
        .iter()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    let at = usdc
        .windows(20)
        .position(|w| w[..8] == count && w[8..] == first_point[..])
        .expect("the ball's points in the usdc");
    let mut huge = usdc.clone();
    huge[at..at + 8].copy_from_slice(&1_000_000_000u64.to_le_bytes());
    std::fs::write(d.join("huge.usdc"), huge).unwrap();
    let e = refused(d, &shot_with("file = \"huge.usdc\""));
    assert!(e.contains("huge.usdc") && e.contains("1000000000"), "{e}");
    // A root prim that does not exist.
    let e = refused(
        d,
        &shot_with("file = \"set.usda\"\nroot = \"/World/Nothing\""),
    );
    assert!(
        e.contains("usd[0].root") && e.contains("/World/Nothing"),
        "{e}"
    );
    // Layers that reference each other in a cycle.
    std::fs::write(
        d.join("a.usda"),
        "#usda 1.0\ndef Xform \"A\" (references = @./b.usda@</B>) {}\n",
    )
    .unwrap();
    std::fs::write(
        d.join("b.usda"),
        "#usda 1.0\ndef Xform \"B\" (references = @./a.usda@</A>) {}\n",
    )
    .unwrap();
    let e = refused(d, &shot_with("file = \"a.usda\""));
    assert!(
        e.contains("a.usda") && e.to_lowercase().contains("cycl"),
        "{e}"
    );
    // A mesh whose faces name points it does not have.
    std::fs::write(
        d.join("bad_mesh.usda"),
        "#usda 1.0\ndef Mesh \"Tri\" {\n point3f[] points = [(0,0,0), (1,0,0), (0,1,0)]\n \
         int[] faceVertexCounts = [3]\n int[] faceVertexIndices = [0, 1, 7]\n}\n",
    )
    .unwrap();
    let e = refused(d, &shot_with("file = \"bad_mesh.usda\""));
    assert!(
        e.contains("bad_mesh.usda") && e.contains("</Tri>.faceVertexIndices") && e.contains("7"),
        "{e}"
    );
    // A deforming mesh whose later sample has fewer points than its faces name.
    std::fs::write(
        d.join("shrinking.usda"),
        "#usda 1.0\ndef Mesh \"Tri\" {\n point3f[] points.timeSamples = {\n  \
         1: [(0,0,0), (1,0,0), (0,1,0)],\n  2: [(0,0,0), (1,0,0)],\n }\n \
         int[] faceVertexCounts = [3]\n int[] faceVertexIndices = [0, 1, 2]\n}\n",
    )
    .unwrap();
    let e = refused(d, &shot_with("file = \"shrinking.usda\""));
    assert!(
        e.contains("</Tri>.faceVertexIndices") && e.contains("2 points at time code 2"),
        "{e}"
    );
    // A key the section does not have.
    let e = refused(d, &shot_with("file = \"set.usda\"\nlayer = \"x\""));
    assert!(e.contains("usd[0]") && e.contains("layer"), "{e}");
}

/// A stage with a PointInstancer of one triangle prototype whose own attributes are `body`.
fn instancer(body: &str) -> String {
    format!(
        "#usda 1.0\ndef PointInstancer \"Scatter\" {{\n rel prototypes = [</Scatter/Tri>]\n \
         {body}\n def Mesh \"Tri\" {{\n  point3f[] points = [(0,0,0), (1,0,0), (0,1,0)]\n  \
         int[] faceVertexCounts = [3]\n  int[] faceVertexIndices = [0, 1, 2]\n }}\n}}\n"
    )
}

/// Renders `stage` (usda text) in `dir` under a memory budget of 8 MiB and returns rift's
/// standard error, asserting it failed without writing the image.
fn refused_under_8_mib(dir: &Path, stage: &str) -> String {
    std::fs::write(dir.join("many.usda"), stage).unwrap();
    std::fs::write(dir.join("bad.toml"), shot_with("file = \"many.usda\"")).unwrap();
    let out = rift(
        dir,
        &[
            "render",
            "bad.toml",
            "-o",
            "bad.exr",
            "--frames",
            "1",
            "--max-memory",
            "8M",
        ],
    );
    let e = stderr(&out);
    assert!(
        !out.status.success() && !dir.join("bad.exr").exists(),
        "{e}"
    );
    e
}

#[test]
fn bad_instancers_are_refused_naming_the_prim_and_the_attribute() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases = [
        (
            "int[] protoIndices = [0, 1]\n point3f[] positions = [(0,0,0), (1,0,0)]",
            vec!["</Scatter>.protoIndices", "entry 1 is 1", "1 prototypes"],
        ),
        (
            "int[] protoIndices = [0, 0]\n point3f[] positions = [(0,0,0)]",
            vec!["</Scatter>.positions", "1 entries for 2 instances"],
        ),
        (
            "int[] protoIndices = [0]",
            vec!["</Scatter>.positions", "missing"],
        ),
        (
            "int[] protoIndices = [0]\n point3f[] positions = [(0,0,0)]\n \
             quath[] orientations = [(0, 0, 0, 0)]",
            vec!["</Scatter>.orientations", "entry 0 is not a rotation"],
        ),
        (
            "int[] protoIndices = [0, 0]\n point3f[] positions.timeSamples = {\n  \
             1: [(0,0,0)],\n  2: [(1,0,0), (2,0,0)],\n }",
            vec!["</Scatter>.positions", "1 entries for 2 instances"],
        ),
    ];
    for (i, (body, expected)) in cases.iter().enumerate() {
        let name = format!("instancer{i}.usda");
        std::fs::write(d.join(&name), instancer(body)).unwrap();
        let e = refused(d, &shot_with(&format!("file = \"{name}\"")));
        for part in expected {
            assert!(e.contains(&name) && e.contains(part), "{body}: {e}");
        }
    }
    // Instances that would not fit in the memory budget: refused before they are made.
    let many = format!(
        "int[] protoIndices = [{}]\n point3f[] positions = [{}]",
        vec!["0"; 20000].join(", "),
        vec!["(0,0,0)"; 20000].join(", ")
    );
    let e = refused_under_8_mib(d, &instancer(&many));
    assert!(
        e.contains("</Scatter>.protoIndices") && e.contains("20000 instances"),
        "{e}"
    );
    // Fewer instances that fit still, but not keyed at ten times within the shutter.
    let points = vec!["(0,0,0)"; 4000].join(", ");
    let samples: Vec<String> = (0..10)
        .map(|k| format!("{}: [{points}]", 1.0 + 0.05 * k as f64))
        .collect();
    let keyed = format!(
        "int[] protoIndices = [{}]\n point3f[] positions.timeSamples = {{ {} }}",
        vec!["0"; 4000].join(", "),
        samples.join(", ")
    );
    let e = refused_under_8_mib(d, &instancer(&keyed));
    assert!(
        e.contains("</Scatter>.protoIndices") && e.contains("4000 instances"),
        "{e}"
    );
    // An instanced prim cannot be moved from the shot file: its instancer places it.
    let fine = "int[] protoIndices = [0, 0]\n point3f[] positions = [(0,0,0), (2,0,0)]";
    std::fs::write(d.join("fine.usda"), instancer(fine)).unwrap();
    let moved = shot_with("file = \"fine.usda\"")
        + "\n[[object]]\nname = \"/Scatter/Tri\"\ntransform = { position = [0, 1, 0] }\n";
    let e = refused(d, &moved);
    assert!(
        e.contains("</Scatter/Tri>.transform") && e.contains("2 instances"),
        "{e}"
    );
}

/// A stage under a dome light with grey quads `placed` (a PointInstancer's, or meshes and
/// instances of the class `/Proto`'s quad) under an Xform whose `translate` (`rig`) moves them
/// too.
fn moving_quads(placed: &str, rig: &str) -> String {
    format!(
        "#usda 1.0\n(\n timeCodesPerSecond = 24\n startTimeCode = 1\n endTimeCode = 2\n)\n\
         class \"Proto\" {{\n {}\n}}\n\
         def DomeLight \"Sky\" {{\n color3f inputs:color = (1, 0.9, 0.8)\n}}\n\
         def Xform \"Rig\" {{\n double3 xformOp:translate{rig}\n \
         uniform token[] xformOpOrder = [\"xformOp:translate\"]\n {placed}\n}}\n",
        quad("Quad", "")
    )
}

/// A quad mesh 0.4 across called `name`, with `ops` (its transform's attributes).
fn quad(name: &str, ops: &str) -> String {
    format!(
        "def Mesh \"{name}\" {{\n  point3f[] points = [(-0.2,-0.2,0), (0.2,-0.2,0), \
         (0.2,0.2,0), (-0.2,0.2,0)]\n  int[] faceVertexCounts = [4]\n  \
         int[] faceVertexIndices = [0, 1, 2, 3]\n  uniform token subdivisionScheme = \"none\"\n  \
         {ops}\n }}"
    )
}

/// A quad's transform ops, keyed to move it from the left third to the middle over frame 1's
/// shutter while it turns a quarter about its own centre and doubles in size.
const KEYED_OPS: &str = "double3 xformOp:translate.timeSamples = { 1: (-0.8, 1, -1), 2: (0.8, 1, -1) }\n  \
     float xformOp:rotateZ.timeSamples = { 1: 0, 2: 90 }\n  \
     float3 xformOp:scale.timeSamples = { 1: (1, 1, 1), 2: (2, 2, 2) }\n  \
     uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:rotateZ\", \
     \"xformOp:scale\"]";

/// A quad standing still beside the moving ones.
fn still_quad() -> String {
    quad(
        "Still",
        "double3 xformOp:translate = (0.3, 0.7, -1.2)\n  \
         uniform token[] xformOpOrder = [\"xformOp:translate\"]",
    )
}

/// An instanceable prim of the class `/Proto`'s quad moved by [`KEYED_OPS`], beside the still
/// quad.
fn keyed_instance() -> String {
    format!(
        "def Xform \"Moving\" (\n  inherits = </Proto>\n  instanceable = true\n ) {{\n  \
         {KEYED_OPS}\n }}\n {}",
        still_quad()
    )
}

/// Renders the stage `<name>.usda` in `dir` through a shot of its own (`<name><suffix>.toml`,
/// the shot's sections `extra` added) to `<name><suffix>.exr`; returns rift's standard error.
fn render_stage(dir: &Path, name: &str, suffix: &str, extra: &str) -> String {
    let shot = shot_with(&format!("file = \"{name}.usda\"")) + extra;
    std::fs::write(dir.join(format!("{name}{suffix}.toml")), shot).unwrap();
    render(
        dir,
        &format!("{name}{suffix}.toml"),
        &format!("{name}{suffix}.exr"),
    )
}

#[test]
fn a_point_instancer_sampled_over_time_moves_its_instances_as_the_same_keyed_instance_does() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // The rig bobs up at time code 1.5, the end of frame 1's shutter, between the placements'
    // samples at 1 and 2: the instance is placed there by its placements interpolated as USD
    // interpolates them (positions and scales linearly, orientations along the sphere).
    let bob = ".timeSamples = { 1: (0, 0, 0), 1.5: (0, 0.1, 0), 2: (0, 0, 0) }";
    let instancer = |second: &str| {
        format!(
            "def PointInstancer \"Scatter\" {{\n  rel prototypes = [</Rig/Scatter/Quad>]\n  \
             int[] protoIndices = [0, 0]\n  point3f[] positions.timeSamples = {{ \
             1: [(-0.8, 1, -1), (0.3, 0.7, -1.2)], 2: [{second}, (0.3, 0.7, -1.2)] }}\n  \
             {}\n }}",
            quad("Quad", "")
        )
    };
    let moving = instancer("(0.8, 1, -1)").replace(
        "int[] protoIndices",
        "quath[] orientations.timeSamples = { 1: [(1, 0, 0, 0), (1, 0, 0, 0)], \
             2: [(0.70710677, 0, 0, 0.70710677), (1, 0, 0, 0)] }\n  \
             float3[] scales.timeSamples = { 1: [(1, 1, 1), (1, 1, 1)], \
             2: [(2, 2, 2), (1, 1, 1)] }\n  int[] protoIndices",
    );
    std::fs::write(d.join("instanced.usda"), moving_quads(&moving, bob)).unwrap();
    // The same motion keyed by transform ops on an instance of the class's quad, which rift
    // also keys by its world transforms. Its rotation is keyed in whole degrees, as usd-core
    // writes them, which the USD crate alone would hold at 0 until time code 2.
    std::fs::write(d.join("keyed.usda"), moving_quads(&keyed_instance(), bob)).unwrap();
    // The instancer held where frame 1 starts: what rift rendered before it read the samples.
    let held = instancer("(-0.8, 1, -1)");
    std::fs::write(d.join("held.usda"), moving_quads(&held, bob)).unwrap();
    for name in ["instanced", "keyed", "held"] {
        let said = render_stage(d, name, "", "");
        assert!(!said.contains("Scatter"), "{name}: {said}");
    }
    let p = |name: &str| d.join(name);
    // Frame 1's shutter sweeps the quad from the left third to the middle, turning and
    // growing, as the keyed instance does (the same samples: only the BVH's ties may differ),
    // and unlike the held one.
    assert_means_agree(&p("instanced.exr"), &p("keyed.exr"), 2e-3);
    assert_means_differ(&p("instanced.exr"), &p("held.exr"), 0.02);
}

/// A PointInstancer's instance grows between its scales' samples as USD interpolates them,
/// linearly, as a mesh grown by the same samples of a scale op does: rift blends keys' scales
/// geometrically, so an instance's keys follow its growth as a prim's do.
#[test]
fn an_instance_grows_between_its_samples_as_a_scale_op_grows_a_mesh() {
    let instancer = format!(
        "def PointInstancer \"Scatter\" {{\n  rel prototypes = [</Rig/Scatter/Quad>]\n  \
         int[] protoIndices = [0]\n  point3f[] positions = [(0, 1, -1)]\n  \
         float3[] scales.timeSamples = {{ 1: [(1, 1, 1)], 2: [(6, 6, 6)] }}\n  {}\n }}",
        quad("Quad", "")
    );
    let mesh = quad(
        "Grown",
        "double3 xformOp:translate = (0, 1, -1)\n  \
         float3 xformOp:scale.timeSamples = { 1: (1, 1, 1), 2: (6, 6, 6) }\n  \
         uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:scale\"]",
    );
    assert_stages_agree(&instancer, &mesh, " = (0, 0, 0)");
}

/// A turning PointInstancer carries an instance standing 0.8 from its origin along the arc, as
/// a turning Xform carries a mesh there: rift's blend of two keys a quarter turn apart would cut
/// the arc's chord, so the instance's keys follow it as a prim's do.
#[test]
fn a_turning_instancer_carries_its_instances_along_arcs() {
    let turn = "float xformOp:rotateZ.timeSamples = { 1: 0, 2: 90 }\n  \
                uniform token[] xformOpOrder = [\"xformOp:rotateZ\"]";
    let instancer = format!(
        "def PointInstancer \"Scatter\" {{\n  {turn}\n  \
         rel prototypes = [</Rig/Scatter/Quad>]\n  int[] protoIndices = [0]\n  \
         point3f[] positions = [(0.8, 0, 0)]\n  {}\n }}",
        quad("Quad", "")
    );
    let mesh = format!(
        "def Xform \"Turn\" {{\n  {turn}\n  {}\n }}",
        quad(
            "Quad",
            "double3 xformOp:translate = (0.8, 0, 0)\n  \
             uniform token[] xformOpOrder = [\"xformOp:translate\"]"
        )
    );
    assert_stages_agree(&instancer, &mesh, " = (0, 1, -1)");
}

/// Renders `instancer` and `mesh` each in [`moving_quads`] (its rig at `rig`) and asserts the
/// two images' means agree.
fn assert_stages_agree(instancer: &str, mesh: &str, rig: &str) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("instanced.usda"), moving_quads(instancer, rig)).unwrap();
    std::fs::write(d.join("mesh.usda"), moving_quads(mesh, rig)).unwrap();
    for name in ["instanced", "mesh"] {
        render_stage(d, name, "", "");
    }
    assert_means_agree(&d.join("instanced.exr"), &d.join("mesh.exr"), 2e-3);
}

/// A mesh keyed by its own transform ops moves as the same keyed instance does: its keys
/// place its centre where its ops put it, so it turns about that centre between samples rather
/// than about the stage's origin.
#[test]
fn a_keyed_mesh_moves_as_the_same_keyed_instance_does() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let still = " = (0, 0, 0)";
    let mesh = format!("{}\n {}", quad("Moving", KEYED_OPS), still_quad());
    std::fs::write(
        d.join("instanced.usda"),
        moving_quads(&keyed_instance(), still),
    )
    .unwrap();
    std::fs::write(d.join("mesh.usda"), moving_quads(&mesh, still)).unwrap();
    for name in ["instanced", "mesh"] {
        render_stage(d, name, "", "");
    }
    assert_means_agree(&d.join("mesh.exr"), &d.join("instanced.exr"), 2e-3);
    // Its section's transform, and a copy's own, place it from where the stage puts it at its
    // first sample, as they place a prim that stands there.
    let first = quad(
        "Moving",
        "double3 xformOp:translate = (-0.8, 1, -1)\n  \
         uniform token[] xformOpOrder = [\"xformOp:translate\"]",
    );
    let standing = format!("{first}\n {}", still_quad());
    std::fs::write(d.join("standing.usda"), moving_quads(&standing, still)).unwrap();
    let moved = "\n[[object]]\nname = \"/Rig/Moving\"\ntransform = { position = [0.5, 0.0, 0.0] }\n\
                 \n[[object]]\nname = \"moved_copy\"\ncopy_of = \"/Rig/Moving\"\n\
                 transform = { position = [0.9, -0.3, 0.0] }\n";
    for name in ["mesh", "standing"] {
        render_stage(d, name, "_moved", moved);
    }
    let p = |name: &str| d.join(name);
    assert_means_agree(&p("mesh_moved.exr"), &p("standing_moved.exr"), 2e-3);
    assert_means_differ(&p("mesh_moved.exr"), &p("mesh.exr"), 0.02);
}

/// A stage whose Xform "Arm" turns `turn` (the rotateZ's samples) and carries a quad 0.8 out.
fn arm(turn: &str) -> String {
    let arm = format!(
        "def Xform \"Arm\" {{\n double3 xformOp:translate = (-0.4, -0.2, -0.2)\n \
         float xformOp:rotateZ.timeSamples = {{ {turn} }}\n \
         uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:rotateZ\"]\n {}\n}}",
        quad(
            "Quad",
            "double3 xformOp:translate = (0.8, 0, 0)\n  \
             uniform token[] xformOpOrder = [\"xformOp:translate\"]"
        )
    );
    // The rig stands at (0, 1, -1), so the arm turns about (-0.4, 0.8, -1.2).
    moving_quads(&arm, " = (0, 1, -1)")
}

/// A prim a turning parent carries sweeps its arc, as USD places it, though the parent's turn
/// is keyed only at whole frames: rift adds samples where its blend of two would cut across.
#[test]
fn a_prim_on_a_turning_arm_sweeps_its_arc_between_sparse_samples() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Three quarters of a turn between time codes 1 and 2, 135° within frame 1's shutter.
    let dense: Vec<String> = (0..=32)
        .map(|i| format!("{}: {}", 1.0 + i as f64 / 32.0, 270.0 * i as f64 / 32.0))
        .collect();
    std::fs::write(d.join("sparse.usda"), arm("1: 0, 2: 270")).unwrap();
    std::fs::write(d.join("dense.usda"), arm(&dense.join(", "))).unwrap();
    for name in ["sparse", "dense"] {
        render_stage(d, name, "", "");
    }
    assert_means_agree(&d.join("sparse.exr"), &d.join("dense.exr"), 2e-3);
}

#[test]
fn an_instancer_whose_instances_cannot_be_followed_over_time_is_said_and_held() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Its second sample has an instance more (a particle born), and it gives velocities.
    let body = "int[] protoIndices = [0]\n point3f[] positions.timeSamples = {\n  \
                1: [(0,1,-1)],\n  2: [(1,1,-1), (0,1,-1)],\n }\n \
                vector3f[] velocities = [(24, 0, 0)]";
    std::fs::write(d.join("born.usda"), instancer(body)).unwrap();
    std::fs::write(d.join("born.toml"), shot_with("file = \"born.usda\"")).unwrap();
    let said = render(d, "born.toml", "born.exr");
    assert!(
        said.contains("born.usda")
            && said.contains("</Scatter> cannot be followed over time")
            && said.contains("at time code 2 positions has 2 entries"),
        "{said}"
    );
    // Its instances renumbered between the samples: followed by index they would swap.
    let body = "int[] protoIndices = [0, 0]\n point3f[] positions.timeSamples = {\n  \
                1: [(0,1,-1), (1,1,-1)],\n  2: [(1,1,-1), (0,1,-1)],\n }\n \
                int64[] ids.timeSamples = { 1: [3, 4], 2: [4, 3] }";
    std::fs::write(d.join("renumbered.usda"), instancer(body)).unwrap();
    let shot = shot_with("file = \"renumbered.usda\"");
    std::fs::write(d.join("renumbered.toml"), shot).unwrap();
    let said = render(d, "renumbered.toml", "renumbered.exr");
    assert!(
        said.contains("</Scatter> cannot be followed over time")
            && said.contains("at time code 2 its ids differ"),
        "{said}"
    );
    // Followed, its velocities are not used: said.
    let body = "int[] protoIndices = [0]\n point3f[] positions.timeSamples = {\n  \
                1: [(0,1,-1)],\n  2: [(1,1,-1)],\n }\n vector3f[] velocities = [(24, 0, 0)]";
    std::fs::write(d.join("both.usda"), instancer(body)).unwrap();
    std::fs::write(d.join("both.toml"), shot_with("file = \"both.usda\"")).unwrap();
    let said = render(d, "both.toml", "both.exr");
    assert!(
        said.contains("</Scatter> gives velocities and samples its placements over time"),
        "{said}"
    );
}

#[test]
fn a_prim_of_a_kind_rift_does_not_read_is_said_and_left_out() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("sphere.usda"),
        "#usda 1.0\ndef Xform \"World\" {\n def Sphere \"Ball\" { double radius = 1 }\n \
         def Mesh \"Floor\" {\n  point3f[] points = [(-5,0,-5), (5,0,-5), (5,0,5), (-5,0,5)]\n  \
         int[] faceVertexCounts = [4]\n  int[] faceVertexIndices = [0, 3, 2, 1]\n  \
         uniform token subdivisionScheme = \"none\"\n }\n def Mesh \"Rock\" {\n  \
         point3f[] points = [(0,0,-1), (0.3,0,-1), (0,0.3,-1)]\n  \
         normal3f[] normals = [(0,0,1), (0,0,1), (0,0,1)]\n  \
         int[] faceVertexCounts = [3]\n  int[] faceVertexIndices = [0, 1, 2]\n }\n def SphereLight \"Lamp\" {\n  \
         float inputs:intensity = 50\n  double3 xformOp:translate = (0, 2, 0)\n  \
         uniform token[] xformOpOrder = [\"xformOp:translate\"]\n }\n}\n",
    )
    .unwrap();
    std::fs::write(d.join("shot.toml"), shot_with("file = \"sphere.usda\"")).unwrap();
    let said = render(d, "shot.toml", "out.exr");
    assert!(
        said.contains("</World/Ball> is a Sphere") && said.contains("export it as a mesh"),
        "{said}"
    );
    // A mesh without a subdivision scheme is Catmull-Clark in USD; rift says which it
    // renders as their cages once for the stage. Its normals it reads (smooth shading).
    assert!(
        said.contains("1 mesh is a subdivision surface (</World/Rock>)")
            && !said.contains("normal"),
        "{said}"
    );
    // The floor (unbound: USD's 18% grey) is lit by the lamp.
    let means = third_means(&d.join("out.exr"));
    assert!(means[1][0] > 0.01, "{means:?}");
}

#[test]
fn a_set_blender_exports_renders_with_what_it_does_not_read_said() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = python_command("python3")
        .arg(root().join("tests/support/blender_set.py"))
        .arg(d)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "blender_set.py (bpy comes from tests/requirements.txt): {}",
        String::from_utf8_lossy(&out.stderr)
    );
    // Blender's stage is Z-up: the shot's camera is placed in its axes, as Blender's is.
    let shot = "[shot]\nname = \"blender\"\nfps = 24.0\nframes = [1, 1]\n[camera]\n\
                resolution = [64, 48]\nfov_degrees = 39.6\n[camera.transform]\n\
                position = [0.0, -5.0, 2.5]\nlook_at = [0.0, 0.0, 0.17]\nup = [0.0, 0.0, 1.0]\n\
                [render]\nspp = 16\n[[usd]]\nfile = \"blender.usda\"\n";
    std::fs::write(d.join("shot.toml"), shot).unwrap();
    let said = render(d, "shot.toml", "out.exr");
    for expected in [
        "the stage's up axis is Z",
        "</root/Camera/Camera> is a Camera",
        "enableColorTemperature",
    ] {
        assert!(said.contains(expected), "{expected:?} not said:\n{said}");
    }
    // The floor's texture (orange and grey squares) reaches the image: the lower half, all
    // floor, has both orange (red well above blue) and grey pixels.
    let layer = rift_render::frame::film::read_exr_layer(&d.join("out.exr")).unwrap();
    let (w, h) = (layer.size.0, layer.size.1);
    let (r, b) = (&layer.channels["R"], &layer.channels["B"]);
    let lower = (h * 3 / 4..h).flat_map(|y| (0..w).map(move |x| y * w + x));
    let (mut orange, mut grey) = (0, 0);
    for i in lower {
        match r[i] > 3.0 * b[i] {
            true => orange += 1,
            false => grey += 1,
        }
    }
    assert!(orange > 20 && grey > 20, "orange {orange}, grey {grey}");
    // Blender's animated camera, read from the stage: at frame 1 it frames the set as the
    // shot file's camera at Blender's frame-1 pose does; by frame 24 it has moved.
    let camera = std::fs::read_to_string(d.join("camera.toml")).unwrap();
    let head = "[shot]\nname = \"blender\"\nfps = 24.0\nframes = [1, 24]\nshutter = [0.0, 0.0]\n";
    let tail = "[render]\nspp = 16\n[[usd]]\nfile = \"blender.usda\"\n";
    let own = format!("{head}{camera}{tail}");
    let usd =
        format!("{head}[camera]\nresolution = [160, 90]\nusd = \"/root/Camera/Camera\"\n{tail}");
    std::fs::write(d.join("own.toml"), own).unwrap();
    std::fs::write(d.join("usd.toml"), usd).unwrap();
    let said = render(d, "usd.toml", "usd.exr");
    assert!(
        !said.contains("is a Camera"),
        "the shot's camera is read, not said: {said}"
    );
    render(d, "own.toml", "own.exr");
    assert_means_agree(&d.join("usd.exr"), &d.join("own.exr"), 2e-3);
    let out = rift(
        d,
        &[
            "render", "usd.toml", "-o", "late.exr", "--frames", "24", "--spp", "16",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let (early, late) = (
        third_means(&d.join("usd.exr")),
        third_means(&d.join("late.exr")),
    );
    assert!(
        (early[1][0] - late[1][0]).abs() / early[1][0] > 0.02,
        "{early:?} against {late:?}"
    );
}
