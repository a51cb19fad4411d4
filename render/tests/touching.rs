//! Surfaces that touch: a smooth glass block resting on a diffuse floor under a uniform sky,
//! seen from above. Light refracted down through the block leaves its bottom face exactly in
//! the floor's plane; a ray that starts there must meet the floor, not slip past it to the sky
//! below. So the block touching the floor must look as it does lifted by a hair (1 mm on a
//! 1 m block), near the origin and 10 km from it, where the offset that keeps a ray off its
//! own surface is a thousand times wider than the gap.
//!
//! With `contact = "optical"` the block instead touches with no air between, and must look as
//! it does sunk into the floor by a hair, at the origin and 10 km out, and unlike it lifted.

use crate::common;

use common::{box_obj, render_at};
use std::path::Path;

/// Side of the image in pixels; the block fills its middle third and more.
const SIZE: u32 = 24;

/// How the block touches: its material's `contact` and how far it is lifted (metres; below 0
/// sunk into the floor).
#[derive(Clone, Copy)]
struct Placing {
    contact: &'static str,
    lift: f64,
}

const TOUCHING: Placing = Placing {
    contact: "gap",
    lift: 0.0,
};
const LIFTED: Placing = Placing {
    contact: "gap",
    lift: 1e-3,
};
const SUNK: Placing = Placing {
    contact: "gap",
    lift: -1e-3,
};
const OPTICAL: Placing = Placing {
    contact: "optical",
    lift: 0.0,
};

/// The shot: the floor and the block (placed as `placing` says) at `origin`, the camera 3 m
/// above the block's centre looking down.
fn shot(dir: &Path, origin: [f64; 3], placing: Placing) -> String {
    let [x, y, z] = origin;
    let floor = box_obj([-10.0, -1.0, -10.0], [10.0, 0.0, 10.0], &[]);
    let block = box_obj([-0.5, 0.0, -0.5], [0.5, 0.25, 0.5], &[]);
    std::fs::write(dir.join("floor.obj"), floor).unwrap();
    std::fs::write(dir.join("block.obj"), block).unwrap();
    format!(
        r#"
[shot]
name = "touching"
fps = 24.0
frames = [1, 1]
[camera]
resolution = [{SIZE}, {SIZE}]
fov_degrees = 30.0
[camera.transform]
position = [{x}, {cy}, {z}]
look_at = [{x}, {y}, {z}]
up = [0.0, 0.0, -1.0]
[render]
max_bounces = 6
[environment]
radiance = [1.0, 1.0, 1.0]
[[material]]
name = "floor"
type = "diffuse"
reflectance = [0.6, 0.6, 0.6]
[[material]]
name = "glass"
type = "dielectric"
ior = 1.5
contact = "{contact}"
[[object]]
name = "floor"
mesh = "floor.obj"
material = "floor"
transform = {{ position = [{x}, {y}, {z}] }}
[[object]]
name = "block"
mesh = "block.obj"
material = "glass"
transform = {{ position = [{x}, {by}, {z}] }}
"#,
        cy = y + 3.0,
        by = y + placing.lift,
        contact = placing.contact,
    )
}

/// The mean green radiance over the middle 12 × 12 pixels (all within the block's top face)
/// for seeds 1 and 2.
fn block_means(origin: [f64; 3], placing: Placing) -> [f64; 2] {
    let dir = tempfile::tempdir().unwrap();
    let text = shot(dir.path(), origin, placing);
    [1, 2].map(|seed| {
        let image = render_at(dir.path(), "touching", &text, 256, seed);
        assert_eq!(image.discarded, 0);
        let (lo, hi) = (SIZE / 4, 3 * SIZE / 4);
        let mut sum = 0.0;
        for y in lo..hi {
            for x in lo..hi {
                sum += image.rgb[(y * SIZE + x) as usize].y as f64;
            }
        }
        sum / ((hi - lo) * (hi - lo)) as f64
    })
}

/// The mean of the two seeds' means, and their spread (which bounds its noise).
fn mean_and_spread(m: [f64; 2]) -> (f64, f64) {
    (0.5 * (m[0] + m[1]), (m[0] - m[1]).abs())
}

/// Fails unless `a` and `b` (labelled) agree within 1% and the seeds' spread.
fn assert_alike(what: &str, a: [f64; 2], b: [f64; 2]) {
    let ((a, sa), (b, sb)) = (mean_and_spread(a), mean_and_spread(b));
    eprintln!("{what}: {a:.4} against {b:.4}, seed spread {:.4}", sa + sb);
    assert!(
        (a - b).abs() < 0.01 * b + 2.0 * (sa + sb),
        "{what}: {a:.4} against {b:.4}"
    );
}

fn assert_touching_looks_lifted(origin: [f64; 3]) {
    let what = format!("at {origin:?}: touching, against lifted 1 mm");
    assert_alike(
        &what,
        block_means(origin, TOUCHING),
        block_means(origin, LIFTED),
    );
}

#[test]
fn a_glass_block_touching_the_floor_looks_as_it_does_lifted_by_a_hair() {
    assert_touching_looks_lifted([0.0; 3]);
}

#[test]
fn ten_kilometres_out_touching_still_looks_lifted() {
    assert_touching_looks_lifted([10_000.0, 0.0, -10_000.0]);
}

/// In optical contact the block looks as it does sunk 1 mm into the floor, at the origin and
/// 10 km out (each against the sunk block at the same place: 10 km out, light that leaves the
/// floor under the glass at grazing angles comes out about 2% brighter whatever the contact),
/// and unlike it lifted: total internal reflection at the bottom is gone.
#[test]
fn in_optical_contact_the_block_looks_sunk_not_lifted() {
    for origin in [[0.0; 3], [10_000.0, 0.0, -10_000.0]] {
        let what = format!("at {origin:?}: optical, against sunk 1 mm");
        assert_alike(
            &what,
            block_means(origin, OPTICAL),
            block_means(origin, SUNK),
        );
    }
    let (sunk, lifted) = (block_means([0.0; 3], SUNK), block_means([0.0; 3], LIFTED));
    let ((s, ss), (l, sl)) = (mean_and_spread(sunk), mean_and_spread(lifted));
    eprintln!("sunk {s:.4} against lifted {l:.4}");
    assert!(
        (s - l).abs() > 0.02 * l + 2.0 * (ss + sl),
        "sunk {s:.4} against lifted {l:.4}: the model makes no difference to tell"
    );
}

/// `contact` is refused, naming the file and key, on a material that lets no light through and
/// with a value it does not know.
#[test]
fn a_contact_that_cannot_be_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let text = shot(dir.path(), [0.0; 3], OPTICAL);
    let opaque = text.replace(
        "reflectance = [0.6, 0.6, 0.6]",
        "reflectance = [0.6, 0.6, 0.6]\ncontact = \"optical\"",
    );
    let unknown = text.replace("contact = \"optical\"", "contact = \"glued\"");
    for (text, expected) in [(opaque, "material[0].contact"), (unknown, "glued")] {
        let path = dir.path().join("shot.toml");
        std::fs::write(&path, text).unwrap();
        let shot = rift_render::rift_fx::Shot::load(&path).unwrap();
        let error = rift_render::Scene::load(&shot, 1).err().expect("refused");
        let message = format!("{error:#}");
        assert!(
            message.contains(expected) && message.contains("shot.toml"),
            "{message}"
        );
    }
}
