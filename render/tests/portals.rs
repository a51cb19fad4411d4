//! Portals in the path tracer: nested levels, identity and tinted openings, and the equivalence
//! between looking through an opening and looking from the camera the constraint solver places
//! on the other side.

use crate::common;

use common::{
    assert_identity_opening_changes_nothing, assert_statistically_equal, equivalence, render_at,
    render_shot, square, tunnel_shot, tunnel_shot_at,
};
use glam::{DVec3, Vec3};
use rift_render::Scene;
use rift_render::frame::film::Image;
use rift_render::frame::{RenderOptions, render};
use rift_render::prepare::Prepared;
use rift_render::rift_fx::Shot;
use rift_render::rift_fx::rig::AnimatedTransform;
use std::path::Path;

/// An opening whose there frame sits 1.5 in front of its here frame: whatever enters comes out
/// in front of it again, heading back in, so the camera sees it nested in itself.
const NESTED_OPENING: &str = r#"
[[portal]]
name = "A"
here = { position = [0.0, 0.0, 0.0] }
there = { position = [0.0, 0.0, 1.5] }
[portal.surface]
radius = 1.0
"#;

#[test]
fn a_portal_seen_in_itself_shows_exactly_the_depth_limit_in_levels() {
    let dir = tempfile::tempdir().unwrap();
    for k in [1u32, 2, 4] {
        let text = tunnel_shot(
            dir.path(),
            &format!("[render]\nmax_portal_depth = {k}\n{NESTED_OPENING}"),
        );
        let image = render_shot(dir.path(), &format!("nested{k}"), &text, 4);
        let mut levels: Vec<u32> = image
            .portal_depth
            .iter()
            .filter(|d| (*d - d.round()).abs() < 1e-6)
            .map(|d| d.round() as u32)
            .collect();
        levels.sort();
        levels.dedup();
        assert_eq!(levels, (0..=k).collect::<Vec<_>>(), "limit {k}");
        assert!(image.portal_depth.iter().all(|&d| d <= k as f32));
        // Rays that reach the limit end on the opening: black, but covered.
        let centre = 48 * 96 + 48;
        assert_eq!(image.portal_depth[centre], k as f32);
        assert_eq!(image.rgb[centre], Vec3::ZERO);
        assert_eq!(image.alpha[centre], 1.0);
        // One level less deep, the rays see the wall through the opening.
        let ring = image
            .portal_depth
            .iter()
            .zip(&image.rgb)
            .filter(|(d, _)| **d == (k - 1) as f32);
        assert!(ring.clone().count() > 0);
        assert!(ring.clone().all(|(_, c)| c.min_element() > 0.0));
    }
}

#[test]
fn an_identity_opening_renders_like_no_opening() {
    // A small lamp behind the opening lights a floor in front of it: light sampling from the
    // floor is blocked by the opening's teleport region, so that light must be found by BSDF
    // sampling through it at full weight, and the image must still match.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("floor.obj"),
        "v -6 -1.2 -3\nv 6 -1.2 -3\nv 6 -1.2 6\nv -6 -1.2 6\nf 1 4 3 2\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("lamp.obj"), square(-1.0, 0.4)).unwrap();
    let scene = r#"
[render]
spp = 64
[[material]]
name = "lamp"
type = "diffuse"
reflectance = [0.0, 0.0, 0.0]
emission = [20.0, 16.0, 12.0]
[[object]]
name = "floor"
mesh = "floor.obj"
material = "grey"
[[object]]
name = "lamp"
mesh = "lamp.obj"
material = "lamp"
"#;
    let depth = assert_identity_opening_changes_nothing(dir.path(), scene, 64, "identity opening");
    assert!(depth.contains(&1.0));
}

#[test]
fn a_tinted_opening_scales_what_is_seen_through_it_by_the_tint() {
    // The opening at the origin leads 50 m away, to a lit wall; nothing on the camera's side
    // but the camera, so only camera paths cross the tinted opening.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("far.obj"), square(-53.0, 6.0)).unwrap();
    let pair = |tint: &str| {
        format!(
            r#"
[[material]]
name = "warm"
type = "diffuse"
reflectance = [0.7, 0.5, 0.3]
[[object]]
name = "far"
mesh = "far.obj"
material = "warm"
[[portal]]
name = "A"
here = {{ position = [0.0, 0.0, 0.0] }}
pair = "B"
[portal.surface]
radius = 1.0
tint = {tint}
[[portal]]
name = "B"
here = {{ position = [0.0, 0.0, -50.0], rotation_degrees = [0.0, 180.0, 0.0] }}
pair = "A"
"#
        )
    };
    let tint = Vec3::new(0.5, 0.25, 1.0);
    let plain = render_at(
        dir.path(),
        "plain",
        &tunnel_shot(dir.path(), &pair("[1.0, 1.0, 1.0]")),
        32,
        0,
    );
    let tinted = render_at(
        dir.path(),
        "tinted",
        &tunnel_shot(dir.path(), &pair("[0.5, 0.25, 1.0]")),
        32,
        0,
    );
    let region = |image: &Image| -> Vec<usize> {
        (0..image.rgb.len())
            .filter(|&i| image.portal_depth[i] == 1.0)
            .collect()
    };
    assert_eq!(region(&plain), region(&tinted));
    let pixels = region(&plain);
    assert!(pixels.len() > 1000, "{} pixels see through", pixels.len());
    let mean = |image: &Image| {
        pixels
            .iter()
            .fold(DVec3::ZERO, |s, &i| s + image.rgb[i].as_dvec3())
            / pixels.len() as f64
    };
    let ratio = mean(&tinted) / mean(&plain);
    assert!(
        (ratio - tint.as_dvec3()).abs().max_element() < 0.01 * ratio.max_element(),
        "ratio {ratio} against tint {tint}"
    );
    // Outside the opening nothing changes.
    let outside: Vec<usize> = (0..plain.rgb.len())
        .filter(|&i| plain.portal_depth[i] == 0.0)
        .collect();
    assert!(outside.iter().all(|&i| plain.rgb[i] == tinted.rgb[i]));
}

