//! Analytic radiometry tests (in the spirit of pbrt's integrator tests): results known exactly.

use crate::common;

use glam::Vec3;
use std::fmt::Write as _;
use std::path::Path;

/// An icosphere of radius 1 as OBJ text (convex: no point sees another).
fn icosphere_obj(subdivisions: u32) -> String {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut f: Vec<[usize; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut next = Vec::new();
        let mut mid = std::collections::HashMap::new();
        let mut midpoint = |a: usize, b: usize, v: &mut Vec<Vec3>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push(((v[a] + v[b]) * 0.5).normalize());
                v.len() - 1
            })
        };
        for [a, b, c] in f {
            let (ab, bc, ca) = (
                midpoint(a, b, &mut v),
                midpoint(b, c, &mut v),
                midpoint(c, a, &mut v),
            );
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = next;
    }
    let mut obj = String::new();
    for p in &v {
        writeln!(obj, "v {} {} {}", p.x, p.y, p.z).unwrap();
    }
    for [a, b, c] in f {
        writeln!(obj, "f {} {} {}", a + 1, b + 1, c + 1).unwrap();
    }
    obj
}

/// Renders `extra` TOML (materials, objects, environment) at 48×48 and `spp`.
fn render(dir: &Path, extra: &str, spp: u32) -> rift_render::frame::film::Image {
    common::render_shot(dir, "shot", &shot(extra), spp)
}

/// The shot [`render`] renders: a 48×48 camera at z = 4 looking down −Z, and `extra`.
fn shot(extra: &str) -> String {
    format!(
        r#"
[shot]
name = "analytic"
fps = 24.0
frames = [1, 1]
[camera]
resolution = [48, 48]
fov_degrees = 40.0
[camera.transform]
position = [0.0, 0.0, 4.0]
{extra}
"#
    )
}

fn sphere_scene(reflectance: f32) -> String {
    sphere_with(&format!(
        "type = \"diffuse\"\nreflectance = [{reflectance}, {reflectance}, {reflectance}]"
    ))
}

/// A unit sphere of material `body` (the `[[material]]` keys after its name) in a uniform
/// environment of radiance 1.
fn sphere_with(body: &str) -> String {
    format!(
        r#"
[environment]
radiance = [1.0, 1.0, 1.0]
[[material]]
name = "m"
{body}
[[object]]
name = "ball"
mesh = "ball.obj"
material = "m"
"#
    )
}

/// Mean over pixels where every camera ray hit (alpha 1) and over those where none did.
fn means(img: &rift_render::frame::film::Image) -> (Vec3, Vec3, usize) {
    let (mut hit, mut miss, mut n_hit, mut n_miss) = (Vec3::ZERO, Vec3::ZERO, 0, 0);
    for (c, a) in img.rgb.iter().zip(&img.alpha) {
        if *a == 1.0 {
            hit += *c;
            n_hit += 1;
        } else if *a == 0.0 {
            miss += *c;
            n_miss += 1;
        }
    }
    (hit / n_hit as f32, miss / n_miss.max(1) as f32, n_hit)
}

#[test]
fn white_furnace_and_half_albedo_sphere() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("ball.obj"), icosphere_obj(3)).unwrap();
    for albedo in [1.0f32, 0.5] {
        let img = render(dir.path(), &sphere_scene(albedo), 32);
        let (on, off, n) = means(&img);
        assert!(n > 300, "the sphere covers pixels");
        assert!(
            (on - Vec3::splat(albedo)).abs().max_element() < 0.005 * albedo,
            "albedo {albedo}: sphere mean {on}"
        );
        assert_eq!(off, Vec3::ONE, "the environment seen directly is exact");
        // Every pixel of the convex sphere converges to the albedo: none is far off.
        for (c, a) in img.rgb.iter().zip(&img.alpha) {
            if *a == 1.0 {
                assert!(
                    (c.x - albedo).abs() < 0.15 * albedo,
                    "pixel {c} for albedo {albedo}"
                );
            }
        }
    }
}

