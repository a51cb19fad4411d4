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

/// A coarse UV sphere (`SEGMENTS` around, `RINGS` from pole to pole) of unit radius about
/// `centre`, with its true (unit) normals at the corners: corner positions, corner normals,
/// and triangles.
fn coarse_sphere(centre: [f64; 3]) -> (Vec<[f64; 3]>, Vec<[f64; 3]>, Vec<[usize; 3]>) {
    const SEGMENTS: usize = 10;
    const RINGS: usize = 6;
    let mut normals = Vec::new();
    for i in 0..=RINGS {
        let theta = PI * i as f64 / RINGS as f64;
        for j in 0..SEGMENTS {
            let phi = 2.0 * PI * j as f64 / SEGMENTS as f64;
            let (x, y, z) = (
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
            normals.push([x, y, z]);
        }
    }
    let points = (normals.iter())
        .map(|n| [0, 1, 2].map(|k| centre[k] + n[k]))
        .collect();
    let mut triangles = Vec::new();
    for i in 0..RINGS {
        for j in 0..SEGMENTS {
            let at = |i: usize, j: usize| i * SEGMENTS + j % SEGMENTS;
            let (a, b, c, d) = (at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j));
            if i > 0 {
                triangles.push([a, b, c]);
            }
            if i + 1 < RINGS {
                triangles.push([a, c, d]);
            }
        }
    }
    (points, normals, triangles)
}

