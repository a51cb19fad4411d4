//! Media from OpenVDB density grids: tracking against closed forms (slab transmittance, a
//! furnace), moving and teleported grids, and bad inputs. The VDB files in tests/data/vdb are
//! written by OpenVDB itself (tools/make_vdb_fixtures.py).

use crate::common;

use common::{
    assert_identity_opening_changes_nothing, box_obj, equivalence, render_shot, render_shot_with,
};
use glam::Vec3;
use rift_render::Scene;
use rift_render::media::grid::Rng;
use rift_render::rift_fx::Shot;
use std::path::{Path, PathBuf};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/vdb")
}

/// The mean of two renders of `text` with different seeds, and its standard error from their
/// pixel-by-pixel difference (each pixel's variance is half its squared difference).
fn mean_of_two_seeds(dir: &Path, text: &str, spp: u32) -> (Vec3, Vec3) {
    let a = render_shot_with(dir, "a", text, spp, Some(1));
    let b = render_shot_with(dir, "b", text, spp, Some(2));
    let n = a.rgb.len() as f32;
    let sum: Vec3 = a.rgb.iter().zip(&b.rgb).map(|(a, b)| 0.5 * (*a + *b)).sum();
    let variance: Vec3 = a
        .rgb
        .iter()
        .zip(&b.rgb)
        .map(|(a, b)| 0.25 * (*a - *b) * (*a - *b))
        .sum();
    (sum / n, variance.sqrt() / n)
}

/// The slab fixture: density 1 over voxels x in [-8, 40), y in [-8, 24), z in [0, 16), voxels
/// 0.25 m; trilinear ramps of one voxel at each face make its optical thickness along z exactly
/// 16 voxels = 4 m per unit density. Placed so its centre is on the −Z axis 4.13 m away and its
/// z extent spans world z from −6.25 to −2.
const SLAB: &str = r#"vdb = "slab.vdb"
transform = { position = [-3.875, -1.875, -6.0] }"#;

/// [`common::lamp_wall`] with the VDB fixtures copied beside it.
fn lamp_wall(dir: &Path, resolution: [u32; 2], fov: f32, extra: &str) -> String {
    for f in ["slab.vdb", "puff.vdb", "puff_half.vdb"] {
        std::fs::copy(fixtures().join(f), dir.join(f)).unwrap();
    }
    common::lamp_wall(dir, resolution, fov, extra)
}

fn scene(dir: &Path, text: &str) -> Scene {
    let path = dir.join("grid.toml");
    std::fs::write(&path, text).unwrap();
    Scene::load(&Shot::load(&path).unwrap(), 1).unwrap()
}

#[test]
fn ratio_tracking_through_a_slab_gives_its_transmittance() {
    // Straight lines through the slab at several angles: the mean of ratio-tracking estimates
    // must equal e^(−σ·4 m / cos θ) per channel within four standard errors.
    let dir = tempfile::tempdir().unwrap();
    let sigma = Vec3::new(0.1, 0.3, 0.6);
    let medium = format!(
        "[[medium]]\nname = \"slab\"\n{SLAB}\nabsorption = [{}, {}, {}]",
        sigma.x, sigma.y, sigma.z
    );
    let s = scene(dir.path(), &lamp_wall(dir.path(), [4, 4], 10.0, &medium));
    for (k, dir_xy) in [(0.0f32, 0.0f32), (0.2, 0.0), (0.1, -0.25)]
        .iter()
        .enumerate()
    {
        let d = Vec3::new(dir_xy.0, dir_xy.1, -1.0).normalize();
        let origin = Vec3::new(0.0, 0.0, -1.0);
        let n = 20_000;
        let (mut sum, mut sum2) = (Vec3::ZERO, Vec3::ZERO);
        for i in 0..n {
            let mut rng = Rng::new(i * 7919 + k as u32);
            let t = s
                .media
                .grids
                .transmittance(origin, d, 0.0, 0.0, 10.0, &mut rng);
            sum += t;
            sum2 += t * t;
        }
        let m = sum / n as f32;
        let error = ((sum2 / n as f32 - m * m) / n as f32)
            .max(Vec3::ZERO)
            .sqrt();
        let expected = (-sigma * 4.0 / -d.z).exp();
        assert!(
            ((m - expected).abs() - 4.0 * error - 1e-4).max_element() <= 0.0,
            "direction {d}: {m} ± {error}, expected {expected}"
        );
        // The same through the scene's media as shadow rays see them (ratio tracking seeded by
        // the ray) and, with no grid, nothing.
        let t = s.media.transmittance(origin, d, 10.0, 0.0);
        assert!(t.cmple(Vec3::splat(1.0 + 1e-6)).all() && t.cmpge(Vec3::ZERO).all());
    }
}

