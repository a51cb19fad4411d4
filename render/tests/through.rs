//! Light sampling through openings: the estimate must not change (same means with the new
//! sampling on and off, per region), only its noise, for every kind of opening and emitter.

use crate::common;

use common::{box_obj, render_at};
use glam::{DVec2, DVec3, Vec3};
use rift_render::Scene;
use rift_render::frame::film::{Image, relative_mse};
use rift_render::geometry::Ray;
use rift_render::lights::Receiver;
use rift_render::prepare::Prepared;
use rift_render::rift_fx::Shot;
use rift_render::through::{Strategies, Survey, View};
use std::path::Path;

/// A dark room (a closed grey box around the origin, camera inside) whose only light comes
/// through an opening in its −X wall from a second room 30 m away, where `light` sits (TOML
/// sections). `here` and `there` are extra keys for the two openings' `[portal.surface]`;
/// `extra` adds anything else.
fn two_rooms(dir: &Path, here: &str, there: &str, light: &str, extra: &str) -> String {
    std::fs::write(
        dir.join("room.obj"),
        box_obj([-2.0, 0.0, -2.0], [2.0, 3.0, 2.0], &[]),
    )
    .unwrap();
    std::fs::write(
        dir.join("lamp.obj"),
        box_obj([-0.3, -0.3, -0.3], [0.3, 0.3, 0.3], &[]),
    )
    .unwrap();
    format!(
        r#"
[shot]
name = "rooms"
fps = 24.0
frames = [1, 1]
shutter = [-0.25, 0.25]
[camera]
resolution = [40, 30]
fov_degrees = 70.0
[camera.transform]
position = [1.6, 1.6, 1.5]
look_at = [-2.0, 0.8, -0.6]
[render]
max_bounces = 3
[[material]]
name = "grey"
type = "diffuse"
reflectance = [0.6, 0.6, 0.6]
[[material]]
name = "soot"
type = "diffuse"
reflectance = [0.05, 0.05, 0.05]
[[material]]
name = "lamp"
type = "diffuse"
reflectance = [0.0, 0.0, 0.0]
emission = [10.0, 8.0, 6.0]
two_sided_emission = true
[[object]]
name = "room"
mesh = "room.obj"
material = "grey"
[[object]]
name = "far_room"
mesh = "room.obj"
material = "soot"
transform = {{ position = [30.0, 0.0, 0.0] }}
{light}
[[portal]]
name = "window"
here = {{ position = [-1.98, 1.4, 0.0], rotation_degrees = [0.0, 90.0, 0.0] }}
pair = "window_there"
[portal.surface]
{here}
[[portal]]
name = "window_there"
here = {{ position = [31.98, 1.4, 0.0], rotation_degrees = [0.0, -90.0, 0.0] }}
pair = "window"
[portal.surface]
{there}
{extra}
"#
    )
}

const LAMP: &str = r#"
[[object]]
name = "lamp"
mesh = "lamp.obj"
material = "lamp"
transform = { position = [29.6, 1.5, 0.2] }
"#;

/// The lamp in a third room, reached from the far room's −Z wall: two openings in a row
/// (the `extra` of [`two_rooms`], with no light in the far room).
fn third_room_lamp() -> String {
    format!(
        r#"
[[object]]
name = "third_room"
mesh = "room.obj"
material = "soot"
transform = {{ position = [60.0, 0.0, 0.0] }}
{}
[[portal]]
name = "door"
here = {{ position = [30.0, 1.4, -1.98] }}
pair = "door_there"
[portal.surface]
rectangle = [1.4, 1.4]
[[portal]]
name = "door_there"
here = {{ position = [60.0, 1.4, 1.98], rotation_degrees = [0.0, 180.0, 0.0] }}
pair = "door"
[portal.surface]
rectangle = [1.4, 1.4]
"#,
        LAMP.replace("[29.6, 1.5, 0.2]", "[60.2, 1.5, 0.6]")
    )
}

const RECTANGLE: &str = "rectangle = [1.6, 1.2]";
/// Half of [`RECTANGLE`]'s sides.
const RECTANGLE_HALF: [f64; 2] = [0.8, 0.6];
const DISK_RADIUS: f64 = 0.7;
const POLYGON_POINTS: [[f64; 2]; 5] = [
    [-0.8, -0.6],
    [0.8, -0.6],
    [0.9, 0.2],
    [0.0, 0.7],
    [-0.9, 0.2],
];

/// The edge of a test opening's teleport region, in its local plane.
enum Outline {
    /// Corners, counter-clockwise.
    Polygon(Vec<DVec2>),
    Disk(f64),
}