/// The sphere as OBJ with its corner normals, each vector given as `turn` takes it (the
/// inverse of the object's own turn, so the object lands on the sphere).
fn sphere_obj(
    (points, normals, triangles): &(Vec<[f64; 3]>, Vec<[f64; 3]>, Vec<[usize; 3]>),
    turn: fn([f64; 3]) -> [f64; 3],
) -> String {
    let mut text = String::new();
    for p in points.iter().map(|&p| turn(p)) {
        text += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    for n in normals.iter().map(|&n| turn(n)) {
        text += &format!("vn {} {} {}\n", n[0], n[1], n[2]);
    }
    for t in triangles {
        let [a, b, c] = t.map(|i| i + 1);
        text += &format!("f {a}//{a} {b}//{b} {c}//{c}\n");
    }
    text
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot3(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Along the ray from the origin towards `dir`, the nearest triangle's interpolated normal
/// (unit) and its flat normal turned to the same side.
fn smooth_and_flat(
    (points, normals, triangles): &(Vec<[f64; 3]>, Vec<[f64; 3]>, Vec<[usize; 3]>),
    dir: [f64; 3],
) -> Option<([f64; 3], [f64; 3])> {
    let mut nearest: Option<(f64, [f64; 3], [f64; 3])> = None;
    for &[a, b, c] in triangles {
        let (e1, e2) = (sub(points[b], points[a]), sub(points[c], points[a]));
        let p = cross3(dir, e2);
        let det = dot3(p, e1);
        let to = sub([0.0; 3], points[a]);
        let (u, q) = (dot3(p, to) / det, cross3(to, e1));
        let (v, t) = (dot3(dir, q) / det, dot3(q, e2) / det);
        let inside = u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0;
        if inside && nearest.is_none_or(|(best, ..)| t < best) {
            let n = [0, 1, 2]
                .map(|k| (1.0 - u - v) * normals[a][k] + u * normals[b][k] + v * normals[c][k]);
            let length = dot3(n, n).sqrt();
            let flat = cross3(e1, e2);
            let turn = dot3(flat, n).signum() / dot3(flat, flat).sqrt();
            nearest = Some((t, n.map(|x| x / length), flat.map(|x| x * turn)));
        }
    }
    nearest.map(|(_, smooth, flat)| (smooth, flat))
}

/// Per pixel of a `SIZE`² image through a 40° lens at the origin, the closed form
/// ρ/π · E · (n·l) for a sphere (E = 1) lit along `sun` (and along −`sun` too when `both`),
/// each pixel's sixteen points averaged, and whether its centre lies where the light grazes:
/// under the triangle's own plane but over its interpolated normal's (`None` off the sphere).
fn sphere_closed_form(
    sphere: &(Vec<[f64; 3]>, Vec<[f64; 3]>, Vec<[usize; 3]>),
    size: usize,
    sun: [f64; 3],
    both: bool,
) -> Vec<(f64, Option<bool>)> {
    let half = (40.0f64.to_radians() / 2.0).tan();
    let lit = |n: [f64; 3]| match both {
        true => dot3(n, sun).abs(),
        false => dot3(n, sun).max(0.0),
    };
    (0..size * size)
        .map(|pixel| {
            let (col, row) = ((pixel % size) as f64, (pixel / size) as f64);
            let ray = |dx: f64, dy: f64| {
                let x = (2.0 * (col + dx) / size as f64 - 1.0) * half;
                let y = (1.0 - 2.0 * (row + dy) / size as f64) * half;
                smooth_and_flat(sphere, [x, y, -1.0])
            };
            let points = (0..16).filter_map(|k| {
                let (dx, dy) = ((k % 4) as f64 + 0.5, (k / 4) as f64 + 0.5);
                ray(dx / 4.0, dy / 4.0)
            });
            let sum: f64 = points.map(|(smooth, _)| ALBEDO / PI * lit(smooth)).sum();
            let grazes = |(smooth, flat): ([f64; 3], [f64; 3])| {
                let (s, f) = (dot3(smooth, sun), dot3(flat, sun));
                (f < 0.0 && s > 0.0) || (both && f > 0.0 && s < 0.0)
            };
            (sum / 16.0, ray(0.5, 0.5).map(grazes))
        })
        .collect()
}

/// Light grazing a coarse smooth sphere: where it comes from under a triangle's own plane but
/// over its interpolated normal's, the point is lit by that normal as anywhere else (the
/// shadow line follows the smooth surface the normals stand for, not the facets, whose edges
/// cut the light off at up to a third of its value before), under a sun and under lamps picked
/// by the light tree, static and moving alike. Compared with the closed form over the band of
/// such pixels and over the rest of the sphere.
#[test]
fn a_coarse_spheres_shadow_line_follows_its_normals() {
    const SIZE: usize = 96;
    const SUN_DEGREES: f64 = 63.0;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sun = leaning(SUN_DEGREES);
    let centre = [0.0, 0.0, -4.0];
    let sphere = coarse_sphere(centre);
    let shot_of = |file: &str, transform: &str, lights: &str| {
        let text = shot(file, transform);
        let (cut, fov) = (
            text.find("[[light]]").unwrap(),
            2.0 * (H / DEPTH).atan().to_degrees(),
        );
        (text[..cut].to_owned() + lights)
            .replace(
                &format!("[{PIXELS}, {PIXELS}]"),
                &format!("[{SIZE}, {SIZE}]"),
            )
            .replace(&format!("fov_degrees = {fov}"), "fov_degrees = 40.0")
    };
    let sun_light = format!(
        "[[light]]\nname = \"sun\"\ntype = \"distant\"\nintensity = 1.0\nangle = 0.0\n\
         transform = {{ rotation_degrees = [0.0, {SUN_DEGREES}, 0.0] }}\n"
    );
    // Two lamps 1 km away on either side, each giving the sphere E = 1 (a normalised point
    // sends a quarter of its intensity per steradian).
    let lamp = |name: &str, side: f64| {
        let at = [0, 1, 2].map(|k| centre[k] + side * 1000.0 * sun[k]);
        format!(
            "[[light]]\nname = \"{name}\"\ntype = \"point\"\nintensity = 4.0e6\n\
             transform = {{ position = [{}, {}, {}] }}\n",
            at[0], at[1], at[2]
        )
    };
    let lamps = lamp("lamp", 1.0) + &lamp("other_lamp", -1.0);
    // Still, and keyed to creep 1 mm away during the frame turned a quarter turn about the
    // camera's axis (a moving instance, whose normals and side turn at hit time), its mesh
    // turned back so that it lands on the same sphere.
    let moving = "transform = { keys = [\
        { frame = 1, position = [0.0, 0.0, 0.0], rotation_degrees = [0.0, 0.0, 90.0] }, \
        { frame = 2, position = [0.0, 0.0, -0.001], rotation_degrees = [0.0, 0.0, 90.0] }] }";
    let still: fn([f64; 3]) -> [f64; 3] = |v| v;
    let cases: [(&str, &str, fn([f64; 3]) -> [f64; 3], &str, bool); 3] = [
        ("still", "", still, &sun_light, false),
        ("moving", moving, |[x, y, z]| [y, -x, z], &sun_light, false),
        ("lamps", "", still, &lamps, true),
    ];
    for (name, transform, turn, lights, both) in cases {
        let closed = sphere_closed_form(&sphere, SIZE, sun, both);
        let band_pixels = closed.iter().filter(|c| c.1 == Some(true)).count();
        assert!(
            band_pixels > 150,
            "{name}: {band_pixels} pixels where light grazes"
        );
        let file = format!("{name}.obj");
        std::fs::write(d.join(&file), sphere_obj(&sphere, turn)).unwrap();
        let image = render_at(d, name, &shot_of(&file, transform, lights), 16, 1);
        let ratio = |in_band: bool| {
            let (mut got, mut want) = (0.0, 0.0);
            for (pixel, (value, band)) in closed.iter().enumerate() {
                if *band == Some(in_band) {
                    got += image.rgb[pixel].y as f64;
                    want += value;
                }
            }
            got / want
        };
        let (band, lit) = (ratio(true), ratio(false));
        eprintln!("{name}: band {band:.4}, elsewhere {lit:.4} of the closed form");
        assert!(
            (band - 1.0).abs() < 0.03,
            "{name}: the band has {band:.4} of its light"
        );
        assert!(
            (lit - 1.0).abs() < 0.01,
            "{name}: elsewhere {lit:.4} of the light"
        );
    }
}
