//! Cryptomatte layers from `rift render --cryptomatte`: the right object's ID covers each card's
//! pixels fully, through an opening too; coverages stay within one and split at edges; the
//! header names the layer and its manifest maps every object to its ID; what cannot be counted
//! is refused.

use crate::common;

use common::{rift, stderr};
use rift_render::frame::cryptomatte::id;
use rift_render::frame::film::read_exr_layer;
use std::path::Path;

/// Three cards facing a camera at the origin looking down −Z, 5 m away: "red" at left, "blue"
/// at right, both 1.6 m square; an opening 4 m away (centred at x = 0.9, radius 0.5, partly in
/// front of the blue card) leads to "green", a card 100 m along +X. The sky is black.
fn write_scene(dir: &Path) {
    let card = |x: f32, z: f32| {
        format!(
            "v {} -0.8 {z}\nv {} -0.8 {z}\nv {} 0.8 {z}\nv {} 0.8 {z}\nf 1 2 3 4\n",
            x - 0.8,
            x + 0.8,
            x + 0.8,
            x - 0.8
        )
    };
    std::fs::write(dir.join("red.obj"), card(-1.8, -5.0)).unwrap();
    std::fs::write(dir.join("blue.obj"), card(1.8, -5.0)).unwrap();
    std::fs::write(dir.join("green.obj"), card(100.9, -5.0)).unwrap();
    let objects: String = ["red", "blue", "green"]
        .iter()
        .map(|n| format!("[[object]]\nname = \"{n}\"\nmesh = \"{n}.obj\"\nmaterial = \"grey\"\n"))
        .collect();
    std::fs::write(
        dir.join("cards.toml"),
        format!(
            r#"
[shot]
name = "cards"
fps = 24.0
frames = [1, 1]
shutter = [0.0, 0.0]
[camera]
resolution = [64, 32]
fov_degrees = 60.0
[camera.transform]
position = [0.0, 0.0, 0.0]
[environment]
radiance = [0.0, 0.0, 0.0]
[[material]]
name = "grey"
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]
emission = [1.0, 1.0, 1.0]
[[portal]]
name = "door"
here = {{ position = [0.9, 0.0, -4.0] }}
there = {{ position = [100.9, 0.0, -4.0] }}
[portal.surface]
radius = 0.5
{objects}"#
        ),
    )
    .unwrap();
}

