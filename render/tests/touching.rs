//! Surfaces that touch: a smooth glass block resting on a diffuse floor under a uniform sky,
//! seen from above. Light refracted down through the block leaves its bottom face exactly in
//! the floor's plane; a ray that starts there must meet the floor, not slip past it to the sky
//! below. So the block touching the floor must look as it does lifted by a hair (1 mm on a
//! 1 m block), near the origin and 10 km from it, where the offset that keeps a ray off its
//! own surface is a thousand times wider than the gap.

use crate::common;

use common::{box_obj, render_at};
use std::path::Path;

/// Side of the image in pixels; the block fills its middle third and more.
const SIZE: u32 = 24;

/// The shot: the floor and the block (lifted by `lift` metres) placed at `origin`, the camera
/// 3 m above the block's centre looking down.
fn shot(dir: &Path, origin: [f64; 3], lift: f64) -> String {
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
        by = y + lift,
    )
}

/// The mean green radiance over the middle 12 × 12 pixels (all within the block's top face)
/// for seeds 1 and 2.
fn block_means(origin: [f64; 3], lift: f64) -> [f64; 2] {
    let dir = tempfile::tempdir().unwrap();
    let text = shot(dir.path(), origin, lift);
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

fn assert_touching_looks_lifted(origin: [f64; 3]) {
    let touching = block_means(origin, 0.0);
    let lifted = block_means(origin, 1e-3);
    let mean = |m: [f64; 2]| 0.5 * (m[0] + m[1]);
    // The two seeds' spread bounds the noise of each mean.
    let noise = (touching[0] - touching[1]).abs() + (lifted[0] - lifted[1]).abs();
    let (t, l) = (mean(touching), mean(lifted));
    eprintln!("at {origin:?}: touching {t:.4}, lifted 1 mm {l:.4}, seed spread {noise:.4}");
    assert!(
        (t - l).abs() < 0.01 * l + 2.0 * noise,
        "at {origin:?}: the block touching the floor {t:.4} against lifted 1 mm {l:.4}"
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
