//! Motion blur with known answers: an emitter sweeping across the frame leaves the analytic
//! coverage profile, a moving camera gives the same profile, and light sampling of a moving
//! emitter at each ray's time is unbiased.

use crate::common;

use glam::Vec3;
use std::path::Path;

const QUAD: &str = "v -0.5 -0.5 0\nv 0.5 -0.5 0\nv 0.5 0.5 0\nv -0.5 0.5 0\nf 1 2 3\nf 1 3 4\n";
const SIZE: usize = 48;
/// Half the width of the view at z = 0 from the camera at z = 4 with a 40° field of view.
fn half_view() -> f32 {
    4.0 * 20f32.to_radians().tan()
}

/// Renders a shot (header added) at 48×48; the shutter spans the whole frame 1 → 2.
fn render(
    dir: &Path,
    camera_transform: &str,
    body: &str,
    spp: u32,
) -> rift_render::frame::film::Image {
    let text = format!(
        r#"
[shot]
name = "motion"
fps = 24.0
frames = [1, 1]
shutter = [0.0, 1.0]
[camera]
resolution = [{SIZE}, {SIZE}]
fov_degrees = 40.0
[camera.transform]
{camera_transform}
{body}
"#
    );
    std::fs::write(dir.join("quad.obj"), QUAD).unwrap();
    common::render_shot(dir, "shot", &text, spp)
}

const LAMP: &str = r#"
[[material]]
name = "lamp"
type = "diffuse"
reflectance = [0.0, 0.0, 0.0]
emission = [1.0, 1.0, 1.0]
two_sided_emission = true
"#;

/// The unit lamp quad as an object (its transform, if any, follows).
const PANEL: &str = r#"
[[object]]
name = "panel"
mesh = "quad.obj"
material = "lamp"
"#;

/// Mean over the pixel's footprint (at z = 0) of the fraction of the shutter during which a unit
/// quad moving from x = −0.5 to x = 0.5 covers x: the tent 1 − |x|.
fn expected_coverage(column: usize) -> f32 {
    let w = 2.0 * half_view() / SIZE as f32;
    let x0 = -half_view() + column as f32 * w;
    let steps = 64;
    (0..steps)
        .map(|i| {
            let x = x0 + w * (i as f32 + 0.5) / steps as f32;
            (1.0 - x.abs()).max(0.0)
        })
        .sum::<f32>()
        / steps as f32
}

/// Rows whose footprint lies inside the quad's |y| < 0.5 with a margin.
fn inner_rows() -> impl Iterator<Item = usize> {
    let w = 2.0 * half_view() / SIZE as f32;
    (0..SIZE).filter(move |&r| {
        let y = half_view() - r as f32 * w;
        y < 0.45 && y - w > -0.45
    })
}

fn check_profile(img: &rift_render::frame::film::Image, what: &str) {
    let rows: Vec<usize> = inner_rows().collect();
    assert!(rows.len() >= 8, "{what}: rows {rows:?}");
    let mut worst = 0.0f32;
    for column in 0..SIZE {
        let mean = rows
            .iter()
            .map(|&r| img.rgb[r * SIZE + column].x)
            .sum::<f32>()
            / rows.len() as f32;
        worst = worst.max((mean - expected_coverage(column)).abs());
    }
    assert!(worst < 0.02, "{what}: worst column error {worst}");
}

#[test]
fn moving_emitter_covers_the_analytic_tent() {
    let dir = tempfile::tempdir().unwrap();
    let body = format!(
        r#"{LAMP}{PANEL}[object.transform]
interpolation = "linear"
keys = [{{ frame = 1, position = [-0.5, 0.0, 0.0] }}, {{ frame = 2, position = [0.5, 0.0, 0.0] }}]
"#
    );
    let img = render(dir.path(), "position = [0.0, 0.0, 4.0]", &body, 64);
    check_profile(&img, "moving emitter");
}

#[test]
fn moving_camera_blurs_like_a_moving_object() {
    let dir = tempfile::tempdir().unwrap();
    let body = format!("{LAMP}{PANEL}");
    let camera = r#"interpolation = "linear"
keys = [{ frame = 1, position = [0.5, 0.0, 4.0] }, { frame = 2, position = [-0.5, 0.0, 4.0] }]"#;
    let img = render(dir.path(), camera, &body, 64);
    check_profile(&img, "moving camera");
}

#[test]
fn light_sampling_of_a_moving_emitter_is_unbiased() {
    // A lamp sliding above a floor: the light a floor point receives changes with time, so the
    // blurred render must equal the average of still renders over the shutter. Sampling the
    // lamp at any other time than the ray's would break this.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("floor.obj"),
        "v -3 -1 -3\nv 3 -1 -3\nv 3 -1 3\nv -3 -1 3\nf 1 3 2\nf 1 4 3\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("lamp.obj"),
        "v -0.2 0 -0.2\nv 0.2 0 -0.2\nv 0.2 0 0.2\nv -0.2 0 0.2\nf 1 2 3\nf 1 3 4\n",
    )
    .unwrap();
    let body = |transform: &str| {
        format!(
            r#"{LAMP}
[[material]]
name = "floor"
type = "diffuse"
reflectance = [0.8, 0.8, 0.8]
[[object]]
name = "floor"
mesh = "floor.obj"
material = "floor"
[[object]]
name = "lamp"
mesh = "lamp.obj"
material = "lamp"
transform = {transform}
"#
        )
    };
    let camera = "position = [0.0, 3.0, 0.0]\nlook_at = [0.0, -1.0, 0.0]\nup = [0.0, 0.0, -1.0]";
    // The central 8×8 pixels.
    let centre = |img: &rift_render::frame::film::Image| {
        let mut sum = Vec3::ZERO;
        for y in 20..28 {
            for x in 20..28 {
                sum += img.rgb[y * SIZE + x];
            }
        }
        sum / 64.0
    };
    let moving = render(
        dir.path(),
        camera,
        &body(
            r#"{ interpolation = "linear", keys = [{ frame = 1, position = [0.0, 0.5, 0.0] }, { frame = 2, position = [1.5, 0.5, 0.0] }] }"#,
        ),
        512,
    );
    let steps = 8;
    let still: Vec<Vec3> = (0..steps)
        .map(|i| {
            let x = 1.5 * (i as f32 + 0.5) / steps as f32;
            centre(&render(
                dir.path(),
                camera,
                &body(&format!("{{ position = [{x}, 0.5, 0.0] }}")),
                128,
            ))
        })
        .collect();
    let average = still.iter().sum::<Vec3>() / steps as f32;
    let (first, last) = (still[0], still[steps - 1]);
    assert!(
        first.x > 1.5 * last.x,
        "the light changes over the shutter: {first} → {last}"
    );
    let blurred = centre(&moving);
    assert!(
        ((blurred - average) / average).abs().max_element() < 0.015,
        "blurred {blurred} vs average of stills {average}"
    );
}
