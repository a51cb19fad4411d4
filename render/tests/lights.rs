//! The lights a lighter places (`[[light]]`) against closed forms: a white diffuse wall lit by
//! one light, seen head-on through a narrow lens, has radiance ρ/π times the irradiance each
//! light's form gives there. Then light sampling against rays that scatter (MIS), light groups,
//! and the refusals of bad input.

use crate::common;

use common::render_at;
use glam::Vec3;
use rift_render::Scene;
use rift_render::frame::film::Image;
use rift_render::rift_fx::Shot;
use std::f64::consts::PI;
use std::path::Path;

/// The wall's albedo.
const ALBEDO: f64 = 0.5;

/// A camera at the origin looking down −Z at a white diffuse wall at z = −8 through a lens of
/// `fov` degrees; `lights` adds the lights and anything else.
fn wall_shot(dir: &Path, fov: f32, material: &str, lights: &str) -> String {
    std::fs::write(dir.join("wall.obj"), common::square(-8.0, 30.0)).unwrap();
    format!(
        r#"
[shot]
name = "lights"
fps = 24.0
frames = [1, 1]
[camera]
resolution = [16, 16]
fov_degrees = {fov}
[camera.transform]
position = [0.0, 0.0, 0.0]
[render]
seed = 1
[[material]]
name = "wall"
{material}
[[object]]
name = "wall"
mesh = "wall.obj"
material = "wall"
{lights}
"#
    )
}

const DIFFUSE: &str = "type = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]";

/// Mean radiance of `image` (one channel; the lights are white).
fn mean(image: &Image) -> f64 {
    image.rgb.iter().map(|c| c.y as f64).sum::<f64>() / image.rgb.len() as f64
}

/// Renders `lights` on the wall with two seeds and checks the mean against ρ/π · `irradiance`
/// within 0.5% plus three standard errors.
fn assert_lit(dir: &Path, name: &str, lights: &str, irradiance: f64) {
    let shot = wall_shot(dir, 0.5, DIFFUSE, lights);
    let images = [1, 2].map(|seed| render_at(dir, name, &shot, 64, seed));
    for image in &images {
        assert_eq!(image.discarded, 0, "{name}");
    }
    let [a, b] = images.each_ref().map(mean);
    let got = 0.5 * (a + b);
    let want = ALBEDO / PI * irradiance;
    let error = 0.5 * (a - b).abs();
    let allowed = 0.005 * want + 3.0 * error;
    eprintln!("{name}: {got:.6} against {want:.6} (±{allowed:.6})");
    assert!(
        (got - want).abs() <= allowed,
        "{name}: mean radiance {got} where the closed form gives {want} (±{allowed})"
    );
}

/// A light section: `type` and further keys, 2 m in front of the wall, facing it.
fn light(kind: &str, keys: &str) -> String {
    format!(
        "[[light]]\nname = \"{kind}\"\ntype = \"{kind}\"\n{keys}\ntransform = {{ position = [0.0, 0.0, -6.0] }}\n"
    )
}

#[test]
fn each_kind_of_light_gives_the_irradiance_of_its_closed_form() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let h = 2.0f64;
    // A point of base 4 is a normalised sphere: intensity base/4 = 1 each way, E = I/h².
    assert_lit(
        d,
        "point",
        &light("point", "intensity = 4.0"),
        1.0 / (h * h),
    );
    // A sphere of radiance L and radius r, wholly above the wall: E = πL (r/h)².
    let r = 0.5f64;
    let sphere = light("point", "intensity = 3.0\nradius = 0.5");
    assert_lit(d, "sphere", &sphere, PI * 3.0 * (r / h).powi(2));
    // A disk of radius r on the axis: E = πL r²/(r² + h²); exposure 1 doubles 1.5.
    let disk = light("disk", "intensity = 1.5\nexposure = 1.0\nradius = 0.5");
    assert_lit(d, "disk", &disk, PI * 3.0 * r * r / (r * r + h * h));
    // A square of side 1 below its centre: four corners' form factors.
    let (a, b) = (0.5f64, 0.5f64);
    let corner = |a: f64, b: f64| {
        let (sa, sb) = ((a * a + h * h).sqrt(), (b * b + h * h).sqrt());
        (a / sa) * (b / sa).atan() + (b / sb) * (a / sb).atan()
    };
    let square = 2.0 * corner(a, b);
    assert_lit(d, "rect", &light("rect", "intensity = 2.0"), 2.0 * square);
    // Normalised, the same power from a rectangle twice as large: L = 2 / area.
    let wide = light("rect", "intensity = 2.0\nwidth = 2.0\nnormalize = true");
    let wide_square = 2.0 * corner(1.0, 0.5);
    assert_lit(d, "rect_normalised", &wide, 2.0 / 2.0 * wide_square);
    // A spot on the axis is the point it is made of.
    let spot = light(
        "spot",
        "intensity = 4.0\ncone_angle = 20.0\ncone_softness = 0.5",
    );
    assert_lit(d, "spot", &spot, 1.0 / (h * h));
    // A distant light facing the wall: normalised, its value is the illuminance; otherwise
    // its radiance over a disk of directions of half-angle α gives πL sin²α.
    let sun = light("distant", "intensity = 2.0\nangle = 10.0\nnormalize = true");
    assert_lit(d, "sun_normalised", &sun, 2.0);
    let alpha = 5f64.to_radians();
    let sun = light("distant", "intensity = 0.5\nangle = 10.0");
    assert_lit(d, "sun", &sun, 0.5 * PI * alpha.sin().powi(2));
    let beam = light("distant", "intensity = 0.75\nangle = 0.0");
    assert_lit(d, "sun_beam", &beam, 0.75);
}

