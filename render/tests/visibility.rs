//! Geometric visibility and time through portals: per-object visibility flags, cull volumes
//! behind openings with there-side copies placed by the constraint solver, and per-opening time
//! offsets. Each is checked against a scene built without the feature that must look the same.

use crate::common;

use common::{assert_statistically_equal, box_obj, render_at, render_shot, tunnel_shot};
use glam::Vec3;
use rift_render::frame::film::{Image, relative_mse};

const RED: Vec3 = Vec3::new(0.7, 0.15, 0.1);
const GREY: Vec3 = Vec3::splat(0.5);

/// The pixels of `image` whose camera samples all teleported exactly once.
fn through_opening(image: &Image) -> Vec<usize> {
    (0..image.rgb.len())
        .filter(|&i| image.portal_depth[i] == 1.0)
        .collect()
}

fn pick(image: &Image, pixels: &[usize]) -> Vec<Vec3> {
    pixels.iter().map(|&i| image.rgb[i]).collect()
}

/// Asserts that `a` differs from `b` far beyond the noise of two renders: the control that shows
/// an equality test could fail.
fn assert_clearly_different(a: &[Vec3], b: &[Vec3], noise: f64, what: &str) {
    let err = relative_mse(a, b);
    eprintln!("{what}: relMSE {err:.3e} against noise {noise:.3e}");
    assert!(err > 4.0 * noise, "{what}: relMSE {err:e}, noise {noise:e}");
}

#[test]
fn camera_and_through_portal_flags_choose_what_camera_rays_see() {
    // An identity opening at the origin in front of a red box that fills the view: the centre
    // is seen through the opening, the corners directly.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("box.obj"),
        box_obj([-2.0, -2.0, -1.8], [2.0, 2.0, -1.5], &[]),
    )
    .unwrap();
    let shot = |flags: &str| {
        tunnel_shot(
            dir.path(),
            &format!(
                r#"
[[material]]
name = "red"
type = "diffuse"
reflectance = [{}, {}, {}]
[[object]]
name = "box"
mesh = "box.obj"
material = "red"
visibility = {{ {flags} }}
[[portal]]
name = "A"
here = {{ position = [0.0, 0.0, 0.0] }}
there = {{ position = [0.0, 0.0, 0.0] }}
[portal.surface]
radius = 1.0
"#,
                RED.x, RED.y, RED.z
            ),
        )
    };
    let (centre, corner) = (48 * 96 + 48, 2 * 96 + 2);
    let close = |a: Vec3, b: Vec3| (a - b).abs().max_element() < 1e-5;
    let all = render_shot(dir.path(), "all", &shot(""), 4);
    assert_eq!(all.portal_depth[centre], 1.0);
    assert_eq!(all.portal_depth[corner], 0.0);
    assert!(close(all.albedo[centre], RED) && close(all.albedo[corner], RED));
    // Hidden from rays that come through the opening: the wall shows there, the box elsewhere.
    let hidden = render_shot(dir.path(), "hidden", &shot("through_portal = false"), 4);
    assert!(
        close(hidden.albedo[centre], GREY),
        "{}",
        hidden.albedo[centre]
    );
    assert!(close(hidden.albedo[corner], RED));
    // Hidden from direct camera rays only: the reverse.
    let only = render_shot(dir.path(), "only", &shot("camera = false"), 4);
    assert!(close(only.albedo[centre], RED));
    assert!(close(only.albedo[corner], GREY), "{}", only.albedo[corner]);
}

