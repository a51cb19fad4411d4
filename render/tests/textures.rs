//! Textures against closed forms: a textured diffuse floor under a uniform sky has radiance
//! albedo × sky at every point (the floor sees only sky), so what the camera sees is the
//! texture's linear value there; a fine checker seen at grazing angles keeps its mean through
//! the footprint filtering; a roughness map of one value is that roughness; an OBJ's map_Kd is
//! the same texture as a `[[material]]`'s; and bad textures are refused by file and key.

use crate::common;

use common::render_at;
use rift_render::Scene;
use rift_render::rift_fx::Shot;
use rift_render::texture::mipmap::srgb_to_linear;
use std::path::Path;

/// The sky's radiance.
const SKY: f64 = 2.0;

/// Writes an 8-bit RGB PNG of `width` × `height` (rows top first) to `path`.
fn write_png(path: &Path, width: u32, height: u32, rgb: &[[u8; 3]]) {
    let mut bytes = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut bytes, width, height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().unwrap();
        writer.write_image_data(rgb.as_flattened()).unwrap();
    }
    std::fs::write(path, bytes).unwrap();
}

/// A 20 × 20 m floor at y = 0 facing up, its UVs running 0 to `repeat` over it, with a
/// material named "floor" from `usemtl`.
fn floor_obj(dir: &Path, repeat: f32) {
    let r = repeat;
    let obj = format!(
        "v -10 0 10\nv 10 0 10\nv 10 0 -10\nv -10 0 -10\nvt 0 0\nvt {r} 0\nvt {r} {r}\nvt 0 {r}\n\
         usemtl floor\nf 1/1 2/2 3/3 4/4\n"
    );
    std::fs::write(dir.join("floor.obj"), obj).unwrap();
}

/// A camera at `position` looking at `target` through a lens of `fov` degrees, over the floor
/// under the sky; `material` is the floor's section body.
fn floor_shot(position: [f32; 3], target: [f32; 3], fov: f32, material: &str) -> String {
    format!(
        r#"
[shot]
name = "textures"
fps = 24.0
frames = [1, 1]
[camera]
resolution = [24, 24]
fov_degrees = {fov}
[camera.transform]
position = {position:?}
look_at = {target:?}
up = [0.0, 0.0, -1.0]
[render]
max_bounces = 1
[environment]
radiance = [{SKY}, {SKY}, {SKY}]
[[material]]
name = "floor"
{material}
[[object]]
name = "floor"
mesh = "floor.obj"
"#
    )
}

/// The mean radiance of the green channel over the image, two seeds.
fn mean_of(dir: &Path, name: &str, shot: &str, spp: u32) -> [f64; 2] {
    [1, 2].map(|seed| {
        let image = render_at(dir, name, shot, spp, seed);
        assert_eq!(image.discarded, 0);
        image.rgb.iter().map(|c| c.y as f64).sum::<f64>() / image.rgb.len() as f64
    })
}

/// Asserts two seeds' means of `name` within 0.5% plus three standard errors of `want`.
fn assert_mean(name: &str, means: [f64; 2], want: f64) {
    let got = 0.5 * (means[0] + means[1]);
    let allowed = 0.005 * want + 3.0 * 0.5 * (means[0] - means[1]).abs();
    eprintln!("{name}: {got:.5} against {want:.5} (±{allowed:.5})");
    assert!(
        (got - want).abs() <= allowed,
        "{name}: mean {got} where the texture gives {want} (±{allowed})"
    );
}

#[test]
fn a_textured_floor_shows_each_texel_as_its_linear_albedo() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    floor_obj(d, 1.0);
    // The floor's −X half sRGB 60, its +X half sRGB 200 (eight texels each, so that the
    // filter around the middle of either half blends equal texels).
    let halves: Vec<[u8; 3]> = (0..16)
        .map(|i| if i < 8 { [60; 3] } else { [200; 3] })
        .collect();
    write_png(&d.join("halves.png"), 16, 1, &halves);
    let material = "type = \"diffuse\"\nreflectance = { texture = \"halves.png\" }";
    let look_down = |x: f32| floor_shot([x, 3.0, 0.0], [x, 0.0, 0.0], 2.0, material);
    for (x, value) in [(-5.0, 60u8), (5.0, 200)] {
        let means = mean_of(d, "halves", &look_down(x), 16);
        let albedo = srgb_to_linear(value as f32 / 255.0) as f64;
        assert_mean(&format!("texel {value}"), means, albedo * SKY);
    }
    // Read as linear values, with a scale and an offset.
    let linear = "type = \"diffuse\"\nreflectance = { texture = \"halves.png\", colorspace = \"linear\", scale = 0.5, offset = 0.1 }";
    let shot = floor_shot([5.0, 3.0, 0.0], [5.0, 0.0, 0.0], 2.0, linear);
    let means = mean_of(d, "linear", &shot, 16);
    assert_mean("linear", means, (200.0 / 255.0 * 0.5 + 0.1) * SKY);
}

