//! Ring strands in the renderer: emission radiometry against analytic values, light selection
//! agreeing with itself, visibility and intensity keys, and motion blur coverage.

use crate::common;

use common::square;
use glam::Vec3;
use rift_render::frame::film::Image;
use rift_render::frame::{RenderOptions, render};
use rift_render::lights::LightSelection;
use rift_render::prepare::Prepared;
use rift_render::rift_fx::Shot;
use rift_render::rift_fx::export::cache;
use rift_render::rift_fx::ring::{RingCurves, RingFrame};
use rift_render::scene::Overrides;
use std::path::Path;

/// One straight strand from `a` to `b` (a two-vertex strand is one segment), with velocity
/// and acceleration per vertex.
struct Straight {
    a: Vec3,
    b: Vec3,
    radius: f32,
    radiance: Vec3,
    velocity: Vec3,
    acceleration: Vec3,
}

/// Writes a ring cache for frame 1 holding `strands` as the ring of opening "a".
fn write_cache(dir: &Path, strands: &[Straight]) {
    let mut ring = RingCurves {
        opening: "a".into(),
        ..Default::default()
    };
    for s in strands {
        ring.vertex_counts.push(2);
        ring.directions.push(1);
        for p in [s.a, s.b] {
            ring.points.push(p);
            ring.velocities.push(s.velocity);
            ring.accelerations.push(s.acceleration);
            ring.widths.push(2.0 * s.radius);
            ring.colors.push(s.radiance);
            ring.intensities.push(1.0);
        }
    }
    let frame = RingFrame {
        frame: 1,
        time: 1.0 / 24.0,
        fps: 24.0,
        shutter: [0.0, 0.0],
        rings: vec![ring],
    };
    let mut bytes = Vec::new();
    cache::write(&mut bytes, &frame).unwrap();
    std::fs::write(dir.join("rings.0001.ringcache"), bytes).unwrap();
}

/// A shot whose opening "a" sits at the origin in the world's own frame (so strand
/// coordinates are world coordinates) and never teleports, with the cache above as its ring
/// and `strands` as its `[portal.surface.strands]` keys; its pair is far out of view.
fn strand_shot(camera: &str, shutter: [f64; 2], strands: &str, extra: &str) -> String {
    format!(
        r#"
[shot]
name = "strands"
fps = 24.0
frames = [1, 1]
shutter = [{s0}, {s1}]
[camera]
{camera}
[render]
rings = "rings.####.ringcache"
[[portal]]
name = "a"
here = {{ position = [0.0, 0.0, 0.0] }}
pair = "b"
[portal.surface]
opacity = 0.0
[portal.surface.strands]
{strands}
[[portal]]
name = "b"
here = {{ position = [100.0, 0.0, 0.0], rotation_degrees = [0.0, 90.0, 0.0] }}
pair = "a"
{extra}
"#,
        s0 = shutter[0],
        s1 = shutter[1]
    )
}

fn render_with(dir: &Path, text: &str, spp: u32, selection: LightSelection) -> Image {
    render_seeded(dir, text, spp, selection, None)
}

/// [`render_with`] at `seed` (`None`: the shot's).
fn render_seeded(
    dir: &Path,
    text: &str,
    spp: u32,
    selection: LightSelection,
    seed: Option<u32>,
) -> Image {
    let path = dir.join("strands.toml");
    std::fs::write(&path, text).unwrap();
    let shot = Shot::load(&path).unwrap();
    let overrides = Overrides {
        light_selection: Some(selection),
        seed,
        ..Default::default()
    };
    let prepared = Prepared::build(&shot, 1, &overrides).unwrap();
    render(&prepared, &RenderOptions::new(spp))
}

fn mean(v: &[Vec3]) -> Vec3 {
    v.iter().copied().sum::<Vec3>() / v.len() as f32
}

