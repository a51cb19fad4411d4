//! Rings inside recursive portals: a ringed opening seen in its pair, level after level, must
//! show its whole ring at every level (the strands, the mask and the time of each ray agreeing
//! through every teleport), and nothing may turn into NaN on the way.

use crate::common;

use common::{box_obj, render_shot_with};
use glam::Vec3;
use rift_render::frame::film::Image;

/// Levels the test follows (rings seen through 1, 2, 3 and 4 teleports).
const LEVELS: usize = 4;
/// Image size (square) and vertical field of view.
const SIZE: usize = 320;
const FOV_DEGREES: f64 = 20.0;
/// The camera, on the axis of both openings, looking at the back one.
const CAMERA_Z: f64 = 2.0;
const BACK_Z: f64 = -2.97;
const FRONT_Z: f64 = 2.97;
const RING_RADIUS: f64 = 1.05;

/// A room with a ringed opening on its back wall paired with a plain one on its front wall,
/// so the camera sees the back ring again through each teleport, smaller each time. The
/// strands spin while the shutter is open; `strands` sets their `[portal.surface.strands]`.
fn corridor(dir: &std::path::Path, strands: &str) -> String {
    std::fs::write(
        dir.join("room.obj"),
        box_obj([-3.0, 0.0, -3.0], [3.0, 3.0, 3.0], &[]),
    )
    .unwrap();
    format!(
        r#"
[shot]
name = "corridor"
fps = 24.0
frames = [1, 1]
shutter = [-0.25, 0.25]
[camera]
resolution = [{SIZE}, {SIZE}]
fov_degrees = {FOV_DEGREES}
[camera.transform]
position = [0.0, 1.5, {CAMERA_Z}]
look_at = [0.0, 1.5, -3.0]
[render]
max_portal_depth = 8
[[material]]
name = "plaster"
type = "diffuse"
reflectance = [0.6, 0.6, 0.6]
emission = [0.2, 0.2, 0.2]
[[object]]
name = "room"
mesh = "room.obj"
material = "plaster"
[[portal]]
name = "back"
here = {{ position = [0.0, 1.5, {BACK_Z}] }}
pair = "front"
[portal.surface.strands]
{strands}
[portal.ring]
radius = {RING_RADIUS}
band = 0.08
strands = 24
counter_rotating = 0.5
width = 0.012
seed = 7
noise = {{ amplitude = 0.035, depth = 0.6, frequency = 7.0, octaves = 3, roughness = 0.5, evolution = 0.45 }}
speed = {{ turns_per_second = 0.35, reference_size = 0.25, size_compensation = 1.0, min_visible_turn = 0.1 }}
color = {{ intensity = 12.0, ramp = [{{ at = 0.0, color = [1.0, 0.3, 0.05] }}, {{ at = 1.0, color = [1.0, 0.9, 0.7] }}] }}
[[portal]]
name = "front"
here = {{ position = [0.0, 1.5, {FRONT_Z}], rotation_degrees = [0.0, 180.0, 0.0] }}
pair = "back"
[portal.surface]
radius = 1.5
"#
    )
}

/// Where the ring of level `k` (seen through k teleports) appears: its radius in pixels from
/// the image centre. Unfolded, each teleport adds the room's length to the distance.
fn ring_radius_px(k: usize) -> f64 {
    let focal = 0.5 * SIZE as f64 / (0.5 * FOV_DEGREES).to_radians().tan();
    let distance = (CAMERA_Z - BACK_Z) + k as f64 * (FRONT_Z - BACK_Z);
    focal * RING_RADIUS / distance
}

#[test]
fn rings_stay_whole_through_four_levels_of_recursion_and_nothing_is_nan() {
    let dir = tempfile::tempdir().unwrap();
    let spp = 8;
    // The same samples with the strands shown and hidden to camera rays (teleported or not):
    // everything else (their light on the room, the paths that miss them) is identical, so the
    // difference is exactly the strands the camera sees.
    let shown: Image = render_shot_with(dir.path(), "shown", &corridor(dir.path(), ""), spp, None);
    let hidden: Image = render_shot_with(
        dir.path(),
        "hidden",
        &corridor(
            dir.path(),
            "visibility = { camera = false, through_portal = false }",
        ),
        spp,
        None,
    );
    for image in [&shown, &hidden] {
        assert_eq!(image.discarded, 0, "samples were NaN or infinite");
        assert!(image.rgb.iter().all(|c| c.is_finite()));
    }
    let centre = 0.5 * SIZE as f64;
    const BINS: usize = 32;
    for k in 1..=LEVELS {
        // The annulus halfway to the neighbouring levels holds level k's ring whatever its
        // noise does to the radius (a few per cent).
        let inner = 0.5 * (ring_radius_px(k) + ring_radius_px(k + 1));
        let outer = (0.5 * (ring_radius_px(k) + ring_radius_px(k - 1))).min(centre);
        let mut signal = [0.0f64; BINS];
        let mut depth_sum = 0.0f64;
        let mut depth_weight = 0.0f64;
        for y in 0..SIZE {
            for x in 0..SIZE {
                let (dx, dy) = (x as f64 + 0.5 - centre, y as f64 + 0.5 - centre);
                let r = dx.hypot(dy);
                if r < inner || r > outer {
                    continue;
                }
                let i = y * SIZE + x;
                let strand = (shown.rgb[i] - hidden.rgb[i]).max(Vec3::ZERO).element_sum() as f64;
                let angle = dy.atan2(dx) + std::f64::consts::PI;
                let bin = ((angle / std::f64::consts::TAU * BINS as f64) as usize).min(BINS - 1);
                signal[bin] += strand;
                // Teleports made by the paths of pixels the strands dominate.
                if strand > 1.0 {
                    depth_sum += strand * shown.portal_depth[i] as f64;
                    depth_weight += strand;
                }
            }
        }
        let mut sorted = signal;
        sorted.sort_by(f64::total_cmp);
        let median = sorted[BINS / 2];
        assert!(median > 0.0, "level {k}: no strands seen");
        for (bin, &s) in signal.iter().enumerate() {
            assert!(
                s > 0.3 * median,
                "level {k}: the ring is broken in sector {bin} of {BINS} ({s:.2} against a median {median:.2})"
            );
        }
        let depth = depth_sum / depth_weight;
        assert!(
            (depth - k as f64).abs() < 0.25,
            "level {k}: the strands there were seen after {depth:.2} teleports"
        );
    }
}