#[test]
fn a_fine_checker_seen_at_grazing_angles_keeps_its_mean() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A 64 × 64 checker repeated 40 times over the floor: hundreds of squares per pixel far
    // off, where the footprint picks coarse mipmap levels.
    floor_obj(d, 40.0);
    let texels: Vec<[u8; 3]> = (0..64 * 64)
        .map(|i| {
            if (i % 64 + i / 64) % 2 == 0 {
                [230; 3]
            } else {
                [25; 3]
            }
        })
        .collect();
    write_png(&d.join("checker.png"), 64, 64, &texels);
    let material = "type = \"diffuse\"\nreflectance = { texture = \"checker.png\" }";
    // Low over the floor, looking far along it.
    let shot = floor_shot([0.0, 0.4, 9.0], [0.0, 0.0, -10.0], 20.0, material);
    let means = mean_of(d, "checker", &shot.replace("[24, 24]", "[32, 16]"), 64);
    let mean_albedo = 0.5 * (srgb_to_linear(230.0 / 255.0) + srgb_to_linear(25.0 / 255.0));
    // Part of the view above the horizon is sky; the floor's share is found by rendering the
    // same view with a plain floor of the checker's mean albedo.
    let plain =
        format!("type = \"diffuse\"\nreflectance = [{mean_albedo}, {mean_albedo}, {mean_albedo}]");
    let reference = floor_shot([0.0, 0.4, 9.0], [0.0, 0.0, -10.0], 20.0, &plain);
    let want = mean_of(d, "plain", &reference.replace("[24, 24]", "[32, 16]"), 64);
    assert_mean("grazing checker", means, 0.5 * (want[0] + want[1]));
}

#[test]
fn a_roughness_map_of_one_value_is_that_roughness() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    floor_obj(d, 1.0);
    // Roughness 0.4 in the green channel of a data map (linear: 102/255 = 0.4).
    write_png(&d.join("rough.png"), 2, 2, &[[0, 102, 255]; 4]);
    let conductor = "type = \"conductor\"\nreflectance = [0.9, 0.8, 0.6]\n";
    let mapped = format!("{conductor}roughness = {{ texture = \"rough.png\", channel = \"g\" }}");
    let constant = format!("{conductor}roughness = 0.4");
    let view = |m: &str| floor_shot([0.0, 2.0, 2.0], [0.0, 0.0, 0.0], 40.0, m);
    let a = mean_of(d, "mapped", &view(&mapped), 32);
    let b = mean_of(d, "constant", &view(&constant), 32);
    assert_mean("roughness map", a, 0.5 * (b[0] + b[1]));
}

#[test]
fn an_obj_materials_map_kd_is_the_same_texture() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    floor_obj(d, 2.0);
    write_png(&d.join("halves.png"), 2, 1, &[[60; 3], [200; 3]]);
    let obj = std::fs::read_to_string(d.join("floor.obj")).unwrap();
    std::fs::write(d.join("floor.obj"), format!("mtllib floor.mtl\n{obj}")).unwrap();
    std::fs::write(
        d.join("floor.mtl"),
        "newmtl floor\nKd 1 1 1\nmap_Kd halves.png\n",
    )
    .unwrap();
    let view = |material: &str| floor_shot([1.0, 6.0, 0.0], [1.0, 0.0, 0.0], 30.0, material);
    // Without a [[material]] the MTL's map_Kd is used; the shot's section named like it wins.
    let mtl = view("").replace("[[material]]\nname = \"floor\"\n", "");
    let shot = view("type = \"diffuse\"\nreflectance = { texture = \"halves.png\" }");
    let a = [1, 2].map(|seed| render_at(d, "mtl", &mtl, 16, seed));
    let b = [1, 2].map(|seed| render_at(d, "section", &shot, 16, seed));
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.rgb, y.rgb, "the same texture, the same seeds");
    }
}