#[test]
fn a_strand_seen_head_on_shows_its_radiance_scaled_by_intensity_and_hides_by_flag() {
    let dir = tempfile::tempdir().unwrap();
    let radiance = Vec3::new(2.0, 1.0, 0.5) * 3.0;
    write_cache(
        dir.path(),
        &[Straight {
            a: Vec3::new(0.0, -3.0, 0.0),
            b: Vec3::new(0.0, 3.0, 0.0),
            radius: 0.2,
            radiance,
            velocity: Vec3::ZERO,
            acceleration: Vec3::ZERO,
        }],
    );
    let camera = r#"resolution = [32, 32]
fov_degrees = 2.0
[camera.transform]
position = [0.0, 0.0, 5.0]
look_at = [0.0, 0.0, 0.0]"#;
    let sky = "[environment]\nradiance = [0.1, 0.2, 0.3]";
    let shot = |strands: &str| strand_shot(camera, [0.0, 0.0], strands, sky);
    // The 2° view is 0.17 units wide at the strand: every pixel sees the strand.
    let plain = render_with(dir.path(), &shot(""), 4, LightSelection::Tree);
    let m = mean(&plain.rgb);
    assert!(
        (m - radiance).abs().max_element() < 1e-3 * radiance.max_element(),
        "{m} against {radiance}"
    );
    assert!(plain.alpha.iter().all(|&a| a == 1.0));
    let brighter = render_with(
        dir.path(),
        &shot("intensity = 2.5"),
        4,
        LightSelection::Tree,
    );
    let m = mean(&brighter.rgb);
    assert!((m - 2.5 * radiance).abs().max_element() < 1e-3 * radiance.max_element() * 2.5);
    let hidden = render_with(
        dir.path(),
        &shot("visibility = { camera = false }"),
        4,
        LightSelection::Tree,
    );
    let m = mean(&hidden.rgb);
    assert!(
        (m - Vec3::new(0.1, 0.2, 0.3)).abs().max_element() < 1e-4,
        "{m}: the sky, not the strand"
    );
}

/// Irradiance at (0, 0, z0) on the plane y = 0 from a strand of radius r and radiance L along
/// x ∈ [−a, a] at height h, z = 0: with D the receiver's distance to the axis,
/// E = 2·r·L·h·D·∫ dx / (D² + x²)² (each length element subtends 2r·dx·(D/d)/d² and meets
/// the plane at cos = h/d).
fn strand_irradiance(r: f64, l: f64, h: f64, z0: f64, a: f64) -> f64 {
    let d2 = h * h + z0 * z0;
    let d = d2.sqrt();
    let integral = a / (d2 * (d2 + a * a)) + (a / d).atan() / (d2 * d);
    2.0 * r * l * h * d * integral
}

/// A camera on a small patch of [`FLOOR`] around (0, 0, 1.5).
const FLOOR_CAMERA: &str = r#"resolution = [16, 16]
fov_degrees = 1.0
[camera.transform]
position = [0.0, 4.0, 2.5]
look_at = [0.0, 0.0, 1.5]"#;

/// A grey floor facing +Y (`floor.obj`, the square facing +Z, turned −90° about X).
const FLOOR: &str = r#"[[material]]
name = "grey"
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]
[[object]]
name = "floor"
mesh = "floor.obj"
material = "grey"
transform = { position = [0.0, 0.0, 0.0], rotation_degrees = [-90.0, 0.0, 0.0] }"#;

/// The long strand of [`strand_irradiance`] in 64 pieces end to end (ring strands are closed
/// loops, so each piece is a strand of its own), still or sliding along its own axis by 2.5
/// pieces over the shutter: that leaves the light on the floor unchanged while every piece's
/// bounds and the light tree's moving spheres do change.
#[test]
fn a_long_straight_strand_lights_a_floor_as_the_analytic_irradiance_says() {
    let dir = tempfile::tempdir().unwrap();
    let (r, l, h, z0, a, albedo) = (0.01, 10.0, 1.0, 1.5, 20.0, 0.5);
    std::fs::write(dir.path().join("floor.obj"), square(0.0, 60.0)).unwrap();
    let want = albedo / std::f64::consts::PI
        * strand_irradiance(r as f64, l as f64, h as f64, z0, a as f64);
    let pieces = 64;
    // 2.5 segments in the shutter's 1/24 s.
    let slide = 2.5 * 2.0 * a / pieces as f32 * 24.0;
    for (velocity, shutter) in [(0.0, [0.0, 0.0]), (slide, [-0.5, 0.5])] {
        let end = |k: usize| Vec3::new(-a + 2.0 * a * k as f32 / pieces as f32, h, 0.0);
        let strand: Vec<Straight> = (0..pieces)
            .map(|k| Straight {
                a: end(k),
                b: end(k + 1),
                radius: r,
                radiance: Vec3::splat(l),
                velocity: Vec3::new(velocity, 0.0, 0.0),
                acceleration: Vec3::ZERO,
            })
            .collect();
        write_cache(dir.path(), &strand);
        let text = strand_shot(FLOOR_CAMERA, shutter, "", FLOOR);
        for selection in [LightSelection::Tree, LightSelection::Power] {
            let image = render_with(dir.path(), &text, 256, selection);
            let got = mean(&image.rgb);
            let rel = (got.x as f64 - want).abs() / want;
            eprintln!("{velocity} m/s, {selection:?}: {got} against {want:.5} ({rel:.4})");
            assert!(
                rel < 0.01,
                "{velocity} m/s, {selection:?}: floor radiance {got} against {want}"
            );
        }
    }
}