/// The opening shapes every shape test tries: name, `[portal.surface]` key, outline.
fn shapes() -> [(&'static str, String, Outline); 3] {
    let [hx, hy] = RECTANGLE_HALF;
    assert_eq!(
        RECTANGLE,
        format!("rectangle = [{:?}, {:?}]", 2.0 * hx, 2.0 * hy)
    );
    let corners = |points: &[[f64; 2]]| points.iter().map(|&[x, y]| DVec2::new(x, y)).collect();
    [
        (
            "rectangle",
            RECTANGLE.to_owned(),
            Outline::Polygon(corners(&[[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]])),
        ),
        (
            "polygon",
            format!("polygon = {POLYGON_POINTS:?}"),
            Outline::Polygon(corners(&POLYGON_POINTS)),
        ),
        (
            "disk",
            format!("radius = {DISK_RADIUS}"),
            Outline::Disk(DISK_RADIUS),
        ),
    ]
}

/// Which pixels of an image a check reads: the beauty, or one of its layers.
type Part = fn(&Image) -> &[Vec3];

fn beauty(image: &Image) -> &[Vec3] {
    &image.rgb
}

fn through(image: &Image) -> &[Vec3] {
    image
        .through
        .as_deref()
        .expect("a scene with openings has a through layer")
}

/// Channel means of `part` over the pixels where the camera saw only the dark room itself (no
/// sample teleported), and over the whole frame.
fn region_means(image: &Image, part: Part) -> (DVec3, DVec3) {
    let values = part(image);
    let mean = |keep: &dyn Fn(usize) -> bool| {
        let (sum, n) = (0..values.len())
            .filter(|&i| keep(i))
            .fold((DVec3::ZERO, 0usize), |(s, n), i| {
                (s + values[i].as_dvec3(), n + 1)
            });
        sum / n.max(1) as f64
    };
    (mean(&|i| image.portal_depth[i] == 0.0), mean(&|_| true))
}

/// Renders `shot` with the new sampling on (`spp`) and off (4 × `spp`, it is noisier), two
/// seeds each, and checks that both estimate the same image: over the dark room and over the
/// frame, the means differ by less than 8% plus five standard errors (each estimator's taken
/// from its two seeds; BSDF sampling alone is heavy-tailed there, so two seeds understate its
/// error, and converged renders agree within 1%; a missing opacity, tint or MIS factor is off
/// by tens of percent), and, where `less_noisy`, the new sampling is the less noisy at a
/// quarter of the samples. `part` picks the beauty or a layer.
fn same_estimate(dir: &Path, name: &str, shot: &str, spp: u32, less_noisy: bool, part: Part) {
    let off = shot.replace("[render]", "[render]\nlight_through_openings = false");
    let on = [1, 2].map(|seed| render_at(dir, name, shot, spp, seed));
    let off = [3, 4].map(|seed| render_at(dir, &format!("{name}_off"), &off, 4 * spp, seed));
    for image in on.iter().chain(&off) {
        assert_eq!(image.discarded, 0, "{name}: samples discarded");
        assert!(
            image.rgb.iter().all(|c| c.is_finite()),
            "{name}: NaN or Inf"
        );
    }
    let on_means = on.each_ref().map(|i| region_means(i, part));
    let off_means = off.each_ref().map(|i| region_means(i, part));
    assert!(
        off_means[0].0.min_element() > 1e-4,
        "{name}: the dark room is not lit ({})",
        off_means[0].0
    );
    let pick = [|m: &(DVec3, DVec3)| m.0, |m: &(DVec3, DVec3)| m.1];
    for (what, part) in ["dark room", "frame"].into_iter().zip(pick) {
        let (a, b) = (
            on_means.each_ref().map(part),
            off_means.each_ref().map(part),
        );
        let (mean_on, mean_off) = (0.5 * (a[0] + a[1]), 0.5 * (b[0] + b[1]));
        // The standard error of the mean of two draws is about half their difference.
        let error = (0.25 * ((a[0] - a[1]).powf(2.0) + (b[0] - b[1]).powf(2.0))).powf(0.5);
        let allowed = 0.08 * mean_off + 5.0 * error;
        eprintln!(
            "{name} {what}: on {mean_on:.5} off {mean_off:.5}, allowed ±{allowed:.5} (rel {:.4})",
            ((mean_on - mean_off) / mean_off).abs().max_element()
        );
        assert!(
            (mean_on - mean_off).abs().cmple(allowed).all(),
            "{name} {what}: mean {mean_on} with light through openings, {mean_off} without \
             (allowed ±{allowed})"
        );
    }
    // Noise over the dark room: its pixels of each image.
    let room = |image: &Image| -> Vec<Vec3> {
        (0..image.rgb.len())
            .filter(|&i| on[0].portal_depth[i] == 0.0 && on[1].portal_depth[i] == 0.0)
            .map(|i| part(image)[i])
            .collect()
    };
    let noise_on = relative_mse(&room(&on[0]), &room(&on[1]));
    let noise_off = relative_mse(&room(&off[0]), &room(&off[1]));
    eprintln!("{name}: relMSE between seeds: on {noise_on:.3e}, off (4× spp) {noise_off:.3e}");
    assert!(
        !less_noisy || noise_on < noise_off,
        "{name}: sampling through openings is noisier ({noise_on:e} against {noise_off:e})"
    );
}

#[test]
fn a_lamp_seen_through_rectangle_polygon_and_disk_openings_gives_the_same_image() {
    let dir = tempfile::tempdir().unwrap();
    for (name, shape, _) in shapes() {
        let shot = two_rooms(dir.path(), &shape, &shape, LAMP, "");
        same_estimate(dir.path(), name, &shot, 256, true, beauty);
    }
}

#[test]
fn opacity_tint_motion_and_time_offsets_keep_the_estimate() {
    let dir = tempfile::tempdir().unwrap();
    let moving = r#"
[[portal]]
name = "moving"
here = { keys = [
  { frame = 0, position = [0.0, 1.4, 1.98], rotation_degrees = [0.0, 180.0, 0.0] },
  { frame = 2, position = [0.4, 1.5, 1.98], rotation_degrees = [0.0, 180.0, 0.0] },
] }
pair = "moving_there"
[portal.surface]
radius = 0.5
[[portal]]
name = "moving_there"
here = { position = [30.0, 1.4, -1.98] }
pair = "moving"
[portal.surface]
radius = 0.5
"#;
    let moving_lamp = r#"
[[object]]
name = "lamp"
mesh = "lamp.obj"
material = "lamp"
transform = { interpolation = "linear", keys = [
  { frame = 0, position = [29.4, 1.3, 0.2] },
  { frame = 2, position = [29.8, 1.7, -0.2] },
] }
"#;
    let half = format!("{RECTANGLE}\nopacity = 0.5\ntint = [1.0, 0.6, 0.3]");
    let delayed = format!("{RECTANGLE}\ntime_offset = 0.5");
    for (name, here, light, extra) in [
        ("opacity and tint", half.as_str(), LAMP, ""),
        ("moving opening", RECTANGLE, LAMP, moving),
        ("time offset", delayed.as_str(), moving_lamp, ""),
    ] {
        let shot = two_rooms(dir.path(), here, RECTANGLE, light, extra);
        same_estimate(dir.path(), name, &shot, 256, true, beauty);
    }
}

#[test]
fn the_environment_strands_and_a_chain_of_two_openings_light_through_openings() {
    let dir = tempfile::tempdir().unwrap();
    // The far room has no −Z wall: the sky lights it, and the dark room through the window.
    std::fs::write(
        dir.path().join("open_room.obj"),
        box_obj([-2.0, 0.0, -2.0], [2.0, 3.0, 2.0], &["-z"]),
    )
    .unwrap();
    let sky = r#"
[environment]
radiance = [0.6, 0.8, 1.2]
"#;
    let open = two_rooms(dir.path(), RECTANGLE, RECTANGLE, "", sky).replace(
        "mesh = \"room.obj\"\nmaterial = \"soot\"",
        "mesh = \"open_room.obj\"\nmaterial = \"soot\"",
    );
    // Light sampling of the sky from beyond the window rarely picks a direction through it (the
    // window is a small part of the sky): points drawn on the window find it.
    same_estimate(dir.path(), "environment", &open, 256, true, beauty);

    // A ring on a third opening in the far room: its strands light the far room and, through
    // the window, the dark room.
    let ring = r#"
[[portal]]
name = "ringed"
here = { position = [30.0, 1.5, -1.9] }
pair = "ringed_there"
[portal.ring]
radius = 0.6
band = 0.05
strands = 6
width = 0.02
color = { intensity = 40.0 }
[[portal]]
name = "ringed_there"
here = { position = [60.0, 1.5, 0.0] }
pair = "ringed"
"#;
    let strands = two_rooms(dir.path(), RECTANGLE, RECTANGLE, "", ring);
    same_estimate(dir.path(), "strands", &strands, 256, true, beauty);

    // Thick strands packed into a flat band, facing the window: they hide most of one another,
    // much of it within a millimetre of their surfaces, so a shadow ray that stops short of the
    // light by more than that counts hidden light (it came out 76% too bright at 1 mm).
    let packed = r#"
[[portal]]
name = "ringed"
here = { position = [30.0, 1.5, -1.9], rotation_degrees = [0.0, 90.0, 0.0] }
pair = "ringed_there"
[portal.ring]
radius = 0.6
band = 0.06
strands = 12
width = 0.08
width_variation = 0.0
noise = { amplitude = 0.0, depth = 0.0 }
color = { intensity = 10.0 }
[[portal]]
name = "ringed_there"
here = { position = [60.0, 1.5, 0.0] }
pair = "ringed"
"#;
    let packed = two_rooms(dir.path(), RECTANGLE, RECTANGLE, "", packed);
    same_estimate(dir.path(), "packed strands", &packed, 256, true, beauty);

    let two = two_rooms(dir.path(), RECTANGLE, RECTANGLE, "", &third_room_lamp());
    same_estimate(dir.path(), "two openings", &two, 256, true, beauty);
}

#[test]
fn each_kind_of_light_lights_the_dark_room_through_the_window() {
    let dir = tempfile::tempdir().unwrap();
    // A light of each kind with a surface in the lamp room, facing the window on its +X wall.
    let aim = "transform = { position = [29.0, 1.5, 0.2], rotation_degrees = [0.0, -90.0, 0.0] }";
    let lights = [
        (
            "sphere light",
            "type = \"point\"\nintensity = 40.0\nradius = 0.2",
        ),
        (
            "rect light",
            "type = \"rect\"\nintensity = 20.0\nwidth = 0.6\nheight = 0.6",
        ),
        (
            "disk light",
            "type = \"disk\"\nintensity = 20.0\nradius = 0.3",
        ),
        (
            "soft spot light",
            "type = \"spot\"\nintensity = 40.0\nradius = 0.2\ncone_angle = 50.0\ncone_softness = 0.4",
        ),
    ];
    for (name, keys) in lights {
        let light = format!("[[light]]\nname = \"light\"\n{keys}\n{aim}\n");
        let shot = two_rooms(dir.path(), RECTANGLE, RECTANGLE, &light, "");
        same_estimate(dir.path(), name, &shot, 128, false, beauty);
    }
    // A point has no surface: only light sampling through the window finds it, so it is
    // checked against a normalised sphere of 2 cm, which gives the same light.
    let point = format!(
        "[[light]]\nname = \"light\"\ntype = \"spot\"\nintensity = 40.0\ncone_angle = 60.0\n{aim}\n"
    );
    let sphere = point.replace(
        "intensity = 40.0",
        "intensity = 40.0\nradius = 0.02\nnormalize = true",
    );
    let [a, b] = [point, sphere].map(|light| {
        let shot = two_rooms(dir.path(), RECTANGLE, RECTANGLE, &light, "");
        [1, 2].map(|seed| render_at(dir.path(), "point", &shot, 64, seed))
    });
    common::assert_statistically_equal(
        [&a[0].rgb, &a[1].rgb],
        [&b[0].rgb, &b[1].rgb],
        "a point through the window against a small sphere",
    );
    // A sun shining into the far room through its open side and on through the window.
    std::fs::write(
        dir.path().join("open_room.obj"),
        box_obj([-2.0, 0.0, -2.0], [2.0, 3.0, 2.0], &["-z"]),
    )
    .unwrap();
    let sun = r#"
[[light]]
name = "sun"
type = "distant"
intensity = 3.0
angle = 5.0
normalize = true
transform = { rotation_degrees = [0.0, -135.0, 0.0] }
"#;
    let open = two_rooms(dir.path(), RECTANGLE, RECTANGLE, "", sun).replace(
        "mesh = \"room.obj\"\nmaterial = \"soot\"",
        "mesh = \"open_room.obj\"\nmaterial = \"soot\"",
    );
    same_estimate(dir.path(), "sun", &open, 256, false, beauty);
}

#[test]
fn chains_of_two_openings_are_searched_only_where_they_may_matter() {
    let dir = tempfile::tempdir().unwrap();
    // The chains light sampling may take at a floor point of the dark room, as their lengths,
    // when the dark room holds `own_light` and the third room the lamp.
    let chains = |own_light: &str| -> Vec<u32> {
        let text = two_rooms(
            dir.path(),
            RECTANGLE,
            RECTANGLE,
            own_light,
            &third_room_lamp(),
        );
        let path = dir.path().join("rooms.toml");
        std::fs::write(&path, &text).unwrap();
        let prepared = prepare(&path);
        let [start, end] = prepared.scene.portals.times();
        let at = Receiver {
            p: Vec3::new(0.5, 0.01, 0.0),
            n: Some(Vec3::Y),
            time: 0.5 * (start + end),
        };
        let mut strategies = None;
        Strategies::update(&mut strategies, &view(&prepared), &at);
        let chains = strategies.iter().flat_map(|s| s.chains());
        chains.map(|(chain, _)| chain.teleports()).collect()
    };
    // Lit only from the third room: window then door is the chain that brings the light.
    let dark = chains("");
    assert!(
        dark.contains(&2),
        "lit from the third room: chains {dark:?}"
    );
    // A lamp of the room's own half a metre above the point outshines anything two openings
    // away: the search stops at the window (which the lamp's light comes back through).
    let own = LAMP
        .replace("\"lamp\"\nmesh", "\"own_lamp\"\nmesh")
        .replace("[29.6, 1.5, 0.2]", "[0.5, 0.6, 0.0]");
    let lit = chains(&own);
    assert!(!lit.contains(&2), "a lamp beside the point: chains {lit:?}");
}

#[test]
fn the_dark_room_is_lit_only_through_the_window() {
    // Sanity for the tests above: with the window closed (opacity 0) the dark room is black.
    let dir = tempfile::tempdir().unwrap();
    let shot = two_rooms(
        dir.path(),
        "rectangle = [1.6, 1.2]\nopacity = 0.0",
        RECTANGLE,
        LAMP,
        "",
    );
    let image = render_at(dir.path(), "closed", &shot, 16, 1);
    let (region, _) = region_means(&image, beauty);
    assert!(region.max_element() < 1e-6, "light leaks: {region}");
}

#[test]
fn light_through_openings_has_its_own_layer_and_the_two_layers_sum_to_the_beauty() {
    let dir = tempfile::tempdir().unwrap();
    let room_lamp = r#"
[[object]]
name = "room_lamp"
mesh = "lamp.obj"
material = "lamp"
transform = { position = [1.2, 2.6, -1.2], scale = 0.3 }
"#;
    let dark_room = |image: &Image| -> Vec<usize> {
        (0..image.rgb.len())
            .filter(|&i| image.portal_depth[i] == 0.0)
            .collect()
    };
    // The far lamp alone: all the dark room shows arrived through the window.
    let far_lamp = two_rooms(dir.path(), RECTANGLE, RECTANGLE, LAMP, "");
    let image = render_at(dir.path(), "far_lamp", &far_lamp, 16, 1);
    for i in dark_room(&image) {
        let (beauty, through) = (image.rgb[i], through(&image)[i]);
        assert!(
            (beauty - through).abs().max_element() <= 1e-6 * beauty.max_element(),
            "pixel {i}: beauty {beauty}, through {through}"
        );
    }
    // The room's own lamp alone: only what left through the window and came back off the
    // sooty far room (a few percent at most) is light through openings.
    let own_lamp = two_rooms(dir.path(), RECTANGLE, RECTANGLE, room_lamp, "");
    let image = render_at(dir.path(), "own_lamp", &own_lamp, 64, 1);
    let (all, came_back) = (
        region_means(&image, beauty).0,
        region_means(&image, through).0,
    );
    assert!(
        came_back.max_element() > 0.0 && came_back.max_element() < 0.03 * all.min_element(),
        "own lamp: through {came_back} of {all}"
    );

    // Both: the through layer is the same estimate with the new sampling on and off, and less
    // noisy with it.
    let both = two_rooms(
        dir.path(),
        RECTANGLE,
        RECTANGLE,
        &format!("{LAMP}{room_lamp}"),
        "",
    );
    same_estimate(dir.path(), "through layer", &both, 256, true, through);

    // In the EXR, throughOpenings + notThroughOpenings is the beauty.
    let image = render_at(dir.path(), "both", &both, 16, 1);
    let path = dir.path().join("both.exr");
    image.write_exr(&path).unwrap();
    let layer = rift_render::frame::film::read_exr_layer(&path).unwrap();
    for c in ["R", "G", "B"] {
        let get = |name: &str| &layer.channels[name];
        let (sum, a, b) = (
            get(c),
            get(&format!("throughOpenings.{c}")),
            get(&format!("notThroughOpenings.{c}")),
        );
        assert!(a.iter().any(|&v| v > 0.0) && b.iter().any(|&v| v > 0.0));
        for i in 0..sum.len() {
            assert!(
                (sum[i] - (a[i] + b[i])).abs() <= 1e-6 * sum[i].abs(),
                "{c} at {i}: {} + {} != {}",
                a[i],
                b[i],
                sum[i]
            );
        }
    }
}

/// Points just inside and just outside `outline`: (inside, outside) pairs `EDGE_STEP` from
/// points along each edge, or around the disk.
fn edge_pairs(outline: &Outline) -> Vec<(DVec2, DVec2)> {
    const EDGE_STEP: f64 = 2e-5;
    let polygon = match outline {
        Outline::Polygon(corners) => corners,
        Outline::Disk(radius) => {
            return (0..64)
                .map(|k| {
                    let u = DVec2::from_angle(std::f64::consts::TAU * (k as f64 + 0.5) / 64.0);
                    (u * (radius - EDGE_STEP), u * (radius + EDGE_STEP))
                })
                .collect();
        }
    };
    let mut pairs = Vec::new();
    for (k, &a) in polygon.iter().enumerate() {
        let b = polygon[(k + 1) % polygon.len()];
        // Counter-clockwise: the inside is to the left of each edge.
        let inward = (b - a).perp().normalize();
        for s in 1..16 {
            let p = a.lerp(b, s as f64 / 16.0);
            pairs.push((p + inward * EDGE_STEP, p - inward * EDGE_STEP));
        }
    }
    pairs
}

#[test]
fn rays_just_inside_the_edge_teleport_and_rays_just_outside_do_not() {
    let dir = tempfile::tempdir().unwrap();
    for (name, shape, outline) in shapes() {
        let text = two_rooms(dir.path(), &shape, &shape, LAMP, "");
        let path = dir.path().join(format!("{name}.toml"));
        std::fs::write(&path, &text).unwrap();
        let shot = Shot::load(&path).unwrap();
        let scene = Scene::load(&shot, 1).unwrap();
        let time = 1.0 / 24.0;
        let (here, there) = (scene.portals.here(0, time), scene.portals.there(0, time));
        // From three points in the dark room, one near the window and at grazing angles.
        for from in [
            DVec3::new(1.0, 1.3, 0.4),
            DVec3::new(-1.7, 1.5, 0.1),
            DVec3::new(-1.9, 0.4, 1.8),
        ] {
            let ray_to = |local: DVec2| {
                let target = here.transform_point(local.extend(0.0));
                let d = (target - from).normalize();
                Ray::new(from.as_vec3(), d.as_vec3(), f32::INFINITY, time)
            };
            for (inside, outside) in edge_pairs(&outline) {
                let ray = ray_to(inside);
                let hit = scene.portals.intersect(&ray);
                let hit = hit.unwrap_or_else(|| panic!("{name}: {inside} from {from} missed"));
                let next = scene.portals.teleport(&hit, ray.dir, time).unwrap();
                assert!(next.origin.is_finite() && next.direction.is_finite());
                // It leaves the paired window from the same local point (its origin is lifted
                // off the plane along its own line: follow that back to the plane).
                let to_local = there.inverse();
                let origin = to_local.transform_point(next.origin.as_dvec3());
                let d = to_local.transform_vector(next.direction.as_dvec3());
                assert!(d.z < 0.0 && origin.z <= 0.0, "{name}: leaves backwards");
                let left = (origin - d * (origin.z / d.z)).truncate();
                assert!(
                    (left - inside).length() < 5e-5,
                    "{name}: entered at {inside}, left at {left}"
                );
                let ray = ray_to(outside);
                assert!(
                    scene.portals.intersect(&ray).is_none(),
                    "{name}: {outside} from {from} teleported"
                );
            }
        }
    }
}

#[test]
fn ordinary_light_sampling_is_known_to_be_blocked_in_the_dark_room_only() {
    let dir = tempfile::tempdir().unwrap();
    let text = two_rooms(dir.path(), RECTANGLE, RECTANGLE, LAMP, "");
    let path = dir.path().join("rooms.toml");
    std::fs::write(&path, &text).unwrap();
    let prepared = prepare(&path);
    let share = |p: [f32; 3]| survey(&prepared).visibility.at(Vec3::from(p));
    // The lamp is behind the dark room's walls (the window teleports: it passes nothing
    // straight), and in plain view across its own room, where only its far faces (it is a box
    // that glows on both sides of its faces) are hidden: about half of it.
    for p in [[0.0, 1.5, 0.0], [-1.5, 0.5, 1.5], [1.5, 2.5, -1.5]] {
        assert!(share(p) <= 0.02, "dark room at {p:?}: {}", share(p));
    }
    for p in [[31.0, 1.5, 1.0], [28.5, 0.5, -1.5]] {
        assert!(share(p) >= 0.35, "lamp room at {p:?}: {}", share(p));
    }
    // With light sampling through openings off nothing weighs against it: no grid is built.
    let off = text.replace("[render]", "[render]\nlight_through_openings = false");
    std::fs::write(&path, &off).unwrap();
    assert!(prepare(&path).survey.is_none());
}

/// Irradiance at `p` (facing `n`) from the lamp of [`LAMP`], by quadrature over its faces:
/// an axis-aligned box of half side 0.3 at `centre` glowing with luminance `radiance`.
fn lamp_irradiance(p: DVec3, n: DVec3, centre: DVec3, radiance: f64) -> f64 {
    const STEPS: usize = 24;
    let half = 0.3;
    let mut sum = 0.0;
    for axis in 0..3 {
        for sign in [-1.0, 1.0] {
            let mut normal = DVec3::ZERO;
            normal[axis] = sign;
            let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
            let cell = 2.0 * half / STEPS as f64;
            for i in 0..STEPS {
                for j in 0..STEPS {
                    let mut q = centre + normal * half;
                    q[a] += -half + (i as f64 + 0.5) * cell;
                    q[b] += -half + (j as f64 + 0.5) * cell;
                    let to = q - p;
                    let d2 = to.length_squared();
                    let w = to / d2.sqrt();
                    let (cos_p, cos_q) = (w.dot(n), -w.dot(normal));
                    if cos_p > 0.0 && cos_q > 0.0 {
                        sum += radiance * cos_p * cos_q / d2 * cell * cell;
                    }
                }
            }
        }
    }
    sum
}

#[test]
fn each_exit_is_measured_as_what_it_passes_on() {
    let dir = tempfile::tempdir().unwrap();
    // A sky outside both closed rooms: the light tree counts it, though no exit sees it.
    let sky = "[environment]\nradiance = [0.2, 0.2, 0.2]";
    let text = two_rooms(dir.path(), RECTANGLE, RECTANGLE, LAMP, sky);
    let path = dir.path().join("rooms.toml");
    std::fs::write(&path, &text).unwrap();
    let prepared = prepare(&path);
    let exits = survey(&prepared).apertures.exits();
    // The window's exit is in the lamp's room, at x = 31.98, facing −X: π times the mean
    // irradiance over it, by quadrature, within the probes' noise.
    let luminance = 0.2126 * 10.0 + 0.7152 * 8.0 + 0.0722 * 6.0;
    let lamp = DVec3::new(29.6, 1.5, 0.2);
    let [w, h] = RECTANGLE_HALF;
    let mut expected = 0.0;
    for i in 0..16 {
        for j in 0..16 {
            let z = -w + (i as f64 + 0.5) * w / 8.0;
            let y = 1.4 - h + (j as f64 + 0.5) * h / 8.0;
            let p = DVec3::new(31.98, y, z);
            expected += lamp_irradiance(p, -DVec3::X, lamp, luminance) / 256.0;
        }
    }
    let expected = std::f64::consts::PI * expected;
    let window = exits[0];
    assert!(
        (window.light as f64 / expected - 1.0).abs() < 0.1,
        "window exit: measured {}, quadrature {expected}",
        window.light
    );
    assert_eq!(window.sky_share, 0.0, "the sky is walled off");
    // The other exit opens into the dark room: next to nothing, so light sampling does not
    // look through it.
    assert!(exits[1].light < 1e-3 * window.light, "{:?}", exits[1]);
}

/// `extra` sections for [`two_rooms`]: a grid of `rows` × `columns` windows in the dark
/// room's +Z wall, each leading into the far room through its +Z wall.
fn wall_of_windows(rows: usize, columns: usize) -> String {
    let mut text = String::new();
    for k in 0..rows * columns {
        let x = -1.6 + 3.2 * ((k % columns) as f64 + 0.5) / columns as f64;
        let y = 0.3 + 2.4 * ((k / columns) as f64 + 0.5) / rows as f64;
        let (w, h) = (2.0 / columns as f64, 1.6 / rows as f64);
        for (name, pair, centre) in [("w", "t", x), ("t", "w", 30.0 + x)] {
            text += &format!(
                "[[portal]]\nname = \"{name}{k}\"\n\
                 here = {{ position = [{centre}, {y}, 1.98], rotation_degrees = [0.0, 180.0, 0.0] }}\n\
                 pair = \"{pair}{k}\"\n[portal.surface]\nrectangle = [{w}, {h}]\n"
            );
        }
    }
    text
}

#[test]
fn the_tree_over_openings_keeps_the_strategies_that_searching_every_opening_keeps() {
    let dir = tempfile::tempdir().unwrap();
    // A wall of 30 windows into the far room, the window of [`two_rooms`], the door on to the
    // third room, and an opening that moves; lit from the far room, or only from the third
    // room (two openings away).
    let moving = r#"
[[portal]]
name = "moving"
here = { keys = [
  { frame = 0, position = [1.98, 1.0, 0.0], rotation_degrees = [0.0, -90.0, 0.0] },
  { frame = 2, position = [1.98, 1.6, 0.5], rotation_degrees = [0.0, -90.0, 0.0] },
] }
pair = "moving_there"
[portal.surface]
radius = 0.4
[[portal]]
name = "moving_there"
here = { position = [28.02, 1.4, 0.5], rotation_degrees = [0.0, 90.0, 0.0] }
pair = "moving"
[portal.surface]
radius = 0.4
"#;
    let extra = wall_of_windows(5, 6) + &third_room_lamp() + moving;
    let far_lamp = LAMP.replace("\"lamp\"\nmesh", "\"far_lamp\"\nmesh");
    for light in [far_lamp.as_str(), ""] {
        let text = two_rooms(dir.path(), RECTANGLE, RECTANGLE, light, &extra);
        let path = dir.path().join("windows.toml");
        std::fs::write(&path, &text).unwrap();
        // The tree alone, without each cell's candidates (compared below).
        let mut tree = prepare(&path);
        survey_mut(&mut tree).candidates = None;
        let mut every = prepare(&path);
        survey_mut(&mut every).candidates = None;
        survey_mut(&mut every).apertures.search_every_opening();
        let [start, end] = tree.scene.portals.times();
        let (mut searched, mut chains_of_two) = (0, 0);
        for k in 0..3000u32 {
            let h = |i: u32| rift_render::sampling::hash32(k * 8 + i) as f32 / u32::MAX as f32;
            // Points through the dark room and the far room, on surfaces facing any way or
            // in the air (no normal).
            let room = if h(0) < 0.7 { 0.0 } else { 30.0 };
            let p = Vec3::new(
                room - 1.95 + 3.9 * h(1),
                0.05 + 2.9 * h(2),
                -1.95 + 3.9 * h(3),
            );
            let n = Vec3::new(h(4) - 0.5, h(5) - 0.5, h(6) - 0.5).normalize();
            let at = Receiver {
                p,
                n: (k % 5 != 0).then_some(n),
                time: start + (end - start) * h(7) as f64,
            };
            let strategies = |prepared: &Prepared| {
                let mut slot = None;
                Strategies::update(&mut slot, &view(prepared), &at);
                slot.map(|s| (s.direct(), s.chains().collect::<Vec<_>>()))
            };
            let (with_tree, with_every) = (strategies(&tree), strategies(&every));
            assert_eq!(with_tree, with_every, "at {at:?}");
            if let Some((_, chains)) = with_tree {
                searched += 1;
                chains_of_two += chains.iter().filter(|(c, _)| c.teleports() == 2).count();
            }
        }
        // The comparison saw both levels of the search.
        assert!(
            searched > 500 && chains_of_two > 50,
            "{searched} points searched, {chains_of_two} chains of two"
        );
    }
}

#[test]
fn each_cells_candidates_keep_what_searching_every_opening_keeps_nearly_everywhere() {
    let dir = tempfile::tempdir().unwrap();
    // The wall of 30 windows (60 openings: the candidates are listed) into the lit far room.
    let text = two_rooms(
        dir.path(),
        RECTANGLE,
        RECTANGLE,
        LAMP,
        &wall_of_windows(5, 6),
    );
    let path = dir.path().join("windows.toml");
    std::fs::write(&path, &text).unwrap();
    let listed = prepare(&path);
    assert!(survey(&listed).candidates.is_some(), "60 openings compete");
    let mut every = prepare(&path);
    survey_mut(&mut every).candidates = None;
    survey_mut(&mut every).apertures.search_every_opening();
    let (mut searched, mut same, mut shares) = (0, 0, [0.0f64; 2]);
    for k in 0..3000u32 {
        let h = |i: u32| rift_render::sampling::hash32(k * 8 + i) as f32 / u32::MAX as f32;
        let at = Receiver {
            p: Vec3::new(-1.95 + 3.9 * h(1), 0.05 + 2.9 * h(2), -1.95 + 3.9 * h(3)),
            n: (k % 5 != 0).then(|| Vec3::new(h(4) - 0.5, h(5) - 0.5, h(6) - 0.5).normalize()),
            time: 0.0,
        };
        let strategies = |prepared: &Prepared| {
            let mut slot = None;
            Strategies::update(&mut slot, &view(prepared), &at);
            slot.map(|s| (s.direct(), s.chains().collect::<Vec<_>>()))
        };
        let (with_list, with_every) = (strategies(&listed), strategies(&every));
        if with_every.is_some() {
            searched += 1;
        }
        same += usize::from(with_list == with_every);
        // What the chains are given where ordinary sampling would be blocked: their share.
        for (total, found) in shares.iter_mut().zip([&with_list, &with_every]) {
            *total += found
                .as_ref()
                .map_or(0.0, |(direct, _)| 1.0 - *direct as f64);
        }
    }
    eprintln!("{searched} points searched, {same} of 3000 alike, chains' shares {shares:?}");
    assert!(searched > 1000, "{searched} points searched");
    // Points whose normal leans between those a cell's list was searched with may keep other
    // chains (about 6% of them), and the chains then get nearly the same share of samples.
    assert!(
        same >= 2700,
        "the candidates changed the strategies at {} points",
        3000 - same
    );
    assert!(shares[0] >= 0.99 * shares[1], "chains' shares {shares:?}");
    // And light through the wall of windows, sampled through each cell's candidates, is the
    // light that BSDF sampling alone finds (which, with windows over much of the view, is
    // less noisy at four times the samples).
    same_estimate(dir.path(), "wall of windows", &text, 256, false, beauty);
}

#[test]
fn rays_find_the_walls_between_an_exit_and_the_openings_it_faces() {
    let dir = tempfile::tempdir().unwrap();
    // Six windows from the dark room into the far room, the window of [`two_rooms`], and the
    // door from the dark room on to the third room.
    let extra = wall_of_windows(2, 3) + &third_room_lamp();
    let text = two_rooms(dir.path(), RECTANGLE, RECTANGLE, "", &extra);
    let path = dir.path().join("rooms.toml");
    std::fs::write(&path, &text).unwrap();
    let scene = Scene::load(&Shot::load(&path).unwrap(), 1).unwrap();
    let pairs = rift_render::through::facing_pairs(&scene.portals);
    let walled = rift_render::prepare::exits::walled_off(&scene, &pairs);
    let [start, end] = scene.portals.times();
    let room = |i: u32, exit: bool| {
        let frame = if exit {
            scene.portals.there(i as usize, start)
        } else {
            scene.portals.here(i as usize, end)
        };
        (frame.translation.x / 10.0).round() as i32
    };
    let (mut across, mut within) = (0, 0);
    for &(from, to) in &pairs {
        let (exit_room, opening_room) = (room(from, true), room(to, false));
        if exit_room != opening_room {
            // An exit in one room facing an opening in another: walls stand between.
            across += 1;
            assert!(
                walled.contains(&(from, to)),
                "{from} -> {to} is not walled off"
            );
        } else {
            // In one room: rays pass.
            within += 1;
            assert!(
                !walled.contains(&(from, to)),
                "{from} -> {to} is walled off"
            );
        }
    }
    assert!(
        across > 10 && within > 3,
        "{across} pairs across walls, {within} within rooms"
    );
}

/// The shot at `path`, loaded and prepared.
fn prepare(path: &Path) -> Prepared {
    Prepared::new(Scene::load(&Shot::load(path).unwrap(), 1).unwrap())
}

/// What preparing measured of the openings (the shot's must be able to bring light).
fn survey(prepared: &Prepared) -> &Survey {
    prepared.survey.as_ref().expect("openings that bring light")
}

fn survey_mut(prepared: &mut Prepared) -> &mut Survey {
    prepared.survey.as_mut().expect("openings that bring light")
}

/// The strategy search's view of the prepared scene.
fn view(prepared: &Prepared) -> View<'_> {
    prepared
        .context()
        .through
        .expect("openings that bring light")
}
