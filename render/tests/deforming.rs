//! Deforming meshes from mesh sequences: the blur of a growing sphere and of a shearing plane
//! against their closed-form coverage, a deforming copy through an opening (with and without a
//! time offset) against a sequence already carried and delayed, and bad sequences refused.

use crate::common;

use glam::Vec3;
use rift_render::Scene;
use rift_render::frame::film::Image;
use rift_render::rift_fx::Shot;
use std::path::Path;

const SIZE: usize = 48;
const SPP: u32 = 64;

/// Half the width of the view at z = 0 from the camera at z = 4 with a 40° field of view.
fn half_view() -> f64 {
    4.0 * 20f64.to_radians().tan()
}

/// A shot of `body` from z = 4 down −Z under a white sky, frame 1 with the shutter open over
/// the whole frame (1 → 2).
fn shot(body: &str) -> String {
    shot_from(0.0, body)
}

/// [`shot`] with the camera moved `x` along +x.
fn shot_from(x: f64, body: &str) -> String {
    format!(
        r#"
[shot]
name = "deforming"
fps = 24.0
frames = [1, 1]
shutter = [0.0, 1.0]
[camera]
resolution = [{SIZE}, {SIZE}]
fov_degrees = 40.0
transform = {{ position = [{x}, 0.0, 4.0] }}
[environment]
radiance = [1.0, 1.0, 1.0]
[[material]]
name = "grey"
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]
{body}
"#
    )
}

/// OBJ text of `vertices` and triangle `faces` (0-based).
fn obj(vertices: &[Vec3], faces: &[[usize; 3]]) -> String {
    let mut text: String = vertices
        .iter()
        .map(|v| format!("v {} {} {}\n", v.x, v.y, v.z))
        .collect();
    for f in faces {
        text += &format!("f {} {} {}\n", f[0] + 1, f[1] + 1, f[2] + 1);
    }
    text
}