#[test]
fn each_card_and_what_the_opening_shows_carry_their_own_ids() {
    let dir = tempfile::tempdir().unwrap();
    write_scene(dir.path());
    let out = rift(
        dir.path(),
        &[
            "render",
            "cards.toml",
            "--spp",
            "16",
            "--cryptomatte",
            "-o",
            "cards.exr",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let layer = read_exr_layer(&dir.path().join("cards.exr")).unwrap();
    let channel = |name: &str| &layer.channels[name];
    let (w, h) = layer.size;
    let at = |x: usize, y: usize| y * w + x;
    let (id0, cover0) = (channel("CryptoObject00.R"), channel("CryptoObject00.G"));
    let (id1, cover1) = (channel("CryptoObject00.B"), channel("CryptoObject00.A"));
    // Card centres (the red card's centre is at x = −1.8 m, 5 m away: 64 px over 60° wide).
    let column = |x_m: f32| {
        let tan = x_m / 5.0;
        ((tan / (30f32.to_radians().tan()) * 0.5 + 0.5) * w as f32) as usize
    };
    let door = ((0.9f32 / 4.0 / 30f32.to_radians().tan() * 0.5 + 0.5) * w as f32) as usize;
    for (name, x) in [
        ("red", column(-1.8)),
        ("blue", column(2.2)),
        ("green", door),
    ] {
        let p = at(x, h / 2);
        assert_eq!(id0[p], id(name), "{name} at column {x}");
        assert_eq!(cover0[p], 1.0, "{name} covers its centre");
        assert_eq!(cover1[p], 0.0);
    }
    // The black sky (above the cards) has no object; every pixel's coverages sum to at most 1,
    // and some pixels on edges split between two IDs.
    assert_eq!(cover0[at(2, 0)], 0.0);
    let mut split = 0;
    for p in 0..w * h {
        let total: f32 = ["G", "A"]
            .iter()
            .flat_map(|c| (0..3).map(move |l| format!("CryptoObject{l:02}.{c}")))
            .map(|name| channel(&name)[p])
            .sum();
        assert!(total <= 1.0 + 1e-6, "pixel {p}: coverage {total}");
        if cover0[p] > 0.0 && cover1[p] > 0.0 {
            split += 1;
            assert!(id0[p] != id1[p]);
        }
    }
    assert!(
        split > 0,
        "the opening's edge over the blue card splits its pixels"
    );
    // The header: the layer's name, hash, conversion and a manifest of every object.
    let meta = exr::meta::MetaData::read_from_file(dir.path().join("cards.exr"), false).unwrap();
    let text = |key: &str| {
        meta.headers[0]
            .own_attributes
            .other
            .iter()
            .find(|(k, _)| {
                k.to_string().starts_with("cryptomatte/") && k.to_string().ends_with(key)
            })
            .map(|(_, v)| match v {
                exr::meta::attribute::AttributeValue::Text(t) => t.to_string(),
                other => panic!("{key}: {other:?}"),
            })
            .unwrap_or_else(|| panic!("no cryptomatte/…/{key} attribute"))
    };
    assert_eq!(text("/name"), "CryptoObject");
    assert_eq!(text("/hash"), "MurmurHash3_32");
    assert_eq!(text("/conversion"), "uint32_to_float32");
    let manifest = text("/manifest");
    for name in ["red", "blue", "green"] {
        assert!(
            manifest.contains(&format!("\"{name}\":\"{:08x}\"", id(name).to_bits())),
            "{manifest}"
        );
    }
}

#[test]
fn cryptomatte_is_refused_where_its_counts_cannot_be_kept() {
    let dir = tempfile::tempdir().unwrap();
    write_scene(dir.path());
    for extra in [
        &["--samples", "0-8"][..],
        &["--checkpoint", "5"],
        &["--resume"],
    ] {
        let mut args = vec![
            "render",
            "cards.toml",
            "--spp",
            "8",
            "--cryptomatte",
            "-o",
            "x.exr",
        ];
        args.extend_from_slice(extra);
        let out = rift(dir.path(), &args);
        assert!(!out.status.success(), "{extra:?}");
        assert!(stderr(&out).contains("--cryptomatte"), "{}", stderr(&out));
        assert!(!dir.path().join("x.exr").exists());
    }
    // A part with Cryptomatte layers is refused by merge, not merged without them.
    let out = rift(
        dir.path(),
        &[
            "render",
            "cards.toml",
            "--spp",
            "4",
            "--cryptomatte",
            "-o",
            "c.exr",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let out = rift(dir.path(), &["merge", "m.exr", "c.exr"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("Cryptomatte"), "{}", stderr(&out));
}

/// Each instance of a USD prototype carries its own ID (its instancer's prototype path and its
/// index), so a compositor can pick one chair of a scattered set: two cards a PointInstancer
/// places where `write_scene` has the red and blue ones, and a third behind the camera, which
/// the manifest leaves out (it lists what the frame shows).
#[test]
fn instances_of_a_usd_prototype_carry_their_own_ids() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("scatter.usda"),
        "#usda 1.0\n(\n metersPerUnit = 1\n upAxis = \"Y\"\n)\n\
         def PointInstancer \"Scatter\" {\n rel prototypes = [</Scatter/Card>]\n \
         int[] protoIndices = [0, 0, 0]\n point3f[] positions = [(-1.8, 0, -5), (1.8, 0, -5), (0, 0, 5)]\n \
         def Mesh \"Card\" {\n  point3f[] points = [(-0.8, -0.8, 0), (0.8, -0.8, 0), \
         (0.8, 0.8, 0), (-0.8, 0.8, 0)]\n  int[] faceVertexCounts = [4]\n  \
         int[] faceVertexIndices = [0, 1, 2, 3]\n }\n}\n",
    )
    .unwrap();
    std::fs::write(
        d.join("scatter.toml"),
        "[shot]\nname = \"scatter\"\nfps = 24.0\nframes = [1, 1]\nshutter = [0.0, 0.0]\n\
         [camera]\nresolution = [64, 32]\nfov_degrees = 60.0\n[camera.transform]\n\
         position = [0.0, 0.0, 0.0]\n[environment]\nradiance = [0.5, 0.5, 0.5]\n\
         [[usd]]\nfile = \"scatter.usda\"\n",
    )
    .unwrap();
    let out = rift(
        d,
        &[
            "render",
            "scatter.toml",
            "--spp",
            "4",
            "--cryptomatte",
            "-o",
            "scatter.exr",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let layer = read_exr_layer(&d.join("scatter.exr")).unwrap();
    let (ids, cover) = (
        &layer.channels["CryptoObject00.R"],
        &layer.channels["CryptoObject00.G"],
    );
    let (w, h) = layer.size;
    let column =
        |x_m: f32| ((x_m / 5.0 / 30f32.to_radians().tan() * 0.5 + 0.5) * w as f32) as usize;
    for (name, x) in [("/Scatter/Card[0]", -1.8), ("/Scatter/Card[1]", 1.8)] {
        let p = (h / 2) * w + column(x);
        assert_eq!(ids[p], id(name), "{name} at its centre");
        assert_eq!(cover[p], 1.0, "{name} covers its centre");
    }
    let meta = exr::meta::MetaData::read_from_file(d.join("scatter.exr"), false).unwrap();
    let manifest = (meta.headers[0].own_attributes.other.iter())
        .find(|(k, _)| k.to_string().ends_with("/manifest"))
        .map(|(_, v)| format!("{v:?}"))
        .unwrap();
    for name in ["/Scatter/Card[0]", "/Scatter/Card[1]"] {
        assert!(manifest.contains(name), "{manifest}");
    }
    assert!(!manifest.contains("/Scatter/Card[2]"), "{manifest}");
}