/// A constant tangent-space normal map tilted `degrees` towards +u (+x on the floor), as
/// 8-bit linear RGB; returns the normal it decodes to, in world space (the floor faces +y).
fn tilted_map(path: &Path, degrees: f64) -> [f64; 3] {
    let (s, c) = degrees.to_radians().sin_cos();
    let encode = |x: f64| ((x + 1.0) * 0.5 * 255.0).round() as u8;
    let rgb = [encode(s), encode(0.0), encode(c)];
    write_png(path, 2, 2, &[rgb; 4]);
    let [x, y, z] = rgb.map(|v| 2.0 * v as f64 / 255.0 - 1.0);
    let length = (x * x + y * y + z * z).sqrt();
    // Tangent x is +u = +x; tangent y is +v, which runs towards −z on the floor.
    [x / length, z / length, -y / length]
}

/// The floor shot lit by a sun alone (no sky), shining from `towards_sun`.
fn sun_shot(material: &str, towards_sun: [f64; 3]) -> String {
    let sun = format!(
        "[[light]]\nname = \"sun\"\ntype = \"distant\"\nintensity = 3.0\nangle = 0.0\n\
         transform = {{ position = {towards_sun:?}, look_at = [0.0, 0.0, 0.0] }}\n"
    );
    let sky = format!("[environment]\nradiance = [{SKY}, {SKY}, {SKY}]\n");
    let shot = floor_shot([0.0, 6.0, 0.01], [0.0, 0.0, 0.0], 30.0, material);
    assert!(shot.contains(&sky));
    shot.replace(&sky, &sun)
}

/// Under a sun, a diffuse floor with a normal map tilted 30° towards the sun is lit by the
/// cosine to the mapped normal: its radiance over the plain floor's is (n_mapped·l)/(n·l).
#[test]
fn a_normal_map_turns_the_surface_to_the_light() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    floor_obj(d, 1.0);
    let mapped = tilted_map(&d.join("tilt.png"), 30.0);
    let diffuse = "type = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]\n";
    let l = [1.0f64, 1.0, 0.0];
    let norm = (2.0f64).sqrt();
    let cos_mapped = (mapped[0] * l[0] + mapped[1] * l[1] + mapped[2] * l[2]) / norm;
    let cos_plain = 1.0 / norm;
    let plain = mean_of(d, "plain", &sun_shot(diffuse, l), 8);
    let with_map = format!("{diffuse}normal_map = {{ texture = \"tilt.png\" }}");
    let tilted = mean_of(d, "tilted", &sun_shot(&with_map, l), 8);
    let want = 0.5 * (plain[0] + plain[1]) * cos_mapped / cos_plain;
    assert_mean("normal map towards the sun", tilted, want);
    // Strength 0 flattens the map.
    let flat = format!("{diffuse}normal_map = {{ texture = \"tilt.png\", scale = 0.0 }}");
    let flattened = mean_of(d, "flat", &sun_shot(&flat, l), 8);
    assert_mean(
        "normal map of strength 0",
        flattened,
        0.5 * (plain[0] + plain[1]),
    );
}

/// A steep normal map lets no light through the surface and creates none: a sun below the
/// floor leaves it black, and under a uniform sky the floor is no brighter than albedo × sky.
#[test]
fn a_normal_map_never_lets_light_through_or_creates_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    floor_obj(d, 1.0);
    tilted_map(&d.join("steep.png"), 70.0);
    for body in [
        "type = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]\n",
        "type = \"standard\"\nbase_color = [0.5, 0.5, 0.5]\nroughness = 0.3\n",
    ] {
        let material = format!("{body}normal_map = {{ texture = \"steep.png\" }}");
        let below = mean_of(d, "below", &sun_shot(&material, [1.0, -0.2, 0.0]), 8);
        assert_eq!(below, [0.0, 0.0], "{body}: lit from below the floor");
        let sky = floor_shot([0.0, 6.0, 0.01], [0.0, 0.0, 0.0], 30.0, &material);
        let means = mean_of(d, "sky", &sky, 64);
        let limit = if body.contains("standard") { 1.0 } else { 0.5 } * SKY;
        for m in means {
            assert!(m <= limit * 1.01, "{body}: {m} under a sky of {SKY}");
        }
    }
}

