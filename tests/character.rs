//! The showcase's character: the mannequin's committed frames are what
//! tools/make_mannequin.py makes; the orb its hand reaches for through the hatch, placed by the
//! script's own teleport, is where the solver's copy through the hatch rests on the pillar; and
//! its copy comes out of the front opening as the original goes into the back one (Cryptomatte
//! coverage of the copy, seen through the opening, grows across frames as the original's
//! shrinks).

use crate::common;

use common::{python_command, root};
use rift_fx::Shot;
use rift_render::Scene;
use rift_render::frame::passes::{RenderOptions, render};
use rift_render::prepare::Prepared;
use rift_render::scene::ply;

/// The vertex positions of a mesh file's triangles, flattened.
fn corners(path: &std::path::Path) -> Vec<f32> {
    let parts = ply::load_ply(path).unwrap_or_else(|e| panic!("{e}"));
    parts
        .iter()
        .flat_map(|p| p.triangles.iter().chain(&p.velocities))
        .flat_map(|t| t.iter().flat_map(|v| v.to_array()))
        .collect()
}

#[test]
fn the_committed_mannequin_is_what_the_script_makes() {
    let fresh = tempfile::tempdir().unwrap();
    let status = python_command("python3")
        .arg(root().join("tools/make_mannequin.py"))
        .arg("--out")
        .arg(fresh.path())
        .status()
        .unwrap();
    assert!(status.success(), "tools/make_mannequin.py failed");
    let committed = root().join("examples/assets/mannequin");
    let names = |dir: &std::path::Path| {
        let mut n: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        n.sort();
        n
    };
    assert_eq!(names(fresh.path()), names(&committed));
    for name in names(&committed) {
        // Compared decoded, within float rounding: another platform's sin and cos may differ
        // in the last bit.
        let (a, b) = (
            corners(&fresh.path().join(&name)),
            corners(&committed.join(&name)),
        );
        assert_eq!(a.len(), b.len(), "{name}");
        let worst = a
            .iter()
            .zip(&b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f32::max);
        assert!(worst < 1e-4, "{name}: differs by {worst}");
    }
}

/// A `[[object]]` section of the showcase by name.
fn showcase_object(name: &str) -> toml::Table {
    let text = std::fs::read_to_string(root().join("examples/shots/showcase.toml")).unwrap();
    let shot: toml::Table = text.parse().unwrap();
    shot["object"]
        .as_array()
        .unwrap()
        .iter()
        .map(|o| o.as_table().unwrap())
        .find(|o| o["name"].as_str() == Some(name))
        .unwrap_or_else(|| panic!("no object {name}"))
        .clone()
}

fn vec3(v: &toml::Value) -> glam::DVec3 {
    let a: Vec<f64> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_float().unwrap())
        .collect();
    glam::DVec3::new(a[0], a[1], a[2])
}

#[test]
fn the_orb_the_hand_reaches_for_rests_on_the_pillar_through_the_hatch() {
    let shot = Shot::load(&root().join("examples/shots/showcase.toml")).unwrap();
    let hatch = shot.rig.find("hatch").expect("the showcase has a hatch");
    // The pillar's top (a unit cube scaled about its centre) and the ball's radius (0.35 in
    // its mesh) scaled like the orb.
    let pillar = &showcase_object("pillar")["transform"];
    let top =
        vec3(&pillar["position"]) + glam::DVec3::Y * 0.5 * pillar["scale"].as_float().unwrap();
    let orb = showcase_object("orb");
    let keys = orb["transform"]["keys"].as_array().unwrap();
    let radius = 0.35 * keys[0]["scale"].as_float().unwrap();
    let resting = top + glam::DVec3::Y * radius;
    // Until the hand takes it (frame 12), the orb waits behind the hatch where the script's
    // teleport puts it; the solver's copy through the hatch is then on the pillar.
    for key in keys.iter().take(2) {
        let frame = key["frame"].as_integer().unwrap() as f64;
        let teleport = shot.rig.teleport_at(hatch, frame / shot.fps);
        let on_pillar = teleport.transform_point(vec3(&key["position"]));
        assert!(
            (on_pillar - resting).length() < 2e-3,
            "frame {frame}: the orb's copy through the hatch is at {on_pillar}, not on the pillar at {resting}"
        );
    }
}

/// The share of the image each of `names` covers at `frame` of the showcase (160×90, 4 spp).
fn coverage(names: &[&str], frame: i64) -> Vec<f64> {
    let mut shot = Shot::load(&root().join("examples/shots/showcase.toml")).unwrap();
    shot.camera.projection.resolution = [160, 90];
    let scene = Scene::load(&shot, frame).unwrap();
    let mut options = RenderOptions::new(4);
    options.cryptomatte = true;
    let image = render(&Prepared::new(scene), &options);
    let crypto = image.cryptomatte.expect("cryptomatte");
    let pixels = crypto.pixels.len() as f64;
    names
        .iter()
        .map(|name| {
            let object = crypto.names.iter().position(|n| n == name).unwrap() as u32;
            let covered: f64 = crypto
                .pixels
                .iter()
                .flat_map(|p| p.iter())
                .filter(|(o, _)| *o == object)
                .map(|(_, c)| *c as f64)
                .sum();
            covered / pixels
        })
        .collect()
}

#[test]
fn the_characters_copy_comes_out_as_the_original_goes_in() {
    let frames = [4, 19, 21];
    let shares: Vec<Vec<f64>> = frames
        .iter()
        .map(|&f| coverage(&["walker", "walker_there"], f))
        .collect();
    for (f, s) in frames.iter().zip(&shares) {
        eprintln!("frame {f}: original {:.4}, copy {:.4}", s[0], s[1]);
    }
    // Frame 4: the character is in the room and its copy not yet out of the front opening;
    // frame 21: it has gone through and its copy is out.
    assert!(shares[0][0] > 0.01 && shares[0][1] < 0.1 * shares[0][0]);
    for k in 1..frames.len() {
        assert!(
            shares[k][0] < shares[k - 1][0],
            "the original's coverage does not shrink: {shares:?}"
        );
        assert!(
            shares[k][1] > shares[k - 1][1],
            "the copy's coverage does not grow: {shares:?}"
        );
    }
    assert!(shares[2][1] > 0.01 && shares[2][0] < 0.5 * shares[2][1]);
}