#[test]
fn an_object_hidden_from_shadow_and_indirect_rays_leaves_the_lighting_as_if_absent() {
    // A black box close to a wall under a uniform sky: seen, it blocks a large part of the sky
    // from the wall around it; hidden from shadow and indirect rays, the wall must be lit as if
    // the box were not there.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("box.obj"),
        box_obj([-0.8, -0.8, -2.7], [0.8, 0.8, -2.5], &[]),
    )
    .unwrap();
    let shot = |object: &str| {
        tunnel_shot(
            dir.path(),
            &format!(
                "[[material]]\nname = \"black\"\ntype = \"diffuse\"\nreflectance = [0.0, 0.0, 0.0]\n{object}"
            ),
        )
    };
    let black_box = |flags: &str| {
        shot(&format!(
            "[[object]]\nname = \"box\"\nmesh = \"box.obj\"\nmaterial = \"black\"\nvisibility = {{ {flags} }}\n"
        ))
    };
    let spp = 32;
    let hidden = black_box("shadow = false, indirect = false");
    let a = render_at(dir.path(), "hidden", &hidden, spp, 1);
    let a2 = render_at(dir.path(), "hidden", &hidden, spp, 2);
    let absent = shot("");
    let b = render_at(dir.path(), "absent", &absent, spp, 3);
    let b2 = render_at(dir.path(), "absent", &absent, spp, 4);
    let seen = render_at(dir.path(), "seen", &black_box(""), spp, 5);
    // The wall's pixels: where the box is not in front.
    let wall: Vec<usize> = (0..a.rgb.len())
        .filter(|&i| (a.albedo[i] - GREY).abs().max_element() < 1e-5)
        .collect();
    assert!(wall.len() > 4000 && wall.len() < a.rgb.len() - 500);
    assert_statistically_equal(
        [&pick(&a, &wall), &pick(&a2, &wall)],
        [&pick(&b, &wall), &pick(&b2, &wall)],
        "box hidden from shadow and indirect rays",
    );
    let noise = relative_mse(&pick(&b2, &wall), &pick(&b, &wall));
    assert_clearly_different(
        &pick(&seen, &wall),
        &pick(&b, &wall),
        noise,
        "a box that every ray sees",
    );
}

/// A scene seen from behind an opening at the origin (facing +Z) whose there frame is 4 m along
/// +X, so both sides show: a floor, a sky, and `objects`, `culls` added.
fn cull_shot(objects: &str, culls: &str) -> String {
    format!(
        r#"
[shot]
name = "cull"
fps = 24.0
frames = [1, 1]
shutter = [0.0, 0.0]
[camera]
resolution = [120, 80]
fov_degrees = 40.0
[camera.transform]
position = [2.0, 2.5, -6.0]
look_at = [2.0, 0.0, 0.0]
[environment]
radiance = [1.0, 1.0, 1.0]
[[material]]
name = "grey"
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]
[[material]]
name = "red"
type = "diffuse"
reflectance = [0.7, 0.15, 0.1]
[[object]]
name = "floor"
mesh = "floor.obj"
material = "grey"
{objects}
[[portal]]
name = "A"
here = {{ position = [0.0, 0.0, 0.0] }}
there = {{ position = [4.0, 0.0, 0.0] }}
[portal.surface]
radius = 1.2
{culls}
"#
    )
}

