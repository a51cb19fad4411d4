//! Stereo: each eye of an off-axis pair puts a point where projective geometry says it must go,
//! so parallax is zero on the convergence plane and grows as interaxial · (1/C − 1/Z); and it
//! does so unchanged through a portal.

use glam::{Mat4, Vec3, Vec4};
use rift_render::Scene;
use rift_render::camera::Eye;
use rift_render::frame::film::Image;
use rift_render::frame::{RenderOptions, render};
use rift_render::prepare::Prepared;
use rift_render::rift_fx::Shot;
use std::path::Path;

const WIDTH: usize = 240;
const HEIGHT: usize = 120;
/// Horizontal field of view.
const FOV_X_DEGREES: f32 = 40.0;
const INTERAXIAL: f32 = 0.3;
const CONVERGENCE: f32 = 4.0;
/// Marker depths: in front of, on and behind the convergence plane.
const DEPTHS: [f32; 3] = [2.0, 4.0, 8.0];

/// A small emissive square facing +Z centred on `(x, 0, z)`, as OBJ text.
fn marker(x: f32, z: f32, half: f32) -> String {
    format!(
        "v {} {} {z}\nv {} {} {z}\nv {} {} {z}\nv {} {} {z}\nf 1 2 3 4\n",
        x - half,
        -half,
        x + half,
        -half,
        x + half,
        half,
        x - half,
        half
    )
}

/// The markers' lateral positions at each depth (left of centre, centre, right).
fn lateral(k: usize) -> f32 {
    (k as f32 - 1.0) * 0.2 * DEPTHS[k]
}

/// A pinhole stereo camera at the origin looking down −Z at three markers; with `through`, the
/// markers stand 100 m along +X and an opening just in front of the camera leads there.
fn stereo_shot(dir: &Path, through: bool) -> Shot {
    let shift = if through { 100.0 } else { 0.0 };
    for (k, &z) in DEPTHS.iter().enumerate() {
        std::fs::write(
            dir.join(format!("marker{k}.obj")),
            marker(lateral(k) + shift, -z, 0.006 * z),
        )
        .unwrap();
    }
    let mut text = format!(
        r#"
[shot]
name = "stereo"
fps = 24.0
frames = [1, 1]
shutter = [0.0, 0.0]
[camera]
resolution = [{WIDTH}, {HEIGHT}]
fov_degrees = {FOV_X_DEGREES}
fov_axis = "horizontal"
transform = {{ position = [0.0, 0.0, 0.0] }}
[camera.stereo]
interaxial = {INTERAXIAL}
convergence = {CONVERGENCE}
[[material]]
name = "glow"
type = "diffuse"
reflectance = [0.0, 0.0, 0.0]
emission = [1.0, 1.0, 1.0]
"#
    );
    for k in 0..DEPTHS.len() {
        text += &format!(
            "[[object]]\nname = \"marker{k}\"\nmesh = \"marker{k}.obj\"\nmaterial = \"glow\"\n"
        );
    }
    if through {
        text += "[[portal]]\nname = \"A\"\nhere = { position = [0.0, 0.0, -0.5] }\nthere = { position = [100.0, 0.0, -0.5] }\n[portal.surface]\nradius = 50.0\n";
    }
    let path = dir.join(format!("stereo{through}.toml"));
    std::fs::write(&path, text).unwrap();
    Shot::load(&path).unwrap()
}

/// Where a point at lateral `x`, depth `z` lands for the eye at `offset` along X: the pixel
/// column of its image, from the off-axis projection.
fn expected_column(x: f32, z: f32, offset: f32) -> f32 {
    let tan_x = (FOV_X_DEGREES.to_radians() * 0.5).tan();
    let film = (x - offset) / z + offset / CONVERGENCE;
    (film / tan_x + 1.0) * 0.5 * WIDTH as f32
}

/// The brightness-weighted column of the image within `radius` pixels of `around`.
fn centroid(image: &Image, around: f32, radius: f32) -> f32 {
    let (mut sum, mut weight) = (0.0f64, 0.0f64);
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let centre = x as f32 + 0.5;
            if (centre - around).abs() > radius {
                continue;
            }
            let v = image.rgb[y * WIDTH + x].dot(Vec3::ONE) as f64;
            sum += v * centre as f64;
            weight += v;
        }
    }
    assert!(weight > 0.0, "nothing bright near column {around}");
    (sum / weight) as f32
}

fn check_parallax(through: bool) {
    let dir = tempfile::tempdir().unwrap();
    let shot = stereo_shot(dir.path(), through);
    let prepared = Prepared::new(Scene::load(&shot, 1).unwrap());
    let eye_image = |eye| {
        let options = RenderOptions {
            eye: Some(eye),
            ..RenderOptions::new(16)
        };
        render(&prepared, &options)
    };
    let (left, right) = (eye_image(Eye::Left), eye_image(Eye::Right));
    assert_eq!(left.metadata.view.as_deref(), Some("left"));
    assert_eq!(right.metadata.view.as_deref(), Some("right"));
    for (k, &z) in DEPTHS.iter().enumerate() {
        let x = lateral(k);
        let want = [
            expected_column(x, z, -0.5 * INTERAXIAL),
            expected_column(x, z, 0.5 * INTERAXIAL),
        ];
        let got = [
            centroid(&left, want[0], 8.0),
            centroid(&right, want[1], 8.0),
        ];
        let parallax = got[1] - got[0];
        let expected = want[1] - want[0];
        eprintln!(
            "through {through}, depth {z}: columns {got:?} (expected {want:?}), parallax {parallax:.3} px (expected {expected:.3})"
        );
        for (e, image) in [&left, &right].iter().enumerate() {
            assert!((got[e] - want[e]).abs() < 0.1, "depth {z}, eye {e}");
            // The EXR's world-to-NDC matrix projects the marker's centre to the same column
            // (without a portal: the matrix knows nothing of teleports).
            if !through {
                let ndc = Mat4::from_cols_array(&image.metadata.world_to_ndc)
                    * Vec4::new(x, 0.0, -z, 1.0);
                let column = (ndc.x / ndc.w + 1.0) * 0.5 * WIDTH as f32;
                assert!(
                    (column - want[e]).abs() < 1e-3,
                    "depth {z}, eye {e}: {column}"
                );
            }
        }
        assert!((parallax - expected).abs() < 0.1, "depth {z}");
        if z == CONVERGENCE {
            assert!(parallax.abs() < 0.05);
        }
    }
}

#[test]
fn each_eye_places_points_with_the_parallax_of_an_off_axis_pair() {
    check_parallax(false);
}

#[test]
fn stereo_parallax_is_unchanged_through_a_portal() {
    check_parallax(true);
}