#[test]
fn through_an_opening_equals_the_solved_camera_on_the_other_side_pinhole() {
    equivalence("pinhole", |shot| {
        let at = shot.camera.transform.at(shot.time_of(12.0));
        shot.camera.transform = AnimatedTransform::constant(at);
        shot.camera.projection.aperture_radius = 0.0;
    });
}

#[test]
fn through_an_opening_equals_the_solved_camera_on_the_other_side_thin_lens() {
    equivalence("thin lens", |shot| {
        let at = shot.camera.transform.at(shot.time_of(12.0));
        shot.camera.transform = AnimatedTransform::constant(at);
        assert!(shot.camera.projection.aperture_radius > 0.0);
    });
}

#[test]
fn through_an_opening_equals_the_solved_camera_on_the_other_side_moving() {
    equivalence("moving thin lens", |shot| {
        assert!(!shot.camera.transform.is_static());
    });
}

#[test]
fn clipping_culls_only_camera_rays_that_have_not_been_teleported() {
    // A world plane keeps z ≥ −1: the wall at z = −3 disappears around the opening, while the
    // wall at z = −53 stays visible through it.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("far.obj"), square(-53.0, 6.0)).unwrap();
    let extra = r#"
[camera.clip]
world_planes = [[0.0, 0.0, 1.0, 1.0]]
[[object]]
name = "far"
mesh = "far.obj"
material = "grey"
[[portal]]
name = "A"
here = { position = [0.0, 0.0, 0.0] }
pair = "B"
[[portal]]
name = "B"
here = { position = [0.0, 0.0, -50.0], rotation_degrees = [0.0, 180.0, 0.0] }
pair = "A"
"#;
    let image = render_shot(dir.path(), "clipped", &tunnel_shot(dir.path(), extra), 4);
    let (mut inside, mut outside) = (0, 0);
    for i in 0..image.rgb.len() {
        match image.portal_depth[i] {
            0.0 => {
                outside += 1;
                assert_eq!(image.alpha[i], 0.0, "pixel {i} sees the clipped wall");
                assert_eq!(image.rgb[i], Vec3::ONE);
            }
            1.0 => {
                inside += 1;
                assert_eq!(image.alpha[i], 1.0, "pixel {i} lost the far wall");
            }
            _ => {}
        }
    }
    assert!(inside > 1000 && outside > 1000, "{inside} / {outside}");
}

#[test]
fn an_opening_10_km_from_the_origin_teleports_without_seams() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("far.obj"), square(-53.0, 6.0)).unwrap();
    // The tinted-opening layout, with everything moved by `o`.
    let shot = |o: [f64; 3]| {
        let at = |z: f64| format!("[{}, {}, {}]", o[0], o[1], z + o[2]);
        let extra = format!(
            r#"
[[object]]
name = "far"
mesh = "far.obj"
material = "grey"
transform = {{ position = {origin} }}
[[portal]]
name = "A"
here = {{ position = {origin} }}
pair = "B"
[[portal]]
name = "B"
here = {{ position = {b}, rotation_degrees = [0.0, 180.0, 0.0] }}
pair = "A"
"#,
            origin = at(0.0),
            b = at(-50.0),
        );
        tunnel_shot_at(dir.path(), o, &extra)
    };
    let near = render_at(dir.path(), "near", &shot([0.0; 3]), 16, 1);
    let near2 = render_at(dir.path(), "near2", &shot([0.0; 3]), 16, 2);
    let far = render_at(dir.path(), "far", &shot([1e4, 30.0, -1e4]), 16, 3);
    let far2 = render_at(dir.path(), "far2", &shot([1e4, 30.0, -1e4]), 16, 4);
    // The same pixels teleport, none escapes, and the images agree within their noise.
    let region = |image: &Image| {
        (0..image.rgb.len())
            .filter(|&i| image.portal_depth[i] == 1.0)
            .count()
    };
    let (n, f) = (region(&near), region(&far));
    assert!(n > 500 && n.abs_diff(f) <= n / 100, "{n} vs {f}");
    assert!(far.alpha.iter().all(|&a| a == 1.0));
    assert!(far.rgb.iter().all(|c| c.is_finite()) && far.discarded == 0);
    assert_statistically_equal([&far.rgb, &far2.rgb], [&near.rgb, &near2.rgb], "10 km away");
}

#[test]
fn the_hall_of_mirrors_example_recurses_deeply() {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/shots/hall_of_mirrors.toml");
    let mut shot = Shot::load(&file).unwrap();
    shot.camera.projection.resolution = [96, 54];
    let prepared = Prepared::new(Scene::load(&shot, 1).unwrap());
    let image = render(&prepared, &RenderOptions::new(4));
    // Levels shrink towards the vanishing point, so at this size only the first few cover whole
    // pixels; each of them must appear.
    for level in 0..=4 {
        assert!(
            image.portal_depth.contains(&(level as f32)),
            "no pixel at level {level}"
        );
    }
    let deepest = image.portal_depth.iter().fold(0.0f32, |a, &b| a.max(b));
    assert!(deepest <= prepared.scene.settings.max_portal_depth as f32);
    assert!(image.rgb.iter().all(|c| c.is_finite()) && image.discarded == 0);
}