#[test]
fn a_spot_lights_nothing_outside_its_cone_and_fades_across_its_softness() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // The camera looks at the wall 45° off the spot's axis (2 m aside, 2 m away).
    let aside = |cone: &str| {
        let spot = format!(
            "[[light]]\nname = \"spot\"\ntype = \"spot\"\nintensity = 4.0\n{cone}\ntransform = {{ position = [-2.0, 0.0, -6.0] }}\n"
        );
        let shot = wall_shot(d, 0.5, DIFFUSE, &spot);
        mean(&render_at(d, "aside", &shot, 16, 1))
    };
    assert_eq!(aside("cone_angle = 40.0"), 0.0, "beyond the cone");
    // Within a 60° cone, 45° off the axis is halfway through the fade that starts at
    // 60° · (1 − 0.5) = 30°: t = 0.5, and the smoothstep leaves 1 − 0.5 of the light.
    let lit = aside("cone_angle = 60.0");
    let faded = aside("cone_angle = 60.0\ncone_softness = 0.5");
    let t: f64 = (45.0 - 30.0) / 30.0;
    let factor = 1.0 - t * t * (3.0 - 2.0 * t);
    assert!(lit > 0.0);
    assert!(
        (faded / lit - factor).abs() < 0.01,
        "faded {faded} against {lit}: {}",
        faded / lit
    );
}

#[test]
fn rays_that_scatter_find_shape_lights_as_light_sampling_does() {
    // A glossy wall reflects a large light back at the camera: BSDF sampling finds it often.
    // Its MIS with light sampling must give what light sampling alone gives (the light hidden
    // from rays that scatter), within the two estimates' noise from two seeds each.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let glossy = "type = \"conductor\"\nreflectance = [0.9, 0.9, 0.9]\nroughness = 0.4";
    let lights = [
        ("rect", "intensity = 3.0\nwidth = 4.0\nheight = 3.0"),
        ("disk", "intensity = 3.0\nradius = 1.5"),
        ("point", "intensity = 5.0\nradius = 0.4"),
    ];
    for (kind, keys) in lights {
        let both = wall_shot(d, 30.0, glossy, &light(kind, keys));
        let hidden = format!("{keys}\nvisibility = {{ indirect = false }}");
        let hidden = wall_shot(d, 30.0, glossy, &light(kind, &hidden));
        let a = [1, 2].map(|seed| mean(&render_at(d, "mis", &both, 64, seed)));
        let b = [3, 4].map(|seed| mean(&render_at(d, "nee", &hidden, 64, seed)));
        let (ma, mb) = (0.5 * (a[0] + a[1]), 0.5 * (b[0] + b[1]));
        let error = 0.5 * ((a[0] - a[1]).powi(2) + (b[0] - b[1]).powi(2)).sqrt();
        let allowed = 0.005 * mb + 4.0 * error;
        eprintln!("{kind}: MIS {ma:.5}, light sampling alone {mb:.5} (±{allowed:.5})");
        assert!(
            (ma - mb).abs() <= allowed,
            "{kind}: MIS gives {ma}, light sampling alone {mb} (±{allowed})"
        );
    }
}