/// A UV sphere of radius `r` about the origin, poles on ±Z (so the camera on +Z sees the
/// equator as its outline, a polygon of 96 sides).
fn sphere(r: f32) -> String {
    let (around, down) = (96, 48);
    let mut vertices = Vec::new();
    for i in 0..=down {
        let theta = std::f32::consts::PI * i as f32 / down as f32;
        for j in 0..around {
            let phi = std::f32::consts::TAU * j as f32 / around as f32;
            vertices.push(
                r * Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                ),
            );
        }
    }
    let at = |i: usize, j: usize| i * around + j % around;
    let mut faces = Vec::new();
    for i in 0..down {
        for j in 0..around {
            faces.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            faces.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    obj(&vertices, &faces)
}

/// The mean over pixel (`row`, `column`)'s footprint at z = 0 of `coverage(x, y)`.
fn pixel_mean(row: usize, column: usize, coverage: impl Fn(f64, f64) -> f64) -> f64 {
    let w = 2.0 * half_view() / SIZE as f64;
    let steps = 8;
    let mut sum = 0.0;
    for a in 0..steps {
        for b in 0..steps {
            let x = -half_view() + (column as f64 + (a as f64 + 0.5) / steps as f64) * w;
            let y = half_view() - (row as f64 + (b as f64 + 0.5) / steps as f64) * w;
            sum += coverage(x, y);
        }
    }
    sum / (steps * steps) as f64
}

/// Compares the renders' alpha (the share of each pixel's samples that met the object) with
/// `expected` per pixel: pixels binned by their expected coverage, each bin's mean within four
/// standard deviations of a pixel sample's coverage (a Bernoulli draw) plus 0.3%.
fn check_coverage(images: &[Image], expected: &[f64], what: &str) {
    let bins = 10;
    for (seed, image) in images.iter().enumerate() {
        let mut sums = vec![(0.0f64, 0.0f64, 0.0f64, 0usize); bins];
        for (i, &e) in expected.iter().enumerate() {
            if e <= 0.02 || e >= 0.98 {
                continue;
            }
            let bin = &mut sums[((e * bins as f64) as usize).min(bins - 1)];
            bin.0 += image.alpha[i] as f64;
            bin.1 += e;
            bin.2 += e * (1.0 - e);
            bin.3 += 1;
        }
        let used = sums.iter().filter(|b| b.3 >= 8).count();
        assert!(used >= 8, "{what}: only {used} coverage bins have pixels");
        for (k, &(got, want, var, n)) in sums.iter().enumerate().filter(|(_, b)| b.3 >= 8) {
            let n = n as f64;
            let sigma = (var / SPP as f64).sqrt() / n;
            let err = (got - want) / n;
            eprintln!("{what} seed {seed} bin {k}: {n} px, error {err:+.4} (σ {sigma:.4})");
            assert!(
                err.abs() < 4.0 * sigma + 0.003,
                "{what} seed {seed}: pixels expected at {:.3} covered {:.3} (σ {sigma:.4})",
                want / n,
                got / n
            );
        }
        // Outside the motion: fully covered and empty pixels are exactly so.
        for (i, &e) in expected.iter().enumerate() {
            if e == 0.0 || e == 1.0 {
                assert_eq!(image.alpha[i] as f64, e, "{what} seed {seed}: pixel {i}");
            }
        }
    }
}

fn render_two_seeds(dir: &Path, text: &str) -> Vec<Image> {
    [1, 2]
        .map(|seed| common::render_at(dir, "shot", text, SPP, seed))
        .into()
}

fn expected_image(coverage: impl Fn(f64, f64) -> f64 + Copy) -> Vec<f64> {
    (0..SIZE * SIZE)
        .map(|i| pixel_mean(i / SIZE, i % SIZE, coverage))
        .collect()
}

#[test]
fn a_growing_sphere_blurs_to_its_closed_form_coverage() {
    let dir = tempfile::tempdir().unwrap();
    let (r0, r1) = (0.3, 0.7);
    std::fs::write(dir.path().join("ball.0001.obj"), sphere(r0 as f32)).unwrap();
    std::fs::write(dir.path().join("ball.0002.obj"), sphere(r1 as f32)).unwrap();
    let text = shot("[[object]]\nname = \"ball\"\nmesh = \"ball.####.obj\"\nmaterial = \"grey\"\n");
    let images = render_two_seeds(dir.path(), &text);
    // The outline of a sphere of radius r seen from 4 m passes through the point at distance ρ
    // from the centre of the plane z = 0 where r = ρ / √(1 + ρ²/16); r grows linearly over the
    // shutter, so a point is covered for the share of it after r passes that.
    let expected = expected_image(|x, y| {
        let rho2 = x * x + y * y;
        let r = (rho2 / (1.0 + rho2 / 16.0)).sqrt();
        ((r1 - r) / (r1 - r0)).clamp(0.0, 1.0)
    });
    check_coverage(&images, &expected, "growing sphere");
}

#[test]
fn a_shearing_plane_blurs_to_its_closed_form_coverage() {
    let dir = tempfile::tempdir().unwrap();
    let corners = [[-0.5f32, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]];
    // Over the shutter the top edge slides 1 m along +x, the bottom edge stays.
    for (frame, shear) in [(1, 0.0), (2, 1.0)] {
        let vertices: Vec<Vec3> = corners
            .iter()
            .map(|&[x, y]| Vec3::new(x + shear * (y + 0.5), y, 0.0))
            .collect();
        let text = obj(&vertices, &[[0, 1, 2], [0, 2, 3]]);
        std::fs::write(dir.path().join(format!("sheet.{frame:04}.obj")), text).unwrap();
    }
    let text =
        shot("[[object]]\nname = \"sheet\"\nmesh = \"sheet.####.obj\"\nmaterial = \"grey\"\n");
    let images = render_two_seeds(dir.path(), &text);
    // At shutter fraction τ the point (x, y) is covered when |x − τ(y + ½)| < ½: the share of
    // τ in [0, 1] that does so.
    let expected = expected_image(|x, y| {
        if y.abs() >= 0.5 {
            return 0.0;
        }
        let h = y + 0.5;
        if h <= 0.0 {
            return f64::from(x.abs() < 0.5);
        }
        let (lo, hi) = ((x - 0.5) / h, (x + 0.5) / h);
        (hi.min(1.0) - lo.max(0.0)).max(0.0)
    });
    check_coverage(&images, &expected, "shearing plane");
}

/// A 6×6 grid of quads on z = 0 (2 m across, centred at (`cx`, 0, 0)), its height a wave
/// travelling with the frame number `f`.
fn flag(f: f64, cx: f32) -> String {
    let n = 6;
    let mut vertices = Vec::new();
    for i in 0..=n {
        for j in 0..=n {
            let (x, y) = (
                -1.0 + 2.0 * j as f32 / n as f32,
                -1.0 + 2.0 * i as f32 / n as f32,
            );
            let z = 0.4 * (2.5 * x + 1.3 * f as f32).sin() * (1.0 + y) * 0.5;
            vertices.push(Vec3::new(x + cx, y, z));
        }
    }
    let at = |i: usize, j: usize| i * (n + 1) + j;
    let mut faces = Vec::new();
    for i in 0..n {
        for j in 0..n {
            faces.push([at(i, j), at(i, j + 1), at(i + 1, j + 1)]);
            faces.push([at(i, j), at(i + 1, j + 1), at(i + 1, j)]);
        }
    }
    obj(&vertices, &faces)
}

/// An opening on the axis of a camera at the origin whose there side is 50 m along +x (where a
/// camera `camera_x` = 50 looks directly), delaying rays by `offset_frames`, with `body`.
fn flag_shot(camera_x: f64, body: &str, offset_frames: f64) -> String {
    shot_from(
        camera_x,
        &format!(
            r#"
[[portal]]
name = "A"
here = {{ position = [0.0, 0.0, 1.0] }}
there = {{ position = [50.0, 0.0, 1.0] }}
[portal.surface]
radius = 3.0
time_offset = {offset_frames}
{body}"#
        ),
    )
}

#[test]
fn a_deforming_copy_through_an_opening_is_the_sequence_carried_and_delayed() {
    let dir = tempfile::tempdir().unwrap();
    let copy_of_flag = r#"
[[object]]
name = "flag"
mesh = "flag.####.obj"
material = "grey"
transform = { position = [0.0, -20.0, 0.0] }
[[object]]
name = "flag_there"
copy_of = "flag"
through = "A"
transform = { position = [0.0, 0.0, 0.0] }
"#;
    let moved = "[[object]]\nname = \"moved\"\nmesh = \"moved.####.obj\"\nmaterial = \"grey\"\n";
    for offset in [0.0, 1.0] {
        for f in -2..=4 {
            let own = flag(f as f64, 0.0);
            std::fs::write(dir.path().join(format!("flag.{f:04}.obj")), own).unwrap();
            // The copy at frame f shows the flag `offset` frames earlier, 50 m along +x.
            let carried = flag(f as f64 - offset, 50.0);
            std::fs::write(dir.path().join(format!("moved.{f:04}.obj")), carried).unwrap();
        }
        // Seen directly on the there side, the copy is the flag `offset` frames ago; seen
        // through the opening (whose rays arrive `offset` later) it is the flag now. The flag
        // itself stands 20 m below, out of view.
        for (view, camera_x) in [("through the opening", 0.0), ("directly", 50.0)] {
            let what = format!("deforming copy seen {view}, time offset {offset}");
            let copy = flag_shot(camera_x, copy_of_flag, offset);
            let reference = flag_shot(camera_x, moved, offset);
            let render = |text: &str, seed| common::render_at(dir.path(), "s", text, 32, seed);
            let (a, a2) = (render(&copy, 1), render(&copy, 2));
            let (b, b2) = (render(&reference, 3), render(&reference, 4));
            let covered = b.alpha.iter().filter(|&&a| a > 0.0).count();
            assert!(covered > 200, "{what}: the flag covers {covered} pixels");
            common::assert_statistically_equal([&a.rgb, &a2.rgb], [&b.rgb, &b2.rgb], &what);
        }
    }
    // The offset matters: seen directly, the flag delayed by a frame is not the flag now.
    let now = flag_shot(50.0, copy_of_flag, 0.0);
    let delayed = flag_shot(50.0, copy_of_flag, 1.0);
    let render = |text: &str| common::render_at(dir.path(), "s", text, 32, 1);
    let (a, b) = (render(&now), render(&delayed));
    let diff: f32 = a
        .alpha
        .iter()
        .zip(&b.alpha)
        .map(|(x, y)| (x - y).abs())
        .sum();
    assert!(diff > 20.0, "the time offset changes nothing: {diff}");
}

/// The error loading frame 1 of `text` (written beside the sequence in `dir`) gives.
fn load_error(dir: &Path, text: &str) -> String {
    let path = dir.join("shot.toml");
    std::fs::write(&path, text).unwrap();
    let shot = Shot::load(&path).unwrap();
    match Scene::load(&shot, 1) {
        Ok(_) => panic!("loaded"),
        Err(e) => e.to_string(),
    }
}

const SHEET: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";

fn sequence_shot(mesh: &str) -> String {
    shot(&format!(
        "[[object]]\nname = \"s\"\nmesh = \"{mesh}\"\nmaterial = \"grey\"\n"
    ))
}

#[test]
fn bad_sequences_are_refused_naming_the_file_the_frame_and_the_counts() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let write = |name: &str, text: &str| std::fs::write(d.join(name), text).unwrap();

    // One frame's topology differs.
    write("a.0001.obj", SHEET);
    write("a.0002.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n");
    let e = load_error(d, &sequence_shot("a.####.obj"));
    assert!(
        e.contains("a.0002.obj")
            && e.contains("frame 2")
            && e.contains("1 triangles")
            && e.contains("has 2"),
        "{e}"
    );
    assert!(e.contains("object[0].mesh"), "{e}");

    // A frame missing inside the shutter (frames 1 and 3 only; frame 1's shutter reaches 2).
    write("b.0001.obj", SHEET);
    write("b.0003.obj", SHEET);
    let e = load_error(d, &sequence_shot("b.####.obj"));
    assert!(e.contains("frame 2 (b.0002.obj) is missing"), "{e}");

    // A non-finite vertex in one frame.
    write("c.0001.obj", SHEET);
    write("c.0002.obj", &SHEET.replace("v 1 1 0", "v 1 nan 0"));
    let e = load_error(d, &sequence_shot("c.####.obj"));
    assert!(e.contains("c.0002.obj") && e.contains("not finite"), "{e}");

    // Velocities in one frame and not the next.
    let ply = |velocities: bool| {
        let props = if velocities {
            "property float vx\nproperty float vy\nproperty float vz\n"
        } else {
            ""
        };
        let v = if velocities { " 0 0 1" } else { "" };
        format!(
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
             property float z\n{props}element face 1\nproperty list uchar int vertex_indices\n\
             end_header\n0 0 0{v}\n1 0 0{v}\n0 1 0{v}\n3 0 1 2\n"
        )
    };
    write("v.0001.ply", &ply(true));
    write("v.0002.ply", &ply(false));
    let e = load_error(d, &sequence_shot("v.####.ply"));
    assert!(
        e.contains("v.0002.ply") && e.contains("velocities for 0 of its 1"),
        "{e}"
    );

    // Normals in one frame and not the next.
    write("n.0001.obj", SHEET);
    write(
        "n.0002.obj",
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\nf 1//1 3//1 4//1\n",
    );
    let e = load_error(d, &sequence_shot("n.####.obj"));
    assert!(
        e.contains("n.0002.obj") && e.contains("normals for") && e.contains("or in none"),
        "{e}"
    );

    // An emissive material on a deforming mesh, and a sequence of files rift cannot read.
    write("e.0001.obj", SHEET);
    let lamp = "[[material]]\nname = \"lamp\"\ntype = \"diffuse\"\nemission = [1.0, 1.0, 1.0]\n\
                [[object]]\nname = \"e\"\nmesh = \"e.####.obj\"\nmaterial = \"lamp\"\n";
    let e = load_error(d, &shot(lamp));
    assert!(
        e.contains("object[0].material") && e.contains("emits light"),
        "{e}"
    );
    write("g.0001.abc", SHEET);
    let e = load_error(d, &sequence_shot("g.####.abc"));
    assert!(
        e.contains("g.0001.abc") && e.contains("expected an .obj or .ply"),
        "{e}"
    );

    // No file matches at all, and a run of # outside the file name.
    let e = load_error(d, &sequence_shot("none.####.obj"));
    assert!(
        e.contains("no file in") && e.contains("none.####.obj"),
        "{e}"
    );
    std::fs::create_dir(d.join("f0001")).unwrap();
    let e = load_error(d, &sequence_shot("f####/x.obj"));
    assert!(e.contains("must be in the file name"), "{e}");
}

#[test]
fn copies_share_the_sequence_they_deform_by() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for f in 0..=3 {
        std::fs::write(d.join(format!("flag.{f:04}.obj")), flag(f as f64, 0.0)).unwrap();
    }
    let original = "[[object]]\nname = \"flag\"\nmesh = \"flag.####.obj\"\nmaterial = \"grey\"\n";
    let load = |text: &str| {
        let path = d.join("shot.toml");
        std::fs::write(&path, text).unwrap();
        Scene::load(&Shot::load(&path).unwrap(), 1).unwrap()
    };
    let alone = load(&flag_shot(0.0, original, 0.0));
    let copies = (0..3)
        .map(|i| format!("[[object]]\nname = \"copy{i}\"\ncopy_of = \"flag\"\nthrough = \"A\"\n"))
        .collect::<String>();
    let with_copies = load(&flag_shot(0.0, &format!("{original}{copies}"), 0.0));
    assert!(alone.accel.has_deformation());
    assert!(alone.accel.deformation_bytes() > 0);
    assert_eq!(
        with_copies.accel.deformation_bytes(),
        alone.accel.deformation_bytes(),
        "three copies read the sequence again"
    );
}
