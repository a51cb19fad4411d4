//! Light selection learned per region: it must move samples away from lights the tree cannot
//! know are hidden, keep the estimate (the same means, less noise), and learn the same guide
//! whatever the thread count.

use crate::common;

use common::{assert_statistically_equal, box_obj};
use glam::Vec3;
use rift_render::frame::film::relative_mse;
use rift_render::frame::{RenderOptions, render};
use rift_render::lights::{LightSampler, LightSelection, Receiver};
use rift_render::prepare::Prepared;
use rift_render::rift_fx::Shot;
use rift_render::scene::Overrides;
use std::path::Path;

/// Writes into `dir` a closed room (`room.obj`, the box from `room[0]` to `room[1]`), a lamp
/// (`lamp.obj`, a cube of half-size `lamp`) and the shot `shot` as `name`.toml; returns the
/// shot's path.
fn write_room_and_lamp(
    dir: &Path,
    room: [[f32; 3]; 2],
    lamp: f32,
    name: &str,
    shot: &str,
) -> std::path::PathBuf {
    std::fs::write(dir.join("room.obj"), box_obj(room[0], room[1], &[])).unwrap();
    std::fs::write(dir.join("lamp.obj"), box_obj([-lamp; 3], [lamp; 3], &[])).unwrap();
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, shot).unwrap();
    path
}

/// A closed grey room around the camera, lit by a dim lamp inside it, beside a bright lamp
/// outside it that the light tree, which does not know about walls, prefers.
fn room_beside_a_hidden_lamp(dir: &Path) -> std::path::PathBuf {
    let shot = r#"
[shot]
name = "hidden"
fps = 24.0
frames = [1, 1]
shutter = [0.0, 0.0]
[camera]
resolution = [40, 30]
fov_degrees = 70.0
[camera.transform]
position = [1.5, 1.6, 1.5]
look_at = [-1.0, 0.3, -1.0]
[render]
max_bounces = 3
[[material]]
name = "grey"
type = "diffuse"
reflectance = [0.6, 0.6, 0.6]
[[material]]
name = "dim"
type = "diffuse"
reflectance = [0.0, 0.0, 0.0]
emission = [4.0, 4.0, 4.0]
[[material]]
name = "bright"
type = "diffuse"
reflectance = [0.0, 0.0, 0.0]
emission = [400.0, 400.0, 400.0]
[[object]]
name = "room"
mesh = "room.obj"
material = "grey"
[[object]]
name = "inside"
mesh = "lamp.obj"
material = "dim"
transform = { position = [-0.5, 2.5, 0.0] }
[[object]]
name = "outside"
mesh = "lamp.obj"
material = "bright"
transform = { position = [-4.0, 1.5, 0.0] }
"#;
    write_room_and_lamp(
        dir,
        [[-2.0, 0.0, -2.0], [2.0, 3.0, 2.0]],
        0.2,
        "hidden",
        shot,
    )
}

fn build(path: &Path, selection: LightSelection, seed: u32) -> Prepared {
    let shot = Shot::load(path).unwrap();
    let overrides = Overrides {
        light_selection: Some(selection),
        seed: Some(seed),
        ..Default::default()
    };
    Prepared::build(&shot, 1, &overrides).unwrap()
}

/// The probability light selection at `at` picks an emitter on the lamp outside the room (the
/// twelve emitters after the inside lamp's twelve).
fn outside_share(lights: LightSampler, at: &Receiver) -> f32 {
    (12..24).map(|i| lights.pick_pmf(i, at)).sum()
}

#[test]
fn a_lamp_behind_a_wall_gets_few_samples_once_learned() {
    let dir = tempfile::tempdir().unwrap();
    let path = room_beside_a_hidden_lamp(dir.path());
    let (tree, learned) = (
        build(&path, LightSelection::Tree, 1),
        build(&path, LightSelection::Learned, 1),
    );
    assert!(tree.light_guide.is_none());
    let (with_factors, regions) = learned.light_guide.as_ref().expect("a guide").learned();
    assert!(
        with_factors > 0 && with_factors <= regions,
        "{with_factors} of {regions}"
    );
    let floor = [(-1.0, -1.0), (0.0, 0.5), (-1.5, 1.0), (0.8, -0.8)];
    assert_share_falls(
        &tree,
        &learned,
        floor,
        outside_share,
        0.35,
        "the hidden lamp",
    );
}