/// An MTL's PBR statements (Pm, map_Pr, norm with -bm) make the same standard material as the
/// `[[material]]` section that says the same, image for image.
#[test]
fn an_mtls_pbr_maps_make_the_same_standard_material() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    floor_obj(d, 2.0);
    write_png(&d.join("rough.png"), 2, 1, &[[40; 3], [200; 3]]);
    tilted_map(&d.join("tilt.png"), 25.0);
    let obj = std::fs::read_to_string(d.join("floor.obj")).unwrap();
    std::fs::write(d.join("floor.obj"), format!("mtllib floor.mtl\n{obj}")).unwrap();
    std::fs::write(
        d.join("floor.mtl"),
        "newmtl floor\nKd 0.6 0.4 0.2\nPm 0.25\nmap_Pr rough.png\nnorm -bm 0.5 tilt.png\n",
    )
    .unwrap();
    let view = |material: &str| floor_shot([1.0, 6.0, 0.5], [1.0, 0.0, 0.0], 30.0, material);
    let mtl = view("").replace("[[material]]\nname = \"floor\"\n", "");
    let shot = view(
        "type = \"standard\"\nbase_color = [0.6, 0.4, 0.2]\nmetallic = 0.25\n\
         roughness = { texture = \"rough.png\" }\n\
         normal_map = { texture = \"tilt.png\", scale = 0.5 }",
    );
    let a = [1, 2].map(|seed| render_at(d, "mtl", &mtl, 16, seed));
    let b = [1, 2].map(|seed| render_at(d, "section", &shot, 16, seed));
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.rgb, y.rgb, "the same material, the same seeds");
    }
    // And it is not the plain diffuse floor of Kd.
    let plain = view("type = \"diffuse\"\nreflectance = [0.6, 0.4, 0.2]");
    assert_ne!(render_at(d, "plain", &plain, 16, 1).rgb, a[0].rgb);
}

/// `filter = "bilinear"` reads the full image whatever the footprint: on a checker far finer
/// than the pixels the image keeps the trilinear mean, but its pixels scatter around it (the
/// samples do the filtering) where the mipmap's are smooth.
#[test]
fn a_bilinear_texture_keeps_the_mean_without_the_mipmaps_blur() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    floor_obj(d, 200.0);
    write_png(
        &d.join("fine.png"),
        2,
        2,
        &[[0; 3], [255; 3], [255; 3], [0; 3]],
    );
    let view = |reflectance: &str| {
        let material = format!("type = \"diffuse\"\nreflectance = {reflectance}");
        floor_shot([0.0, 8.0, 0.01], [0.0, 0.0, 0.0], 60.0, &material)
    };
    let textured = |filter: &str| {
        view(&format!(
            "{{ texture = \"fine.png\", filter = \"{filter}\" }}"
        ))
    };
    // Each image's mean and its pixels' spread around it, relative.
    let spread = |rgb: &[glam::Vec3]| {
        let mean = rgb.iter().map(|c| c.y as f64).sum::<f64>() / rgb.len() as f64;
        let var = rgb.iter().map(|c| (c.y as f64 - mean).powi(2)).sum::<f64>() / rgb.len() as f64;
        (mean, var.sqrt() / mean)
    };
    let render =
        |name: &str, shot: &str| [1, 2].map(|seed| spread(&render_at(d, name, shot, 4, seed).rgb));
    let trilinear = render("tri", &textured("trilinear"));
    let bilinear = render("bi", &textured("bilinear"));
    // The plain floor of the checker's mean albedo: the lighting's own noise.
    let plain = render("plain", &view("[0.5, 0.5, 0.5]"));
    // The mean albedo of a black-and-white checker: half of white's linear 1.
    let want = 0.5 * SKY;
    assert_mean("trilinear", trilinear.map(|(m, _)| m), want);
    assert_mean("bilinear", bilinear.map(|(m, _)| m), want);
    let (tri, bi, lighting) = (trilinear[0].1, bilinear[0].1, plain[0].1);
    eprintln!("pixel spread: bilinear {bi:.3}, trilinear {tri:.3}, plain {lighting:.3}");
    assert!(tri < 1.2 * lighting && bi > 1.5 * lighting);
}