#[test]
fn an_absorbing_grid_dims_the_lamp_by_its_transmittance_standing_still_and_moving() {
    let dir = tempfile::tempdir().unwrap();
    let sigma = [0.1f32, 0.25, 0.5];
    let medium = format!(
        "[[medium]]\nname = \"slab\"\n{SLAB}\nabsorption = [{}, {}, {}]",
        sigma[0], sigma[1], sigma[2]
    );
    let text = lamp_wall(dir.path(), [8, 8], 2.0, &medium);
    let (m, error) = mean_of_two_seeds(dir.path(), &text, 256);
    let expected = Vec3::from_array(sigma.map(|s| (-s * 4.0).exp()));
    assert!(
        ((m - expected).abs() - 4.0 * error - 0.002 * expected).max_element() <= 0.0,
        "mean {m} ± {error}, expected {expected}"
    );
    // Keyed: the slab slides 200 m along +X from frame 1 to 2 (linearly), so over frame 1's
    // shutter (−0.25 to +0.25 frames, the keys clamped before frame 1) it covers the narrow
    // view until its left edge, 6.125 m left of the axis, has passed it: a fraction
    // (0.25 + 6.125/200) / 0.5 of the shutter sees T, the rest sees the lamp unattenuated.
    let moving = format!(
        "[[medium]]\nname = \"slab\"\nvdb = \"slab.vdb\"\nabsorption = [{}, {}, {}]\n\
         transform = {{ interpolation = \"linear\", keys = [{{ frame = 1, position = [-3.875, -1.875, -6.0] }}, \
         {{ frame = 2, position = [196.125, -1.875, -6.0] }}] }}",
        sigma[0], sigma[1], sigma[2]
    );
    let text = lamp_wall(dir.path(), [8, 8], 2.0, &moving);
    let (blurred, error) = mean_of_two_seeds(dir.path(), &text, 256);
    let covered = (0.25 + 6.125 / 200.0) / 0.5;
    let expected = expected * covered + Vec3::splat(1.0 - covered);
    assert!(
        ((blurred - expected).abs() - 4.0 * error - 0.005 * expected).max_element() <= 0.0,
        "moving: mean {blurred} ± {error}, expected {expected}"
    );
}

#[test]
fn a_lossless_scattering_grid_in_a_uniform_enclosure_is_invisible() {
    // The furnace: walls emitting 1 all round, a lossless scattering puff (half precision,
    // under an affine map) in the middle; every pixel's expected value is 1. Exercises delta
    // tracking, light sampling from grid points with ratio-tracked shadows, and MIS.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("room.obj"),
        box_obj([-5.0; 3], [5.0; 3], &[]),
    )
    .unwrap();
    let text = lamp_wall(dir.path(), [24, 24], 60.0, "")
        .replace(
            "reflectance = [0.0, 0.0, 0.0]\nemission",
            "reflectance = [0.0, 0.0, 0.0]\ntwo_sided_emission = true\nemission",
        )
        .replace("mesh = \"wall.obj\"", "mesh = \"room.obj\"")
        + "[[medium]]\nname = \"puff\"\nvdb = \"puff_half.vdb\"\nscattering = [8.0, 8.0, 8.0]\n\
           anisotropy = 0.4\ntransform = { position = [0.0, 0.0, -3.0], scale = 1.5 }\n";
    let img = render_shot(dir.path(), "furnace", &text, 64);
    let m = img.rgb.iter().copied().sum::<Vec3>() / img.rgb.len() as f32;
    assert!((m - Vec3::ONE).abs().max_element() < 0.01, "mean {m}");
    assert!(img.rgb.iter().all(|c| c.is_finite()));
}