#[test]
fn cull_volumes_hide_exactly_what_pokes_out_behind_each_side() {
    // A cube straddles the opening, and its copy through the opening straddles the exit. With a
    // cull volume behind each side, the two must look like the open half-boxes that a portal
    // would leave: the front half of the original and the back half of the copy.
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, text: String| std::fs::write(dir.path().join(name), text).unwrap();
    write(
        "floor.obj",
        "v -10 -1 -10\nv 14 -1 -10\nv 14 -1 10\nv -10 -1 10\nf 1 4 3 2\n".into(),
    );
    write("cube.obj", box_obj([-0.6; 3], [0.6; 3], &[]));
    write(
        "front.obj",
        box_obj([-0.6, -0.6, 0.0], [0.6, 0.6, 0.6], &["-z"]),
    );
    write(
        "back.obj",
        box_obj([-0.6, -0.6, -0.6], [0.6, 0.6, 0.0], &["+z"]),
    );
    let cube_and_copy = r#"
[[object]]
name = "cube"
mesh = "cube.obj"
material = "red"
[[object]]
name = "cube_there"
copy_of = "cube"
through = "A"
"#;
    let culls = r#"
[[portal.cull]]
objects = ["cube"]
[[portal.cull]]
objects = ["cube_there"]
side = "there"
depth = 5.0
radius = 3.0
"#;
    let halves = r#"
[[object]]
name = "front_half"
mesh = "front.obj"
material = "red"
[[object]]
name = "back_half"
mesh = "back.obj"
material = "red"
transform = { position = [4.0, 0.0, 0.0] }
"#;
    let spp = 32;
    let culled = cull_shot(cube_and_copy, culls);
    let a = render_at(dir.path(), "culled", &culled, spp, 1);
    let a2 = render_at(dir.path(), "culled", &culled, spp, 2);
    let reference = cull_shot(halves, "");
    let b = render_at(dir.path(), "halves", &reference, spp, 3);
    let b2 = render_at(dir.path(), "halves", &reference, spp, 4);
    assert_statistically_equal([&a.rgb, &a2.rgb], [&b.rgb, &b2.rgb], "culled cube and copy");
    let uncut = render_at(dir.path(), "uncut", &cull_shot(cube_and_copy, ""), spp, 5);
    let noise = relative_mse(&b2.rgb, &b.rgb);
    assert_clearly_different(&uncut.rgb, &b.rgb, noise, "without cull volumes");
}

#[test]
fn a_time_offset_shows_the_there_side_that_much_later() {
    // A box crosses behind an identity opening whose rays are delayed by 2 frames. Through the
    // opening it must look as it does, with no opening, when its keys are 2 frames earlier;
    // motion blur included.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("box.obj"),
        box_obj([-0.5, -0.5, -1.8], [0.5, 0.5, -1.2], &[]),
    )
    .unwrap();
    let shot = |first_key: i64, opening: &str| {
        let text = tunnel_shot(
            dir.path(),
            &format!(
                r#"
[[material]]
name = "red"
type = "diffuse"
reflectance = [0.7, 0.15, 0.1]
[[object]]
name = "mover"
mesh = "box.obj"
material = "red"
transform = {{ interpolation = "linear", keys = [
  {{ frame = {first_key}, position = [-1.2, 0.0, 0.0] }},
  {{ frame = {last_key}, position = [1.2, 0.0, 0.0] }},
] }}
{opening}
"#,
                last_key = first_key + 3
            ),
        );
        text.replace("shutter = [0.0, 0.0]", "shutter = [-0.25, 0.25]")
    };
    let opening = |offset: f64| {
        format!(
            "[[portal]]\nname = \"A\"\nhere = {{ position = [0.0, 0.0, 0.0] }}\nthere = {{ position = [0.0, 0.0, 0.0] }}\n[portal.surface]\nradius = 1.0\ntime_offset = {offset}\n"
        )
    };
    let spp = 32;
    let delayed = shot(1, &opening(2.0));
    let a = render_at(dir.path(), "delayed", &delayed, spp, 1);
    let a2 = render_at(dir.path(), "delayed", &delayed, spp, 2);
    let earlier = shot(-1, &opening(0.0));
    let b = render_at(dir.path(), "earlier", &earlier, spp, 3);
    let b2 = render_at(dir.path(), "earlier", &earlier, spp, 4);
    // Pixels all of whose samples went through in both (edge pixels differ with the seed).
    let in_b = through_opening(&b);
    let region: Vec<usize> = through_opening(&a)
        .into_iter()
        .filter(|i| in_b.binary_search(i).is_ok())
        .collect();
    assert!(region.len() > 2000, "{} pixels", region.len());
    assert_statistically_equal(
        [&pick(&a, &region), &pick(&a2, &region)],
        [&pick(&b, &region), &pick(&b2, &region)],
        "a 2-frame time offset",
    );
    let undelayed = render_at(dir.path(), "undelayed", &shot(1, &opening(0.0)), spp, 5);
    let noise = relative_mse(&pick(&b2, &region), &pick(&b, &region));
    assert_clearly_different(
        &pick(&undelayed, &region),
        &pick(&b, &region),
        noise,
        "no time offset",
    );
}
