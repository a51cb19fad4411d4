//! Authored normals shade smoothly: a diffuse square whose corners carry tilted normals, lit by
//! a sun of zero angular size, has at each point radiance ρ/π · E · (n·l), n its corners'
//! normals interpolated there; without normals, its flat normal's. Checked column by column
//! against that closed form for OBJ `vn` and PLY `nx ny nz`, on a static object (its normals
//! baked to world space with it), on a moving one (turned at hit time by its placement), and
//! on a mesh sequence and a deforming USD mesh (their normals deforming between samples).

use crate::common;

use common::render_at;
use rift_render::frame::film::Image;
use std::f64::consts::PI;
use std::path::Path;

/// The square's albedo.
const ALBEDO: f64 = 0.5;
/// The square's half size; the camera sees exactly x, y in [-H, H] at the square's depth.
const H: f64 = 1.0;
const DEPTH: f64 = 8.0;
const PIXELS: usize = 16;
/// How far the corner normals lean from +Z, and the sun from overhead, towards ±X.
const TILT_DEGREES: f64 = 30.0;

/// A corner normal leaning `degrees` towards +X from +Z.
fn leaning(degrees: f64) -> [f64; 3] {
    let a = degrees.to_radians();
    [a.sin(), 0.0, a.cos()]
}

/// The square at z = -DEPTH as OBJ, its left corners' normals leaning `left` degrees, its
/// right corners' `right` (no `vn` when `None`).
fn square_obj(normals: Option<(f64, f64)>) -> String {
    let mut text = format!(
        "v {l} {l} {z}\nv {h} {l} {z}\nv {h} {h} {z}\nv {l} {h} {z}\n",
        l = -H,
        h = H,
        z = -DEPTH
    );
    match normals {
        None => text += "f 1 2 3 4\n",
        Some((left, right)) => {
            for n in [left, right, right, left].map(leaning) {
                text += &format!("vn {} {} {}\n", n[0], n[1], n[2]);
            }
            text += "f 1//1 2//2 3//3 4//4\n";
        }
    }
    text
}

/// The same square as an ASCII PLY with vertex normals.
fn square_ply((left, right): (f64, f64)) -> String {
    let mut text = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
                    property float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
                    element face 1\nproperty list uchar int vertex_indices\nend_header\n"
        .to_owned();
    let corners = [(-H, -H, left), (H, -H, right), (H, H, right), (-H, H, left)];
    for (x, y, lean) in corners {
        let n = leaning(lean);
        text += &format!("{x} {y} {} {} {} {}\n", -DEPTH, n[0], n[1], n[2]);
    }
    text + "4 0 1 2 3\n"
}

/// A camera at the origin seeing exactly the square, under a sun leaning TILT_DEGREES towards
/// +X of overhead; the square is `mesh`, placed by `transform`.
fn shot(mesh: &str, transform: &str) -> String {
    let fov = 2.0 * (H / DEPTH).atan().to_degrees();
    format!(
        r#"
[shot]
name = "shading_normals"
fps = 24.0
frames = [1, 1]
[camera]
resolution = [{PIXELS}, {PIXELS}]
fov_degrees = {fov}
[camera.transform]
position = [0.0, 0.0, 0.0]
[render]
seed = 1
[[material]]
name = "white"
type = "diffuse"
reflectance = [{ALBEDO}, {ALBEDO}, {ALBEDO}]
[[object]]
name = "square"
mesh = "{mesh}"
material = "white"
{transform}
[[light]]
name = "sun"
type = "distant"
intensity = 1.0
angle = 0.0
transform = {{ rotation_degrees = [0.0, {TILT_DEGREES}, 0.0] }}
"#
    )
}

/// The closed form at column `i`: the normal leaning `left` degrees at x = -H and `right` at
/// x = +H, interpolated linearly in x and normalised, against the sun's direction.
fn expected(i: usize, (left, right): (f64, f64)) -> f64 {
    let x = -H + (i as f64 + 0.5) * 2.0 * H / PIXELS as f64;
    let w = (x + H) / (2.0 * H);
    let [a, b] = [leaning(left), leaning(right)];
    let n: Vec<f64> = (0..3).map(|k| a[k] * (1.0 - w) + b[k] * w).collect();
    let length = n.iter().map(|c| c * c).sum::<f64>().sqrt();
    let sun = leaning(TILT_DEGREES);
    let cos: f64 = (0..3).map(|k| n[k] * sun[k]).sum::<f64>() / length;
    ALBEDO / PI * cos.max(0.0)
}