#[test]
fn an_emitting_grid_glows_by_its_integrated_density() {
    // A puff that emits and absorbs (per metre at density 1), centred 5 m down the view axis
    // (its file places voxel (3, −2, 5), its centre, at (1.15, 1.9, 3.25)), seen against
    // black: the radiance along a ray is ∫ ε d(s) e^(−σ_a ∫₀ˢ d) ds, by quadrature here.
    let dir = tempfile::tempdir().unwrap();
    let text = lamp_wall(dir.path(), [16, 16], 6.0, "")
        .replace("emission = [1.0, 1.0, 1.0]", "emission = [0.0, 0.0, 0.0]")
        + "[[medium]]\nname = \"glow\"\nvdb = \"puff.vdb\"\nemission = [2.0, 1.0, 0.5]\n\
           absorption = [0.5, 0.5, 0.5]\ntransform = { position = [-1.15, -1.9, -8.25] }\n";
    let s = scene(dir.path(), &text);
    // The image's mean by quadrature over 4 x 4 rays per pixel (the film's box filter).
    let grid = &s.media.grids.grids[0];
    let lens = rift_render::camera::Lens::at(&s.camera, 0.0);
    let glow_along = |dir: Vec3| {
        let (steps, from, to) = (400, 3.0f32, 7.0f32);
        let ds = (to - from) / steps as f32;
        let (mut depth, mut glow) = (0.0f32, 0.0f32);
        for i in 0..steps {
            let d = grid.density_at(dir * (from + (i as f32 + 0.5) * ds), 0.0);
            glow += d * (-0.5 * (depth + 0.5 * d * ds)).exp() * ds;
            depth += d * ds;
        }
        glow
    };
    let mut glow = 0.0f64;
    let n = 16;
    for y in 0..n * 4 {
        for x in 0..n * 4 {
            let ndc = glam::Vec2::new(x as f32 + 0.5, y as f32 + 0.5) / (4 * n) as f32;
            glow += glow_along(lens.ray(ndc, glam::Vec2::ZERO).1) as f64;
        }
    }
    let expected = Vec3::new(2.0, 1.0, 0.5) * (glow / (16 * n * n) as f64) as f32;
    let (m, error) = mean_of_two_seeds(dir.path(), &text, 64);
    assert!(
        expected.x > 0.05,
        "the view must cross the puff ({expected})"
    );
    assert!(
        ((m - expected).abs() - 4.0 * error - 0.005 * expected).max_element() <= 0.0,
        "mean {m} ± {error}, expected {expected}"
    );
}

#[test]
fn bad_grid_media_are_refused_with_their_key() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("broken.vdb"),
        b" BDV\0\0\0\0\xe0\0\0\0garbage",
    )
    .unwrap();
    let text = |medium: &str| {
        lamp_wall(
            dir.path(),
            [4, 4],
            10.0,
            &format!("[[medium]]\nname = \"m\"\n{medium}"),
        )
    };
    for (medium, key, says) in [
        ("vdb = \"missing.vdb\"", "medium[0].vdb", "cannot read"),
        ("vdb = \"broken.vdb\"", "medium[0].vdb", "ends"),
        ("vdb = \"wall.obj\"", "medium[0].vdb", "not an OpenVDB file"),
        (
            "vdb = \"puff.vdb\"\ngrid = \"smoke\"",
            "medium[0].grid",
            "\"density\"",
        ),
        (
            "vdb = \"puff_half.vdb\"\ngrid = \"vel\"",
            "medium[0].vdb",
            "scalar float",
        ),
        (
            "vdb = \"puff.vdb\"\ndensity = -1.0",
            "medium[0].density",
            "factor",
        ),
        (
            "vdb = \"puff.vdb\"\nobject = \"wall\"",
            "medium[0].object",
            "transform",
        ),
        (
            "vdb = \"puff.vdb\"\nthrough = \"nowhere\"",
            "medium[0].through",
            "no portal opening",
        ),
        ("grid = \"density\"", "medium[0].grid", "vdb"),
        (
            "transform = { position = [0, 0, 0] }",
            "medium[0].transform",
            "vdb",
        ),
        (
            "vdb = \"puff.vdb\"\nscattering = [-1, 0, 0]",
            "medium[0].scattering",
            "≥ 0",
        ),
        (
            "vdb = \"puff.vdb\"\nanisotropy = 1.0",
            "medium[0].anisotropy",
            "(-1, 1)",
        ),
    ] {
        let path = dir.path().join("bad.toml");
        std::fs::write(&path, text(medium)).unwrap();
        let e = match Shot::load(&path) {
            Err(e) => e.to_string(),
            Ok(shot) => Scene::load(&shot, 1)
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default(),
        };
        assert!(
            e.contains(key) && e.contains(says) && e.contains("bad.toml"),
            "{medium}: expected {key} / {says}, got {e:?}"
        );
    }
}

#[test]
fn a_grid_straddling_an_identity_opening_renders_like_no_opening() {
    // A scattering, absorbing puff (scaled to 1.2 m across its radius) centred on an opening
    // whose there side is its here side: camera rays, bounces and shadow rays crossing it must
    // see the grid continuously, the tracking split at the opening and resumed after.
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(fixtures().join("puff.vdb"), dir.path().join("puff.vdb")).unwrap();
    let scene = r#"
[[medium]]
name = "puff"
vdb = "puff.vdb"
scattering = [2.0, 2.5, 3.0]
absorption = [0.5, 0.5, 0.5]
anisotropy = 0.5
transform = { position = [-3.45, -5.7, -9.75], scale = 3.0 }
"#;
    let depth = assert_identity_opening_changes_nothing(
        dir.path(),
        scene,
        48,
        "a grid through an identity opening",
    );
    assert!(depth.iter().any(|&d| d > 0.3));
}

