//! Helpers shared by the renderer's integration tests (each test binary uses some of them).
#![allow(dead_code)]

use glam::{DVec3, Vec3, Vec4};
use rift_render::Scene;
use rift_render::frame::film::{Image, relative_mse};
use rift_render::frame::{RenderOptions, render};
use rift_render::prepare::Prepared;
use rift_render::rift_fx::Shot;
use std::path::Path;

/// Writes `text` as `dir/<name>.toml`, builds frame 1 and renders it at `spp`.
pub fn render_shot(dir: &Path, name: &str, text: &str, spp: u32) -> Image {
    render_shot_with(dir, name, text, spp, None)
}

/// [`render_shot`], with `seed` (if given) in place of the shot's.
pub fn render_shot_with(dir: &Path, name: &str, text: &str, spp: u32, seed: Option<u32>) -> Image {
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, text).unwrap();
    let shot = Shot::load(&path).unwrap();
    let mut scene = Scene::load(&shot, 1).unwrap();
    if let Some(seed) = seed {
        scene.settings.seed = seed;
    }
    render(&Prepared::new(scene), &RenderOptions::new(spp))
}

/// A square facing +Z at depth `z`, half size `h`, as OBJ text.
pub fn square(z: f32, h: f32) -> String {
    format!(
        "v {h0} {h0} {z}\nv {h} {h0} {z}\nv {h} {h} {z}\nv {h0} {h} {z}\nf 1 2 3 4\n",
        h0 = -h
    )
}

/// A camera at z = 5 looking down −Z at an opening of radius 1 at the origin, in front of a grey
/// wall at z = −3, under a uniform sky; `extra` adds keys and sections.
pub fn tunnel_shot(dir: &Path, extra: &str) -> String {
    tunnel_shot_at(dir, [0.0; 3], extra)
}

/// [`tunnel_shot`] with the camera and wall moved by `offset` (`extra` places its own).
pub fn tunnel_shot_at(dir: &Path, offset: [f64; 3], extra: &str) -> String {
    std::fs::write(dir.join("wall.obj"), square(-3.0, 20.0)).unwrap();
    let at = |p: [f64; 3]| {
        format!(
            "[{}, {}, {}]",
            p[0] + offset[0],
            p[1] + offset[1],
            p[2] + offset[2]
        )
    };
    format!(
        r#"
[shot]
name = "tunnel"
fps = 24.0
frames = [1, 1]
shutter = [0.0, 0.0]
[camera]
resolution = [96, 96]
fov_degrees = 30.0
[camera.transform]
position = {camera}
look_at = {origin}
[environment]
radiance = [1.0, 1.0, 1.0]
[[material]]
name = "grey"
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]
[[object]]
name = "wall"
mesh = "wall.obj"
material = "grey"
transform = {{ position = {origin} }}
{extra}
"#,
        camera = at([0.3, 0.2, 5.0]),
        origin = at([0.0; 3]),
    )
}

/// [`render_shot_with`] at a given seed.
pub fn render_at(dir: &Path, name: &str, text: &str, spp: u32, seed: u32) -> Image {
    render_shot_with(dir, name, text, spp, Some(seed))
}

/// Asserts that two estimates of one image agree: channel means (over both renders of each)
/// within 2%, and a relMSE between them no larger than their own noise explains. `a2` and `b2`
/// are second renders with other seeds; for independent estimates
/// E[relMSE(a, b)] ≈ (relMSE(a, a2) + relMSE(b, b2)) / 2.
pub fn assert_statistically_equal(a: [&[Vec3]; 2], b: [&[Vec3]; 2], what: &str) {
    let mean = |v: &[Vec3]| v.iter().fold(DVec3::ZERO, |s, c| s + c.as_dvec3()) / v.len() as f64;
    let pair_mean = |pair: [&[Vec3]; 2]| 0.5 * (mean(pair[0]) + mean(pair[1]));
    let (ma, mb) = (pair_mean(a), pair_mean(b));
    let rel = (ma - mb).abs() / mb;
    assert!(rel.max_element() < 0.02, "{what}: means {ma} vs {mb}");
    let noise = 0.5 * (relative_mse(a[1], a[0]) + relative_mse(b[1], b[0]));
    let err = relative_mse(a[0], b[0]);
    eprintln!("{what}: means {ma:.4} vs {mb:.4}; relMSE {err:.3e}, noise {noise:.3e}");
    assert!(
        err < 1.25 * noise,
        "{what}: relMSE {err:e} against {noise:e} expected from the renders' own noise"
    );
}

/// An axis-aligned box from `lo` to `hi` as OBJ text, with faces wound outwards; `skip` leaves
/// out faces by name ("-x", "+x", "-y", "+y", "-z", "+z"), for an open box.
pub fn box_obj(lo: [f32; 3], hi: [f32; 3], skip: &[&str]) -> String {
    let corner = |c: usize| {
        Vec3::new(
            if c & 1 == 0 { lo[0] } else { hi[0] },
            if c & 2 == 0 { lo[1] } else { hi[1] },
            if c & 4 == 0 { lo[2] } else { hi[2] },
        )
    };
    let mut text: String = (0..8)
        .map(|c| {
            let p = corner(c);
            format!("v {} {} {}\n", p.x, p.y, p.z)
        })
        .collect();
    for (axis, name) in [(0, "x"), (1, "y"), (2, "z")] {
        for (high, sign) in [(false, "-"), (true, "+")] {
            if skip.contains(&format!("{sign}{name}").as_str()) {
                continue;
            }
            let bit = 1 << axis;
            let (a, b) = (1 << ((axis + 1) % 3), 1 << ((axis + 2) % 3));
            let base = if high { bit } else { 0 };
            let mut quad = [base, base | a, base | a | b, base | b];
            let normal =
                (corner(quad[1]) - corner(quad[0])).cross(corner(quad[2]) - corner(quad[0]));
            if (normal[axis] > 0.0) != high {
                quad.reverse();
            }
            let [q0, q1, q2, q3] = quad.map(|c| c + 1);
            text += &format!("f {q0} {q1} {q2} {q3}\n");
        }
    }
    text
}

