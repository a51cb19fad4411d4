//! The textured set's assets (examples/assets/set/) are what tools/make_set_assets.py makes:
//! the script run again into a temporary folder gives the same meshes, byte for byte, and the
//! same texels in every texture (compared decoded, so another zlib's compression cannot fail
//! it). And the example shot that dresses them renders: through the opening the lit study
//! shows its textured wall and floor.

use crate::common;

use common::{python_command, root};
use rift_fx::Shot;
use rift_render::Scene;
use rift_render::frame::passes::{RenderOptions, render};
use rift_render::prepare::Prepared;
use rift_render::texture::image::{Texels, decode};
use std::path::Path;

/// The decoded 8-bit texels of a PNG, with its size and channels.
fn texels(path: &Path) -> (usize, usize, usize, Vec<u8>) {
    let bytes = std::fs::read(path).unwrap();
    let picture = decode(&bytes, 1 << 30).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let Texels::Bytes(texels) = picture.texels else {
        panic!("{}: 8-bit texels expected", path.display());
    };
    (picture.width, picture.height, picture.channels, texels)
}

#[test]
fn the_committed_set_is_what_the_script_makes() {
    let fresh = tempfile::tempdir().unwrap();
    let status = python_command("python3")
        .arg(root().join("tools/make_set_assets.py"))
        .arg("--out")
        .arg(fresh.path())
        .status()
        .unwrap();
    assert!(status.success(), "tools/make_set_assets.py failed");
    let committed = root().join("examples/assets/set");
    let mut names: Vec<String> = std::fs::read_dir(fresh.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let mut listed: Vec<String> = std::fs::read_dir(&committed)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    listed.sort();
    assert_eq!(
        names, listed,
        "the files the script makes and the committed ones"
    );
    for name in names {
        let (a, b) = (fresh.path().join(&name), committed.join(&name));
        if name.ends_with(".png") {
            assert!(
                texels(&a) == texels(&b),
                "{name}: other texels than the script's"
            );
        } else {
            assert!(
                std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap(),
                "{name}: not what the script writes"
            );
        }
    }
}

#[test]
fn the_textured_set_renders_through_its_opening() {
    let mut shot = Shot::load(&root().join("examples/shots/textured_set.toml")).unwrap();
    shot.camera.projection.resolution = [64, 36];
    let scene = Scene::load(&shot, 1).unwrap();
    assert!(
        scene.textures.list().len() >= 5,
        "the set's textures are read"
    );
    assert!(
        scene.contacts.pairs() > 0,
        "the glass block touches the table"
    );
    let image = render(&Prepared::new(scene), &RenderOptions::new(8));
    assert_eq!(image.discarded, 0);
    // The middle of the frame sees through the opening into the lit study; it is neither
    // black nor blown out.
    let (w, h) = (64usize, 36usize);
    let mut sum = glam::Vec3::ZERO;
    for y in h / 3..2 * h / 3 {
        for x in w / 3..2 * w / 3 {
            sum += image.rgb[y * w + x];
        }
    }
    let mean = sum / ((h / 3) * (w / 3)) as f32;
    assert!(
        mean.min_element() > 0.02 && mean.max_element() < 5.0,
        "the study through the opening: mean {mean}"
    );
    // The bricks are red: the wall's colour comes through the texture.
    assert!(mean.x > mean.z, "mean {mean}");
}