#[test]
fn a_grid_beyond_a_translated_opening_equals_the_solved_camera_on_the_other_side() {
    // An emitting, absorbing puff in the gallery of the through_portal example, centred 2.5 m
    // past its opening on the line of sight (it glows orange over a third of the opening), seen
    // through the room's opening and directly from the camera the solver places.
    let puff = fixtures().join("puff.vdb");
    equivalence("a grid in the gallery", |shot| {
        let at = shot.camera.transform.at(shot.time_of(12.0));
        shot.camera.transform = rift_render::rift_fx::rig::AnimatedTransform::constant(at);
        shot.camera.projection.aperture_radius = 0.0;
        let medium: toml::Table = toml::from_str(&format!(
            "name = \"puff\"\nvdb = {:?}\nabsorption = [1.0, 1.5, 2.0]\nemission = [0.6, 0.4, 0.2]\n\
             transform = {{ position = [36.55, -4.2, -12.25], scale = 3.0 }}",
            puff.display().to_string()
        ))
        .unwrap();
        shot.render.media.push(medium);
    });
}

#[test]
fn a_grid_carried_through_an_opening_sits_where_the_solver_puts_it() {
    // The puff given `through = "room_door"` in the through_portal example is its there-side
    // copy: its density at the teleported image of any point equals the original's there.
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/shots/through_portal.toml");
    let puff = fixtures().join("puff.vdb");
    let medium = |through: &str| -> toml::Table {
        toml::from_str(&format!(
            "name = \"puff\"\nvdb = {:?}\nabsorption = [1.0, 1.0, 1.0]\n\
             transform = {{ position = [-1.15, -0.4, -7.5] }}\n{through}",
            puff.display().to_string()
        ))
        .unwrap()
    };
    let scene_with = |through: &str| {
        let mut shot = Shot::load(&file).unwrap();
        shot.render.media.push(medium(through));
        (Scene::load(&shot, 12).unwrap(), shot)
    };
    let (original, shot) = scene_with("");
    let (carried, _) = scene_with("through = \"room_door\"");
    let time = shot.time_of(12.0);
    let teleport = shot
        .rig
        .teleport_at(shot.rig.find("room_door").unwrap(), time);
    let (a, b) = (
        &original.media.grids.grids[0],
        &carried.media.grids.grids[0],
    );
    let mut inside = 0;
    for k in 0..2000u32 {
        let h = |n: u32| rift_render::sampling::hash32(3 * k + n) as f32 / u32::MAX as f32;
        let p = Vec3::new(-0.5 + h(0), 1.0 + h(1), -4.75 + h(2) * 1.0);
        let there = teleport.transform_point(p.as_dvec3()).as_vec3();
        let (da, db) = (a.density_at(p, time), b.density_at(there, time));
        assert!(
            (da - db).abs() < 1e-4,
            "at {p}: {da} against {db} at {there}"
        );
        inside += (da > 0.05) as u32;
    }
    assert!(inside > 100, "the points must sample the puff ({inside})");
}

#[test]
fn a_cache_of_one_file_per_frame_gives_each_frame_its_grid() {
    // vdb = "sim.####.vdb": frame 1 reads the puff, frame 2 the slab; a frame with no file is
    // refused naming that frame's file.
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(fixtures().join("puff.vdb"), dir.path().join("sim.0001.vdb")).unwrap();
    std::fs::copy(fixtures().join("slab.vdb"), dir.path().join("sim.0002.vdb")).unwrap();
    let text = lamp_wall(
        dir.path(),
        [4, 4],
        10.0,
        "[[medium]]\nname = \"sim\"\nvdb = \"sim.####.vdb\"\nabsorption = [1.0, 1.0, 1.0]\n",
    )
    .replace("frames = [1, 2]", "frames = [1, 3]");
    let path = dir.path().join("sim.toml");
    std::fs::write(&path, &text).unwrap();
    let shot = Shot::load(&path).unwrap();
    // The puff's centre voxel (3, −2, 5) lies at (1.15, 1.9, 3.25); the slab's voxel (2, 2, 2)
    // at (0.5, 0.5, 0.5), which the puff does not reach, and it ends at z = 0.
    let at = |frame: i64, p: Vec3| {
        Scene::load(&shot, frame).unwrap().media.grids.grids[0].density_at(p, 0.0)
    };
    let (puff, slab) = (Vec3::new(1.15, 1.9, 3.25), Vec3::new(0.5, 0.5, 0.5));
    assert!(at(1, puff) > 0.5 && at(1, slab) == 0.0);
    assert!(at(2, slab) == 1.0 && at(2, Vec3::new(0.5, 0.5, -1.0)) == 0.0);
    let e = Scene::load(&shot, 3).err().unwrap().to_string();
    assert!(
        e.contains("sim.0003.vdb") && e.contains("medium[0].vdb"),
        "{e}"
    );
}