/// A black cut-out quad filling the view against a sky of radiance SKY: the camera sees the sky
/// through it in proportion to 1 − opacity, a constant one or a texture's (a grey map of two
/// halves, 0 and 1, giving half the sky).
#[test]
fn a_cut_out_lets_through_what_its_opacity_leaves() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // The quad at y = 1, facing down, UVs 0 to 1 over it.
    std::fs::write(
        d.join("floor.obj"),
        "v -10 1 -10\nv 10 1 -10\nv 10 1 10\nv -10 1 10\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
         usemtl floor\nf 1/1 2/2 3/3 4/4\n",
    )
    .unwrap();
    write_png(&d.join("halves.png"), 2, 1, &[[0; 3], [255; 3]]);
    let look_up = |material: &str| {
        floor_shot([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], 20.0, material)
            .replace("up = [0.0, 0.0, -1.0]", "up = [0.0, 0.0, -1.0]")
    };
    let black = "type = \"diffuse\"\nreflectance = [0.0, 0.0, 0.0]\n";
    let constant = mean_of(
        d,
        "constant",
        &look_up(&format!("{black}opacity = 0.3")),
        16,
    );
    assert_mean("opacity 0.3", constant, 0.7 * SKY);
    let mapped = format!("{black}opacity = {{ texture = \"halves.png\", filter = \"bilinear\" }}");
    // The camera sees the middle of the quad, where the two halves meet: half of it each.
    let halves = mean_of(d, "halves", &look_up(&mapped), 16);
    assert_mean("opacity map of two halves", halves, 0.5 * SKY);
}

/// Shadow rays pass a cut-out as camera rays do: a floor under a leaf of opacity 0.3, lit by
/// a sun alone, gets 0.7 of the light it gets without the leaf.
#[test]
fn a_cut_outs_shadow_lets_through_what_its_opacity_leaves() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    floor_obj(d, 1.0);
    std::fs::write(
        d.join("leaf.obj"),
        "v -10 2 -10\nv 10 2 -10\nv 10 2 10\nv -10 2 10\nf 1 2 3 4\n",
    )
    .unwrap();
    let diffuse = "type = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]\n";
    let below = |extra: &str| {
        let shot = sun_shot(diffuse, [0.3, 1.0, 0.2])
            .replace("position = [0.0, 6.0, 0.01]", "position = [0.0, 1.0, 0.01]");
        format!("{shot}{extra}")
    };
    let leaf = "[[material]]\nname = \"leaf\"\ntype = \"diffuse\"\nreflectance = [0.0, 0.0, 0.0]\n\
                opacity = 0.3\n[[object]]\nname = \"leaf\"\nmesh = \"leaf.obj\"\nmaterial = \"leaf\"\n";
    let open = mean_of(d, "open", &below(""), 64);
    let shaded = mean_of(d, "shaded", &below(leaf), 64);
    assert_mean(
        "the sun through a leaf of opacity 0.3",
        shaded,
        0.7 * 0.5 * (open[0] + open[1]),
    );
}

/// A cut-out on an object that moves is refused, naming the object.
#[test]
fn a_moving_cut_out_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    floor_obj(d, 1.0);
    let shot = floor_shot(
        [0.0, 3.0, 0.0],
        [0.0, 0.0, 0.0],
        10.0,
        "type = \"diffuse\"\nopacity = 0.5",
    )
    .replace(
        "frames = [1, 1]",
        "frames = [1, 1]\nshutter = [-0.25, 0.25]",
    )
    .replace(
        "mesh = \"floor.obj\"\n",
        "mesh = \"floor.obj\"\ntransform = { keys = [{ frame = 0, position = [0.0, 0.0, 0.0] }, \
             { frame = 2, position = [1.0, 0.0, 0.0] }] }\n",
    );
    let path = d.join("moving.toml");
    std::fs::write(&path, shot).unwrap();
    let e = Scene::load(&Shot::load(&path).unwrap(), 1)
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("object[0]") && e.contains("stand still") && e.contains("moving.toml"),
        "{e}"
    );
}