/// The through_portal example seen through its room opening, against a direct render from the
/// camera the constraint solver places behind the gallery opening, clipped at that opening,
/// over the pixels that see wholly through the opening (found without the shot's media, which
/// stop some camera paths before they reach it).
pub fn equivalence(variant: &str, adjust: impl Fn(&mut Shot)) {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/shots/through_portal.toml");
    let mut shot = Shot::load(&file).unwrap();
    shot.camera.projection.resolution = [120, 68];
    adjust(&mut shot);
    let frame = 12;
    let time = shot.time_of(frame as f64);
    let (door, gallery_door) = (
        shot.rig.find("room_door").unwrap(),
        shot.rig.find("gallery_door").unwrap(),
    );
    assert!(shot.rig.is_static());
    let teleport = shot.rig.teleport_at(door, time);

    let mut direct_shot = shot.clone();
    direct_shot.camera = shot.camera.through(&teleport);
    let exit = shot.rig.here_at(gallery_door, time);
    let normal = exit.transform_direction(DVec3::Z);
    let keep_front = Vec4::new(
        normal.x as f32,
        normal.y as f32,
        normal.z as f32,
        -normal.dot(exit.translation) as f32,
    );
    let spp = 32;
    let render_with = |shot: &Shot, seed: u32, clip: bool| {
        let mut scene = Scene::load(shot, frame).unwrap();
        scene.settings.seed = seed;
        if clip {
            scene.clip.world_planes.push(keep_front);
        }
        render(&Prepared::new(scene), &RenderOptions::new(spp))
    };
    let through = render_with(&shot, 0, false);
    let through_again = render_with(&shot, 3, false);
    let direct = render_with(&direct_shot, 1, true);
    let direct_again = render_with(&direct_shot, 2, true);

    let mut clear_shot = shot.clone();
    clear_shot.render.media.clear();
    let clear = render_with(&clear_shot, 0, false);
    let region: Vec<usize> = (0..clear.rgb.len())
        .filter(|&i| clear.portal_depth[i] == 1.0)
        .collect();
    assert!(region.len() > 1500, "{variant}: {} pixels", region.len());
    let pick = |image: &Image| region.iter().map(|&i| image.rgb[i]).collect::<Vec<_>>();
    assert_statistically_equal(
        [&pick(&through), &pick(&through_again)],
        [&pick(&direct), &pick(&direct_again)],
        variant,
    );
}

/// An opening at the origin whose there side is its here side.
pub const IDENTITY_OPENING: &str = r#"
[[portal]]
name = "A"
here = { position = [0.0, 0.0, 0.0], rotation_degrees = [0.0, 10.0, 0.0] }
there = { position = [0.0, 0.0, 0.0], rotation_degrees = [0.0, 10.0, 0.0] }
[portal.surface]
radius = 1.0
"#;

/// Renders the tunnel shot with `scene` (extra TOML) without and with [`IDENTITY_OPENING`],
/// two seeds each at `spp`, asserts the two statistically equal, and returns the portal depth
/// of a render with the opening.
pub fn assert_identity_opening_changes_nothing(
    dir: &Path,
    scene: &str,
    spp: u32,
    what: &str,
) -> Vec<f32> {
    let none = tunnel_shot(dir, scene);
    let with = tunnel_shot(dir, &format!("{scene}{IDENTITY_OPENING}"));
    let a = render_at(dir, "none", &none, spp, 1);
    let b = render_at(dir, "none2", &none, spp, 2);
    let c = render_at(dir, "identity", &with, spp, 3);
    let d = render_at(dir, "identity2", &with, spp, 4);
    assert_statistically_equal([&c.rgb, &d.rgb], [&a.rgb, &b.rgb], what);
    c.portal_depth
}

/// A shot with the camera at the origin looking down −Z at a wall 8 m away emitting 1 (and
/// nothing else lit), at `resolution` and `fov` degrees across; `extra` adds objects and media.
/// Frames 1 and 2, so keys can move things during frame 1's shutter.
pub fn lamp_wall(dir: &Path, resolution: [u32; 2], fov: f32, extra: &str) -> String {
    std::fs::write(dir.join("wall.obj"), square(-8.0, 30.0)).unwrap();
    format!(
        r#"
[shot]
name = "lamp_wall"
fps = 24.0
frames = [1, 2]
[camera]
resolution = [{}, {}]
fov_degrees = {fov}
[camera.transform]
position = [0.0, 0.0, 0.0]
[[material]]
name = "lamp"
type = "diffuse"
reflectance = [0.0, 0.0, 0.0]
emission = [1.0, 1.0, 1.0]
[[object]]
name = "wall"
mesh = "wall.obj"
material = "lamp"
{extra}
"#,
        resolution[0], resolution[1]
    )
}

/// `f` run on a pool of `threads` worker threads.
pub fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}
