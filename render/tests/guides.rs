//! The albedo and normal a denoiser is guided by see through mirror-like surfaces: behind a
//! pane of smooth glass, or in a mirror, they are those of the surface seen there (the albedo
//! times the pane's tint), as Cycles gives its denoiser, so what is seen there denoises
//! sharply; behind rough glass they stay the glass's own. Alpha, depth and object IDs stay
//! the first surface's.

use crate::common;

use common::{render_shot, square};
use glam::Vec3;

/// A camera at the origin looking down -Z through a pane (`pane`: its material's keys) at
/// z = -4 at a red wall at z = -8, under a uniform sky.
fn shot(dir: &std::path::Path, pane: &str) -> String {
    std::fs::write(dir.join("pane.obj"), square(-4.0, 10.0)).unwrap();
    std::fs::write(dir.join("wall.obj"), square(-8.0, 30.0)).unwrap();
    format!(
        r#"
[shot]
name = "guides"
fps = 24.0
frames = [1, 1]
[camera]
resolution = [8, 8]
fov_degrees = 10.0
[camera.transform]
position = [0.0, 0.0, 0.0]
[render]
seed = 1
[environment]
radiance = [1.0, 1.0, 1.0]
[[material]]
name = "pane"
{pane}
[[material]]
name = "red"
type = "diffuse"
reflectance = [0.8, 0.1, 0.1]
[[object]]
name = "pane"
mesh = "pane.obj"
material = "pane"
[[object]]
name = "wall"
mesh = "wall.obj"
material = "red"
"#
    )
}

/// The mean albedo guide and depth over the image.
fn guides(pane: &str) -> (Vec3, f32) {
    let dir = tempfile::tempdir().unwrap();
    let image = render_shot(dir.path(), "guides", &shot(dir.path(), pane), 8);
    let n = image.albedo.len() as f32;
    let albedo = image.albedo.iter().sum::<Vec3>() / n;
    let depth = image.depth.iter().sum::<f32>() / n;
    (albedo, depth)
}

#[test]
fn guides_see_through_smooth_glass_but_not_rough_glass() {
    let (smooth, depth) = guides("type = \"dielectric\"\nior = 1.5");
    // The wall's red, times the share the pane passes (about 0.92 at normal incidence).
    assert!(
        smooth.x > 0.6 && smooth.y < 0.15 && smooth.z < 0.15,
        "{smooth}"
    );
    assert!((depth - 4.0).abs() < 1e-3, "depth {depth} is the pane's");
    let (rough, _) = guides("type = \"dielectric\"\nior = 1.5\nroughness = 0.4");
    assert!(rough.y > 0.5, "rough glass keeps its own albedo: {rough}");
}