#[test]
fn the_camera_sees_a_light_only_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A large rectangle filling the view, in front of a black wall.
    let black = "type = \"diffuse\"\nreflectance = [0.0, 0.0, 0.0]";
    let rect = "intensity = 2.0\nwidth = 10.0\nheight = 10.0";
    let hidden = wall_shot(d, 10.0, black, &light("rect", rect));
    assert_eq!(mean(&render_at(d, "hidden", &hidden, 4, 1)), 0.0);
    // It emits towards −Z: the camera at +Z sees its back unless it is turned round.
    let turned = format!(
        "[[light]]\nname = \"r\"\ntype = \"rect\"\n{rect}\nvisibility = {{ camera = true }}\ntransform = {{ position = [0.0, 0.0, -6.0], rotation_degrees = [0.0, 180.0, 0.0] }}\n"
    );
    let seen = wall_shot(d, 10.0, black, &turned);
    let m = mean(&render_at(d, "seen", &seen, 4, 1));
    assert!(
        (m - 2.0).abs() < 1e-5,
        "the camera sees radiance {m}, not 2"
    );
}

#[test]
fn each_light_has_its_light_group_and_the_groups_sum_to_the_beauty() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let lights = format!(
        "{}light_group = \"key\"\n{}light_group = \"fill\"\n{}",
        light("rect", "intensity = 2.0"),
        light("point", "intensity = 3.0").replace("name = \"point\"", "name = \"p\""),
        light("distant", "intensity = 1.0\nangle = 5.0\nnormalize = true")
    );
    let shot = wall_shot(d, 20.0, DIFFUSE, &lights);
    let image = render_at(d, "groups", &shot, 16, 1);
    let names: Vec<&str> = image.light_groups.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["default", "key", "fill"]);
    for (i, c) in image.rgb.iter().enumerate() {
        let sum: Vec3 = image.light_groups.iter().map(|(_, g)| g[i]).sum();
        assert!((sum - *c).abs().max_element() <= 1e-4 * c.max_element().max(1e-3));
    }
    // Each group holds its own light: the sun (default) gives E = 1 alone.
    let group_mean = |k: usize| {
        image.light_groups[k]
            .1
            .iter()
            .map(|c| c.y as f64)
            .sum::<f64>()
            / image.rgb.len() as f64
    };
    let sun = group_mean(0) / (ALBEDO / PI);
    assert!((sun - 1.0).abs() < 0.02, "the sun's layer gives E = {sun}");
    assert!(group_mean(1) > 0.0 && group_mean(2) > 0.0);
}

/// The error loading `lights` beside the wall gives.
fn refusal(dir: &Path, lights: &str) -> String {
    let path = dir.join("bad.toml");
    std::fs::write(&path, wall_shot(dir, 1.0, DIFFUSE, lights)).unwrap();
    match Shot::load(&path) {
        Err(e) => e.to_string(),
        Ok(shot) => Scene::load(&shot, 1)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default(),
    }
}

#[test]
fn bad_lights_are_refused_by_file_and_key() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases = [
        (light("rect", "intensity = -1.0"), "light[0].intensity"),
        (light("rect", "width = 0.0"), "light[0].width"),
        (light("disk", "radius = 0.0"), "light[0].radius"),
        (light("point", "width = 1.0"), "light[0].width"),
        (light("spot", "intensity = 1.0"), "light[0].cone_angle"),
        (light("point", "normalize = false"), "light[0].normalize"),
        (light("distant", "radius = 1.0"), "light[0].radius"),
        (light("distant", "angle = 200.0"), "light[0].angle"),
        (light("rect", "colour = [1.0, 1.0, 1.0]"), "light[0].colour"),
        (
            light("rect", "visibility = { shadow = false }"),
            "light[0].visibility.shadow",
        ),
        (
            "[[light]]\nname = \"x\"\ntype = \"cylinder\"\n".into(),
            "light[0].type",
        ),
        (
            format!("{}{}", light("rect", ""), light("rect", "")),
            "light[1].name",
        ),
        (
            light("rect", "light_group = \"bad name\""),
            "light[0].light_group",
        ),
    ];
    for (lights, key) in cases {
        let e = refusal(d, &lights);
        assert!(
            e.contains(key) && e.contains("bad.toml"),
            "{key}: expected an error naming it and the file, got {e:?}"
        );
    }
    // A light that is fine loads.
    assert_eq!(refusal(d, &light("rect", "intensity = 2.0")), "");
}