/// A dense bundle over the floor: five by five straight strands 1 m up (radius 0.01, 0.005
/// between neighbours' surfaces), the middle ones hidden from the floor by the others. The
/// tree weighs every strand by its exposure, power alone does not; both must light the floor
/// alike.
#[test]
fn a_dense_bundle_lights_a_floor_alike_whether_exposure_weighs_its_strands_or_not() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("floor.obj"), square(0.0, 60.0)).unwrap();
    let (radius, pitch, pieces, half_length) = (0.01f32, 0.025f32, 32, 5.0f32);
    let mut bundle = Vec::new();
    for row in 0..5 {
        for column in 0..5 {
            let (y, z) = (1.0 + row as f32 * pitch, column as f32 * pitch);
            let x = |k: usize| -half_length + 2.0 * half_length * k as f32 / pieces as f32;
            bundle.extend((0..pieces).map(|k| Straight {
                a: Vec3::new(x(k), y, z),
                b: Vec3::new(x(k + 1), y, z),
                radius,
                radiance: Vec3::splat(10.0),
                velocity: Vec3::ZERO,
                acceleration: Vec3::ZERO,
            }));
        }
    }
    write_cache(dir.path(), &bundle);
    let text = strand_shot(FLOOR_CAMERA, [0.0, 0.0], "", FLOOR);
    let [tree, tree_again, power, power_again] = [
        (LightSelection::Tree, 1),
        (LightSelection::Tree, 2),
        (LightSelection::Power, 3),
        (LightSelection::Power, 4),
    ]
    .map(|(selection, seed)| render_seeded(dir.path(), &text, 128, selection, Some(seed)));
    common::assert_statistically_equal(
        [&tree.rgb, &tree_again.rgb],
        [&power.rgb, &power_again.rgb],
        "floor under a dense bundle",
    );
}

#[test]
fn a_strand_sweeping_across_pixels_covers_the_analytic_area() {
    let dir = tempfile::tempdir().unwrap();
    // A vertical strand 0.04 wide sweeping along +X across a 2-unit-wide orthographic-like
    // view (a long lens far away), with acceleration so the motion is curved in time.
    let (radius, v, acc) = (0.02f32, 24.0f32, -200.0f32);
    write_cache(
        dir.path(),
        &[Straight {
            a: Vec3::new(-0.25, -2.0, 0.0),
            b: Vec3::new(-0.25, 2.0, 0.0),
            radius,
            radiance: Vec3::ONE,
            velocity: Vec3::new(v, 0.0, 0.0),
            acceleration: Vec3::new(acc, 0.0, 0.0),
        }],
    );
    let camera = r#"resolution = [128, 16]
fov_degrees = 0.2291831
[camera.transform]
position = [0.0, 0.0, 500.0]
look_at = [0.0, 0.0, 0.0]"#;
    // The shutter is the frame's whole duration, centred on it: Δ ∈ [−1/48, 1/48] s.
    let image = render_with(
        dir.path(),
        &strand_shot(camera, [-0.5, 0.5], "", ""),
        256,
        LightSelection::Tree,
    );
    // The view is 2 units wide: column c covers x ∈ [−1 + c/64, −1 + (c+1)/64].
    let x_at = |delta: f32| -0.25 + delta * (v + 0.5 * delta * acc);
    let half = 1.0 / 48.0;
    let steps = 20_000;
    for c in 0..128 {
        let (x0, x1) = (-1.0 + c as f32 / 64.0, -1.0 + (c + 1) as f32 / 64.0);
        // Time-averaged fraction of the column the strand's silhouette covers.
        let mut expected = 0.0;
        for k in 0..steps {
            let delta = -half + 2.0 * half * (k as f32 + 0.5) / steps as f32;
            let x = x_at(delta);
            let overlap = ((x + radius).min(x1) - (x - radius).max(x0)).max(0.0);
            expected += overlap / (x1 - x0) / steps as f32;
        }
        let column: f32 = (0..16).map(|y| image.alpha[y * 128 + c]).sum::<f32>() / 16.0;
        assert!(
            (column - expected).abs() < 0.02 + 0.05 * expected,
            "column {c}: coverage {column} against {expected}"
        );
    }
    let total: f32 = image.alpha.iter().sum::<f32>() / 16.0 / 64.0;
    assert!(
        (total - 2.0 * radius).abs() < 0.02 * 2.0 * radius,
        "swept area {total}"
    );
}