/// The error the floor shot with `material` gives (after writing `files`).
fn refusal(dir: &Path, material: &str) -> String {
    let path = dir.join("bad.toml");
    std::fs::write(
        &path,
        floor_shot([0.0, 3.0, 0.0], [0.0, 0.0, 0.0], 10.0, material),
    )
    .unwrap();
    match Shot::load(&path) {
        Err(e) => e.to_string(),
        Ok(shot) => Scene::load(&shot, 1)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default(),
    }
}

#[test]
fn bad_textures_are_refused_by_file_and_key() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    floor_obj(d, 1.0);
    write_png(&d.join("ok.png"), 2, 2, &[[100; 3]; 4]);
    // Truncated: the first half of a good PNG.
    let good = std::fs::read(d.join("ok.png")).unwrap();
    std::fs::write(d.join("cut.png"), &good[..good.len() / 2]).unwrap();
    std::fs::write(d.join("junk.png"), b"not an image at all").unwrap();
    // A PNG header declaring 40000 × 40000 pixels (1.6·10⁹) with no data behind it.
    let mut huge = good[..33].to_vec();
    huge[16..20].copy_from_slice(&40_000u32.to_be_bytes());
    huge[20..24].copy_from_slice(&40_000u32.to_be_bytes());
    let mut crc = flate2::Crc::new();
    crc.update(&huge[12..29]);
    huge[29..33].copy_from_slice(&crc.sum().to_be_bytes());
    // An empty IDAT chunk after it: the header is all there is.
    let mut idat = flate2::Crc::new();
    idat.update(b"IDAT");
    huge.extend([0, 0, 0, 0]);
    huge.extend(b"IDAT");
    huge.extend(idat.sum().to_be_bytes());
    std::fs::write(d.join("huge.png"), huge).unwrap();
    let diffuse =
        |texture: &str| format!("type = \"diffuse\"\nreflectance = {{ texture = \"{texture}\" }}");
    let cases = [
        (
            diffuse("missing.png"),
            "material[0].reflectance.texture",
            "missing.png",
        ),
        (
            diffuse("cut.png"),
            "material[0].reflectance.texture",
            "cut.png",
        ),
        (
            diffuse("junk.png"),
            "material[0].reflectance.texture",
            "not a PNG, JPEG or EXR",
        ),
        (
            diffuse("huge.png"),
            "material[0].reflectance.texture",
            "40000 × 40000",
        ),
        (
            "type = \"dielectric\"\nior = { texture = \"ok.png\" }".into(),
            "material[0].ior",
            "cannot take a texture",
        ),
        (
            "type = \"diffuse\"\nroughness = { texture = \"ok.png\" }".into(),
            "material[0].roughness",
            "no roughness",
        ),
        (
            "type = \"conductor\"\nroughness = { texture = \"ok.png\", channel = \"q\" }".into(),
            "material[0].roughness.channel",
            "\"q\"",
        ),
        (
            "type = \"diffuse\"\nreflectance = { texture = \"ok.png\", colorspace = \"acescg\" }"
                .into(),
            "material[0].reflectance.colorspace",
            "acescg",
        ),
        (
            "type = \"diffuse\"\nreflectance = { texture = \"ok.png\", scale = [1, 2] }".into(),
            "material[0].reflectance.scale",
            "expected a number or [r, g, b]",
        ),
        (
            "type = \"diffuse\"\nnormal_map = { texture = \"ok.png\", offset = 0.5 }".into(),
            "material[0].normal_map.offset",
            "only texture, scale",
        ),
        (
            "type = \"diffuse\"\nnormal_map = { texture = \"ok.png\", filter = \"bilinear\" }"
                .into(),
            "material[0].normal_map.filter",
            "full image",
        ),
        (
            "type = \"diffuse\"\nnormal_map = { texture = \"ok.png\", scale = -1.0 }".into(),
            "material[0].normal_map.scale",
            "≥ 0",
        ),
        (
            "type = \"diffuse\"\nmetallic = { texture = \"ok.png\" }".into(),
            "material[0].metallic",
            "only a standard material",
        ),
        (
            "type = \"conductor\"\ncoat = 0.5".into(),
            "material[0].coat",
            "only a standard material",
        ),
        (
            "type = \"standard\"\nreflectance = [0.5, 0.5, 0.5]".into(),
            "material[0].reflectance",
            "base_color",
        ),
        (
            "type = \"standard\"\nior = 4.0".into(),
            "material[0].ior",
            "4",
        ),
        (
            "type = \"standard\"\nbase_color = [1.2, 0.5, 0.5]".into(),
            "material[0].base_color",
            "creates energy",
        ),
        (
            "type = \"diffuse\"\nopacity = 1.5".into(),
            "material[0].opacity",
            "1.5",
        ),
        (
            "type = \"diffuse\"\nemission = [1.0, 1.0, 1.0]\nopacity = 0.5".into(),
            "material[0].opacity",
            "cannot cut out",
        ),
        (
            "type = \"diffuse\"\nemission = { texture = \"ok.png\" }\nopacity = 0.5".into(),
            "material[0].opacity",
            "cannot cut out",
        ),
        (
            "type = \"diffuse\"\nemission = { texture = \"missing.png\" }".into(),
            "material[0].emission.texture",
            "missing.png",
        ),
        (
            "type = \"standard\"\ncoat_roughness = { texture = \"missing.png\" }".into(),
            "material[0].coat_roughness.texture",
            "missing.png",
        ),
    ];
    for (material, key, says) in cases {
        let e = refusal(d, &material);
        assert!(
            e.contains(key) && e.contains(says) && e.contains("bad.toml"),
            "{key}: expected an error naming it, {says:?} and the file, got {e:?}"
        );
    }
    // A textured material on a mesh without texture coordinates.
    std::fs::write(
        d.join("floor.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 0 1\nusemtl floor\nf 1 2 3\n",
    )
    .unwrap();
    let e = refusal(d, &diffuse("ok.png"));
    assert!(
        e.contains("object[0].mesh") && e.contains("no texture coordinates"),
        "{e}"
    );
    // An MTL's roughness that is not a number from 0 to 1.
    std::fs::write(
        d.join("floor.obj"),
        "mtllib floor.mtl\nv 0 0 0\nv 1 0 0\nv 0 0 1\nusemtl floor\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(d.join("floor.mtl"), "newmtl floor\nPr rough\n").unwrap();
    let shot = floor_shot([0.0, 3.0, 0.0], [0.0, 0.0, 0.0], 10.0, "")
        .replace("[[material]]\nname = \"floor\"\n", "");
    let path = d.join("mtl.toml");
    std::fs::write(&path, shot).unwrap();
    let e = Scene::load(&Shot::load(&path).unwrap(), 1)
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("Pr") && e.contains("\"rough\"") && e.contains("floor.obj"),
        "{e}"
    );
}