/// Mean of column `i` of `image` (one channel: everything is grey).
fn column(image: &Image, i: usize) -> f64 {
    let w = image.width;
    (0..image.height)
        .map(|row| image.rgb[row * w + i].y as f64)
        .sum::<f64>()
        / image.height as f64
}

/// Renders `mesh` (written as `file`) placed by `transform` and checks every inner column
/// against the closed form for corner normals leaning `leans` (left, right) in world space.
fn assert_shaded(dir: &Path, file: &str, mesh: &str, transform: &str, leans: (f64, f64)) {
    std::fs::write(dir.join(file), mesh).unwrap();
    let image = render_at(dir, file, &shot(file, transform), 16, 1);
    assert_columns(&image, leans, &format!("{file} {transform:?}"));
}

/// Checks every inner column of `image` against the closed form for corner normals leaning
/// `leans` (left, right) in world space.
fn assert_columns(image: &Image, leans: (f64, f64), what: &str) {
    assert_eq!(image.discarded, 0, "{what}");
    // The outer columns' pixel filters reach past the square's edge.
    for i in 2..PIXELS - 2 {
        let (got, want) = (column(image, i), expected(i, leans));
        assert!(
            (got - want).abs() <= 0.005 * want + 1e-4,
            "{what}: column {i} has radiance {got:.5} where its normal gives {want:.5}"
        );
    }
}

/// The shot at frame 1.25 (frame 1, the shutter closed a quarter frame after it): halfway
/// between samples at frames 1 and 1.5; the square is `mesh`.
fn shot_between_samples(mesh: &str) -> String {
    shot(mesh, "").replace("frames = [1, 1]", "frames = [1, 1]\nshutter = [0.25, 0.25]")
}

#[test]
fn a_flat_square_is_shaded_by_its_own_normal() {
    let dir = tempfile::tempdir().unwrap();
    assert_shaded(dir.path(), "flat.obj", &square_obj(None), "", (0.0, 0.0));
}

#[test]
fn authored_normals_are_interpolated_across_the_surface() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let leans = (-TILT_DEGREES, TILT_DEGREES);
    assert_shaded(d, "smooth.obj", &square_obj(Some(leans)), "", leans);
    assert_shaded(d, "smooth.ply", &square_ply(leans), "", leans);
    // Leaning towards the sun everywhere: lit as if facing it.
    let towards = (TILT_DEGREES, TILT_DEGREES);
    assert_shaded(d, "towards.obj", &square_obj(Some(towards)), "", towards);
}

#[test]
fn normals_turn_with_their_object_baked_or_moving() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Turned half a turn about the camera's axis, the square covers itself, and the normals
    // that leaned towards +X lean towards -X: away from the sun.
    let leans = (10.0, TILT_DEGREES);
    let turned = (-TILT_DEGREES, -10.0);
    let baked = "transform = { rotation_degrees = [0.0, 0.0, 180.0] }";
    assert_shaded(d, "baked.obj", &square_obj(Some(leans)), baked, turned);
    // Keyed to creep 1 mm along its normal during the frame: a moving instance, whose
    // normals turn at hit time; the creep changes nothing a sun can show.
    let moving = "transform = { keys = [\
        { frame = 1, position = [0.0, 0.0, 0.0], rotation_degrees = [0.0, 0.0, 180.0] }, \
        { frame = 2, position = [0.0, 0.0, -0.001], rotation_degrees = [0.0, 0.0, 180.0] }] }";
    assert_shaded(d, "moving.obj", &square_obj(Some(leans)), moving, turned);
}