/// White furnace for every lossless BSDF: inside a uniform environment of radiance 1 a sphere
/// that neither absorbs nor emits is invisible. Smooth lobes are exact; rough GGX lobes lose
/// the energy that single-scattering microfacet models drop (light that would scatter more than
/// once between facets), about 2% over a sphere at roughness 0.3 (most at grazing angles) and more
/// when rougher, unless `multiscatter` adds it back. A white standard material loses nothing.
#[test]
fn white_furnace_for_every_bsdf() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("ball.obj"), icosphere_obj(3)).unwrap();
    for (body, lowest) in [
        (
            "type = \"conductor\"\nreflectance = [1.0, 1.0, 1.0]",
            0.9999,
        ),
        ("type = \"conductor\"\nroughness = 0.3", 0.97),
        ("type = \"dielectric\"\nior = 1.5", 0.995),
        ("type = \"dielectric\"\nior = 1.5\nroughness = 0.3", 0.94),
        // Energy compensation gives back the light lost between facets (59% at roughness 1).
        (
            "type = \"conductor\"\nroughness = 1.0\nmultiscatter = true",
            0.985,
        ),
        // The standard layered material keeps its energy by tables of its layers' albedo.
        (
            "type = \"standard\"\nbase_color = [1.0, 1.0, 1.0]\nroughness = 0.0",
            0.99,
        ),
        (
            "type = \"standard\"\nbase_color = [1.0, 1.0, 1.0]\nroughness = 0.6",
            0.99,
        ),
        (
            "type = \"standard\"\nbase_color = [1.0, 1.0, 1.0]\nmetallic = 0.4\nroughness = 0.3\n\
             coat = 1.0\ncoat_roughness = 0.1",
            0.99,
        ),
    ] {
        let img = render(dir.path(), &sphere_with(body), 128);
        let (on, _, n) = means(&img);
        assert!(n > 300, "the sphere covers pixels");
        assert!(
            on.min_element() >= lowest && on.max_element() <= 1.0 + 5e-3,
            "{body}: sphere mean {on}"
        );
        eprintln!("furnace {body:?}: {on}");
    }
}

/// `one_sided` blackens the back side only: a convex sphere seen from outside keeps its
/// furnace value, the same sphere wound inside out shows its black back (and a black albedo
/// AOV), and without the key both sides reflect.
#[test]
fn a_one_sided_material_is_black_from_behind_only() {
    let dir = tempfile::tempdir().unwrap();
    let outward = icosphere_obj(3);
    let inward: String = outward
        .lines()
        .map(|line| match line.strip_prefix("f ") {
            Some(face) => {
                let v: Vec<&str> = face.split_whitespace().collect();
                format!("f {} {} {}\n", v[0], v[2], v[1])
            }
            None => format!("{line}\n"),
        })
        .collect();
    let diffuse = "type = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]";
    for (mesh, one_sided, black) in [
        (&outward, true, false),
        (&inward, true, true),
        (&inward, false, false),
    ] {
        std::fs::write(dir.path().join("ball.obj"), mesh).unwrap();
        let body = format!("{diffuse}\none_sided = {one_sided}");
        let img = render(dir.path(), &sphere_with(&body), 32);
        let (on, _, n) = means(&img);
        assert!(n > 300, "the sphere covers pixels");
        let what = format!("one_sided = {one_sided}, black side seen: {black}");
        if black {
            let covered = || img.alpha.iter().map(|&a| a == 1.0);
            for (c, covered) in img.rgb.iter().zip(covered()) {
                assert!(!covered || *c == Vec3::ZERO, "{what}: pixel {c}");
            }
            for (albedo, covered) in img.albedo.iter().zip(covered()) {
                assert!(!covered || *albedo == Vec3::ZERO, "{what}: albedo {albedo}");
            }
        } else {
            assert!(
                (on - Vec3::splat(0.5)).abs().max_element() < 0.0025,
                "{what}: sphere mean {on}"
            );
        }
    }
}