/// A lamp 2 × 1 m at y = 0.6 facing down over the floor, as two quads side by side (−x and
/// +x), their UVs running 0 to ½ and ½ to 1 across; `left_only` leaves out the +x quad.
fn lamp_obj(dir: &Path, left_only: bool) {
    let mut obj = String::from(
        "mtllib lamp.mtl\nv -1 0.6 -0.5\nv 0 0.6 -0.5\nv 0 0.6 0.5\nv -1 0.6 0.5\n\
         vt 0 0\nvt 0.5 0\nvt 0.5 1\nvt 0 1\nusemtl lamp\nf 1/1 2/2 3/3 4/4\n",
    );
    if !left_only {
        obj += "v 0 0.6 -0.5\nv 1 0.6 -0.5\nv 1 0.6 0.5\nv 0 0.6 0.5\n\
                vt 0.5 0\nvt 1 0\nvt 1 1\nvt 0.5 1\nf 5/5 6/6 7/7 8/8\n";
    }
    std::fs::write(dir.join("lamp.obj"), obj).unwrap();
}

/// The floor lit only by the lamp (`lamp` its material's section body), seen from `position`
/// looking at `target`.
fn lamp_shot(position: [f32; 3], target: [f32; 3], lamp: &str) -> String {
    floor_shot(
        position,
        target,
        60.0,
        "type = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]",
    )
    .replace(
        &format!("radiance = [{SKY}, {SKY}, {SKY}]"),
        "radiance = [0.0, 0.0, 0.0]",
    )
    .replace("max_bounces = 1", "max_bounces = 3")
    .replace("up = [0.0, 0.0, -1.0]", "up = [0.0, 1.0, 0.0]")
        + &format!(
            "[[material]]\nname = \"lamp\"\n{lamp}\n[[object]]\nname = \"lamp\"\nmesh = \"lamp.obj\"\n"
        )
}