/// A mesh sequence's normals deform with it: a square (the same in both samples) whose left
/// corners' normals lean from -30° at frame 1 to +30° at its sub-frame 1.5 is shaded halfway
/// between as the still square with those normals halfway (upright); a sequence without
/// normals is shaded flat.
#[test]
fn a_sequences_normals_deform_with_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let lean = TILT_DEGREES;
    std::fs::write(d.join("turning.0001.ply"), square_ply((-lean, lean))).unwrap();
    std::fs::write(d.join("turning.0001.5.ply"), square_ply((lean, lean))).unwrap();
    let image = render_at(
        d,
        "turning",
        &shot_between_samples("turning.####.ply"),
        16,
        1,
    );
    assert_columns(
        &image,
        (0.0, lean),
        "a sequence halfway between its samples",
    );
    for frame in ["0001", "0001.5"] {
        std::fs::write(d.join(format!("flat.{frame}.obj")), square_obj(None)).unwrap();
    }
    let image = render_at(d, "flat", &shot_between_samples("flat.####.obj"), 16, 1);
    assert_columns(&image, (0.0, 0.0), "a sequence without normals");
}

/// The square as a USD mesh whose points are sampled at frames 1 and 1.5 (the same both
/// times), its normals sampled with them when `normals` gives (left, right) leans at each
/// time code, or held still when it gives one.
fn square_usda(normals: &[(f64, (f64, f64))]) -> String {
    let (l, h, z) = (-H, H, -DEPTH);
    let points = format!("[({l}, {l}, {z}), ({h}, {l}, {z}), ({h}, {h}, {z}), ({l}, {h}, {z})]");
    let leaned = |(left, right): (f64, f64)| {
        let n = [left, right, right, left].map(|lean| {
            let [x, y, z] = leaning(lean);
            format!("({x}, {y}, {z})")
        });
        format!("[{}]", n.join(", "))
    };
    let normals = match normals {
        [(_, leans)] => format!("normal3f[] normals = {}", leaned(*leans)),
        samples => {
            let each: Vec<String> = (samples.iter())
                .map(|(code, leans)| format!("{code}: {}", leaned(*leans)))
                .collect();
            format!("normal3f[] normals.timeSamples = {{ {} }}", each.join(", "))
        }
    };
    format!(
        "#usda 1.0\n(\n metersPerUnit = 1\n upAxis = \"Y\"\n)\ndef Mesh \"Square\" {{\n \
         point3f[] points.timeSamples = {{ 1: {points}, 1.5: {points} }}\n \
         int[] faceVertexCounts = [4]\n int[] faceVertexIndices = [0, 1, 2, 3]\n \
         {normals}\n \
         color3f[] primvars:displayColor = [({ALBEDO}, {ALBEDO}, {ALBEDO})]\n \
         uniform token subdivisionScheme = \"none\"\n}}\n"
    )
}

/// A USD mesh's time-sampled normals deform with its points, as a sequence's do; normals not
/// sampled while the points are cannot follow them, and the mesh is shaded flat (and the
/// render says so).
#[test]
fn a_usd_meshs_sampled_normals_deform_with_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let lean = TILT_DEGREES;
    let shot_of = |file: &str| {
        let text = shot_between_samples("unused.obj");
        let (objects, lights) = (
            text.find("[[object]]").unwrap(),
            text.find("[[light]]").unwrap(),
        );
        format!(
            "{}{}[[usd]]\nfile = \"{file}\"\n",
            &text[..objects],
            &text[lights..]
        )
    };
    let sampled = square_usda(&[(1.0, (-lean, lean)), (1.5, (lean, lean))]);
    std::fs::write(d.join("sampled.usda"), sampled).unwrap();
    let image = render_at(d, "sampled", &shot_of("sampled.usda"), 16, 1);
    assert_columns(
        &image,
        (0.0, lean),
        "a USD mesh halfway between its samples",
    );
    std::fs::write(d.join("still.usda"), square_usda(&[(1.0, (-lean, lean))])).unwrap();
    let image = render_at(d, "still", &shot_of("still.usda"), 16, 1);
    assert_columns(&image, (0.0, 0.0), "a USD mesh whose normals stay put");
    let shot = rift_render::rift_fx::Shot::load(&d.join("still.toml")).unwrap();
    let warnings = rift_render::Scene::load(&shot, 1).unwrap().warnings;
    assert!(
        (warnings.iter()).any(|w| w.contains("</Square>") && w.contains("not sampled over time")),
        "{warnings:?}"
    );
}