/// A dielectric lets light through both sides: `one_sided` on one is refused, naming the key.
#[test]
fn a_one_sided_dielectric_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("ball.obj"), icosphere_obj(1)).unwrap();
    let path = dir.path().join("shot.toml");
    let glass = sphere_with("type = \"dielectric\"\none_sided = true");
    std::fs::write(&path, shot(&glass)).unwrap();
    let shot = rift_render::rift_fx::Shot::load(&path).unwrap();
    let error = rift_render::Scene::load(&shot, 1).err().expect("refused");
    let message = format!("{error:#}");
    assert!(
        message.contains("material[0].one_sided") && message.contains("shot.toml"),
        "{message}"
    );
}

#[test]
fn emitter_seen_head_on_shows_its_radiance() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("quad.obj"),
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3\nf 1 3 4\n",
    )
    .unwrap();
    let extra = r#"
[[material]]
name = "lamp"
type = "diffuse"
reflectance = [0.0, 0.0, 0.0]
emission = [2.0, 3.0, 4.0]
[[object]]
name = "panel"
mesh = "quad.obj"
material = "lamp"
"#;
    let img = render(dir.path(), extra, 4);
    let radiance = Vec3::new(2.0, 3.0, 4.0);
    let mut full = 0;
    for (c, a) in img.rgb.iter().zip(&img.alpha) {
        if *a == 1.0 {
            assert!((*c - radiance).abs().max_element() < 1e-5, "{c}");
            full += 1;
        }
    }
    assert!(full > 100);
    // Seen from behind, a one-sided emitter is black.
    let behind = extra.replace(
        "mesh = \"quad.obj\"",
        "mesh = \"quad.obj\"\ntransform = { rotation_degrees = [0.0, 180.0, 0.0] }",
    );
    let img = render(dir.path(), &behind, 4);
    assert!(img.rgb.iter().all(|c| *c == Vec3::ZERO));
}

/// Writes a lat-long EXR whose upper half (the sky) has radiance `sky` and lower half `ground`.
fn write_sky_map(path: &Path, sky: f32, ground: f32) {
    let (w, h) = (64usize, 32usize);
    exr::prelude::write_rgb_file(path, w, h, |_, y| {
        let v = if y < h / 2 { sky } else { ground };
        (v, v, v)
    })
    .unwrap();
}

#[test]
fn lat_long_environment_lights_like_its_radiance() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("ball.obj"), icosphere_obj(3)).unwrap();
    // A map of radiance 1 everywhere is the white furnace again.
    write_sky_map(&dir.path().join("white.exr"), 1.0, 1.0);
    let furnace = sphere_scene(1.0).replace(
        "radiance = [1.0, 1.0, 1.0]",
        "map = \"white.exr\"\nrotation_degrees = 40.0",
    );
    let (on, off, _) = means(&render(dir.path(), &furnace, 32));
    assert!((on - Vec3::ONE).abs().max_element() < 0.005, "{on}");
    assert!((off - Vec3::ONE).abs().max_element() < 1e-6, "{off}");
    // Sky of radiance 2 over a black ground: a floor of albedo 0.5 facing up receives
    // irradiance 2π and reflects radiance 0.5 · 2 = 1.
    write_sky_map(&dir.path().join("sky.exr"), 2.0, 0.0);
    std::fs::write(
        dir.path().join("floor.obj"),
        "v -50 0 -50\nv 50 0 -50\nv 50 0 50\nv -50 0 50\nf 1 3 2\nf 1 4 3\n",
    )
    .unwrap();
    let text = r#"
[shot]
name = "sky"
fps = 24.0
frames = [1, 1]
[camera]
resolution = [32, 32]
fov_degrees = 30.0
[camera.transform]
position = [0.0, 3.0, 0.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 0.0, -1.0]
[environment]
map = "sky.exr"
[[material]]
name = "m"
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]
[[object]]
name = "floor"
mesh = "floor.obj"
material = "m"
"#;
    let img = common::render_shot(dir.path(), "sky", text, 64);
    let mean = img.rgb.iter().sum::<Vec3>() / img.rgb.len() as f32;
    assert!(
        (mean - Vec3::ONE).abs().max_element() < 0.01,
        "floor {mean}"
    );
}