#[test]
fn a_textured_emitter_lights_as_the_light_its_texture_paints() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    floor_obj(d, 1.0);
    // The lamp's texture: white over its −x half, black over its +x half (256 texels, so the
    // bilinear ramp between them is 8 mm wide), at 3 times: the −x quad alone emitting 3.
    let halves: Vec<[u8; 3]> = (0..256)
        .map(|i| if i < 128 { [255; 3] } else { [0; 3] })
        .collect();
    write_png(&d.join("halves.png"), 256, 1, &halves);
    std::fs::write(d.join("lamp.mtl"), "newmtl lamp\nKd 0 0 0\n").unwrap();
    let textured = "type = \"diffuse\"\nreflectance = [0.0, 0.0, 0.0]\n\
                    emission = { texture = \"halves.png\", scale = 3.0 }";
    let constant = "type = \"diffuse\"\nreflectance = [0.0, 0.0, 0.0]\nemission = [3.0, 3.0, 3.0]";
    // Light sampling picks each triangle by its mean (read through the mipmap, so a little of
    // the other half bleeds across the edge they share): the +x quad's are nearly black.
    lamp_obj(d, false);
    let view = [0.0, 1.6, 2.6];
    let shot = lamp_shot(view, [0.0, 0.0, 0.0], textured);
    let path = d.join("textured.toml");
    std::fs::write(&path, &shot).unwrap();
    let scene = Scene::load(&Shot::load(&path).unwrap(), 1).unwrap();
    let means: Vec<f32> = scene.lights.emitters.iter().map(|e| e.radiance.y).collect();
    eprintln!("the lamp's triangles' mean radiance: {means:?}");
    assert_eq!(means.len(), 4);
    assert!(
        means[..2].iter().all(|m| (m - 3.0).abs() < 0.3),
        "{means:?}"
    );
    assert!(means[2..].iter().all(|m| *m < 0.3), "{means:?}");
    // The floor lit by the half-painted lamp is the floor lit by its painted half alone: each
    // strategy reads the texture where it lands (light sampling at the points it draws), so
    // the images agree within their noise, region by region (relMSE), not just on average.
    let a = [1, 2].map(|seed| render_at(d, "textured", &shot, 16, seed));
    lamp_obj(d, true);
    let half = lamp_shot(view, [0.0, 0.0, 0.0], constant);
    let b = [1, 2].map(|seed| render_at(d, "half", &half, 16, seed));
    common::assert_statistically_equal(
        [&a[0].rgb, &a[1].rgb],
        [&b[0].rgb, &b[1].rgb],
        "a half-painted lamp against its painted half",
    );
    // Seen from below, the lamp shows its texture: 3 on the −x half, 0 on the +x half.
    lamp_obj(d, false);
    let below = lamp_shot([0.0, 0.05, 0.0], [0.0, 1.0, 0.0], textured)
        .replace("up = [0.0, 1.0, 0.0]", "up = [0.0, 0.0, 1.0]")
        .replace("fov_degrees = 60", "fov_degrees = 20");
    let image = render_at(d, "below", &below, 4, 1);
    let (w, h) = (image.width, image.height);
    let side = |from: usize, to: usize| {
        let mut sum = 0.0;
        for y in 0..h {
            for x in from..to {
                sum += image.rgb[y * w + x].y as f64;
            }
        }
        sum / ((to - from) * h) as f64
    };
    let (left, right) = (side(0, w / 2 - 2), side(w / 2 + 2, w));
    eprintln!("seen from below: {left:.4} on the painted half, {right:.4} on the black one");
    assert!((left - 3.0).abs() < 0.01 && right < 0.01, "{left} {right}");
    // An OBJ's map_Ke, scaled by its Ke, is the same texture.
    std::fs::write(
        d.join("lamp.mtl"),
        "newmtl lamp\nKd 0 0 0\nKe 3 3 3\nmap_Ke halves.png\n",
    )
    .unwrap();
    let from_mtl = shot.replace(&format!("[[material]]\nname = \"lamp\"\n{textured}\n"), "");
    assert!(!from_mtl.contains("halves.png"));
    for (seed, a) in [1, 2].iter().zip(&a) {
        let mtl = render_at(d, "from_mtl", &from_mtl, 16, *seed);
        assert_eq!(mtl.rgb, a.rgb, "the same emission texture, the same seeds");
    }
}