/// At each floor point (x, z) of `floor`, `share` of light samples is over half under `tree`
/// and below `ratio` times that under `learned`; `what` names what takes the share.
fn assert_share_falls(
    tree: &Prepared,
    learned: &Prepared,
    floor: [(f32, f32); 4],
    share: impl Fn(LightSampler, &Receiver) -> f32,
    ratio: f32,
    what: &str,
) {
    for (x, z) in floor {
        let at = Receiver {
            p: Vec3::new(x, 0.0, z),
            n: Some(Vec3::Y),
            time: 0.0,
        };
        let (plain, guided) = (
            share(tree.context().lights, &at),
            share(learned.context().lights, &at),
        );
        eprintln!("floor at ({x}, {z}): {what}'s share {plain:.3} unlearned, {guided:.3} learned");
        assert!(
            plain > 0.5 && guided < ratio * plain,
            "floor at ({x}, {z}): {what}'s share {plain} unlearned, {guided} learned"
        );
    }
}

#[test]
fn learned_selection_keeps_the_estimate_and_lowers_the_noise() {
    let dir = tempfile::tempdir().unwrap();
    let path = room_beside_a_hidden_lamp(dir.path());
    assert_same_estimate_less_noise(&path, 32, 0.6, "learned against tree");
}

/// Renders the shot at `path` with `spp` samples and seeds 1 and 2, learned and under the
/// tree: the means agree, and the learned pair's noise is below `ratio` times the tree's.
fn assert_same_estimate_less_noise(path: &Path, spp: u32, ratio: f64, what: &str) {
    let images = |selection| {
        [1, 2].map(|seed| render(&build(path, selection, seed), &RenderOptions::new(spp)).rgb)
    };
    let (learned, tree) = (
        images(LightSelection::Learned),
        images(LightSelection::Tree),
    );
    assert_statistically_equal([&learned[0], &learned[1]], [&tree[0], &tree[1]], what);
    let noise = |pair: &[Vec<Vec3>; 2]| relative_mse(&pair[0], &pair[1]);
    eprintln!(
        "{what}: noise {:e} learned against {:e}",
        noise(&learned),
        noise(&tree)
    );
    assert!(
        noise(&learned) < ratio * noise(&tree),
        "{what}: noise {:e} learned against {:e}",
        noise(&learned),
        noise(&tree)
    );
}

#[test]
fn the_guide_and_the_image_are_the_same_for_any_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let path = room_beside_a_hidden_lamp(dir.path());
    let run = |threads| {
        common::on_threads(threads, || {
            let prepared = build(&path, LightSelection::Learned, 3);
            let image = render(&prepared, &RenderOptions::new(4)).rgb;
            (prepared.light_guide, image)
        })
    };
    let (one, three) = (run(1), run(3));
    assert!(one.0.is_some());
    assert!(
        one == three,
        "the guide or the image depends on the thread count"
    );
}

/// A closed grey room around the camera, lit (directly only) by a small lamp in one corner,
/// under a bright sky it cannot see: the sky's estimate, which ignores walls, asks for most of
/// the light samples far from the lamp.
fn closed_room_under_a_sky(dir: &Path) -> std::path::PathBuf {
    let shot = r#"
[shot]
name = "sky"
fps = 24.0
frames = [1, 1]
shutter = [0.0, 0.0]
[camera]
resolution = [40, 30]
fov_degrees = 70.0
[camera.transform]
position = [2.5, 1.6, 2.5]
look_at = [-1.0, 0.3, -1.0]
[render]
max_bounces = 1
[environment]
radiance = [2.0, 2.0, 2.0]
[[material]]
name = "grey"
type = "diffuse"
reflectance = [0.6, 0.6, 0.6]
[[material]]
name = "lamp"
type = "diffuse"
reflectance = [0.0, 0.0, 0.0]
emission = [20.0, 20.0, 20.0]
[[object]]
name = "room"
mesh = "room.obj"
material = "grey"
[[object]]
name = "lamp"
mesh = "lamp.obj"
material = "lamp"
transform = { position = [2.5, 2.7, -2.5] }
"#;
    write_room_and_lamp(dir, [[-3.0, 0.0, -3.0], [3.0, 3.0, 3.0]], 0.1, "sky", shot)
}

#[test]
fn a_sky_behind_walls_gets_few_samples_once_learned() {
    let dir = tempfile::tempdir().unwrap();
    let path = closed_room_under_a_sky(dir.path());
    let (tree, learned) = (
        build(&path, LightSelection::Tree, 1),
        build(&path, LightSelection::Learned, 1),
    );
    // The environment is uniform, so its pdf in any direction is its share of the samples
    // over 4π.
    let sky_share = |lights: LightSampler, at: &Receiver| {
        lights.pdf_environment(Vec3::Y, at) * 4.0 * std::f32::consts::PI
    };
    let floor = [(-1.0, -1.0), (-2.0, -2.0), (0.0, 0.0), (-2.0, 0.5)];
    assert_share_falls(&tree, &learned, floor, sky_share, 0.4, "the sky");
    // The same estimate, with less noise.
    assert_same_estimate_less_noise(&path, 16, 0.5, "learned against tree, under a sky");
}
