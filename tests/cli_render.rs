//! `rift render` end to end: determinism across thread counts and bad input.

mod common;

use common::{files_in, rift, root, stderr};

fn cornell_text() -> String {
    std::fs::read_to_string(root().join("examples/cornell.toml")).unwrap()
}

/// Writes the Cornell shot (edited by `edit`) and its meshes into a temporary directory.
fn scene_dir(edit: impl Fn(String) -> String) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for f in ["cornell.obj", "cornell.mtl"] {
        std::fs::copy(root().join("examples").join(f), dir.path().join(f)).unwrap();
    }
    std::fs::write(dir.path().join("shot.toml"), edit(cornell_text())).unwrap();
    dir
}

fn expect_failure(dir: &tempfile::TempDir, expect: &[&str]) {
    let out = rift(
        dir.path(),
        &["render", "shot.toml", "--spp", "1", "-o", "out/img.exr"],
    );
    let msg = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{msg}");
    for e in expect {
        assert!(msg.contains(e), "message {msg:?} lacks {e:?}");
    }
    assert!(!msg.contains("panicked"), "{msg}");
    assert!(
        files_in(&dir.path().join("out")).is_empty(),
        "left output behind"
    );
}

#[test]
fn same_seed_gives_identical_pixels_for_any_thread_count() {
    let dir = scene_dir(|t| t.replace("resolution = [256, 256]", "resolution = [64, 64]"));
    let mut images = Vec::new();
    for threads in ["1", "2", "3"] {
        let out = format!("img{threads}.exr");
        let r = rift(
            dir.path(),
            &[
                "render",
                "shot.toml",
                "--spp",
                "4",
                "--threads",
                threads,
                "-o",
                &out,
            ],
        );
        assert!(r.status.success(), "{}", stderr(&r));
        images.push(
            rift_render::film::read_exr_rgb(&dir.path().join(out))
                .unwrap()
                .2,
        );
    }
    assert!(images[0] == images[1] && images[1] == images[2]);
    // A different seed changes the noise.
    let r = rift(
        dir.path(),
        &[
            "render",
            "shot.toml",
            "--spp",
            "4",
            "--seed",
            "7",
            "-o",
            "other.exr",
        ],
    );
    assert!(r.status.success());
    let other = rift_render::film::read_exr_rgb(&dir.path().join("other.exr"))
        .unwrap()
        .2;
    assert!(other != images[0]);
}

#[test]
fn missing_mesh() {
    let dir = scene_dir(|t| t.replace("mesh = \"cornell.obj\"", "mesh = \"nowhere.obj\""));
    expect_failure(&dir, &["nowhere.obj", "no such mesh file"]);
}

#[test]
fn malformed_obj() {
    let dir = scene_dir(|t| t);
    std::fs::write(
        dir.path().join("cornell.obj"),
        "mtllib cornell.mtl\nv 0 0 0\nv 1 0 0\nf 1 2 9\n",
    )
    .unwrap();
    expect_failure(&dir, &["cornell.obj", "malformed OBJ"]);
}

#[test]
fn unknown_material() {
    let dir = scene_dir(|t| {
        t.replace(
            "mesh = \"cornell.obj\"",
            "mesh = \"cornell.obj\"\nmaterial = \"chrome\"",
        )
    });
    expect_failure(
        &dir,
        &[
            "shot.toml: object[0].material",
            "no material is called \"chrome\"",
        ],
    );
}

#[test]
fn unknown_render_key() {
    let dir = scene_dir(|t| t.replace("spp = 64", "spp = 64\nsamples = 3"));
    expect_failure(&dir, &["shot.toml: render.samples", "unknown field"]);
}

#[test]
fn bad_material_values() {
    let dir = scene_dir(|t| {
        t + "\n[[material]]\nname = \"hot\"\ntype = \"diffuse\"\nreflectance = [1.5, 0.2, 0.2]\n"
    });
    expect_failure(&dir, &["shot.toml: material[0].reflectance", "above 1"]);
}

#[test]
fn unwritable_output() {
    let dir = scene_dir(|t| t);
    std::fs::write(dir.path().join("blocker"), b"").unwrap();
    let out = rift(
        dir.path(),
        &["render", "shot.toml", "--spp", "1", "-o", "blocker/img.exr"],
    );
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains("blocker"), "{}", stderr(&out));
}

#[test]
fn nan_in_a_transform() {
    let dir = scene_dir(|t| {
        t.replace(
            "mesh = \"cornell.obj\"",
            "mesh = \"cornell.obj\"\ntransform = { position = [nan, 0.0, 0.0] }",
        )
    });
    expect_failure(&dir, &["shot.toml: object[0].transform.position", "finite"]);
}

#[test]
fn zero_resolution() {
    let dir = scene_dir(|t| t.replace("resolution = [256, 256]", "resolution = [0, 256]"));
    expect_failure(
        &dir,
        &["shot.toml: camera.resolution[0]", "positive integer"],
    );
}

#[test]
fn resolution_override_and_png_preview() {
    let dir = scene_dir(|t| t);
    let r = rift(
        dir.path(),
        &[
            "render",
            "shot.toml",
            "--spp",
            "1",
            "--res",
            "40",
            "30",
            "--png",
            "-o",
            "img.####.exr",
        ],
    );
    assert!(r.status.success(), "{}", stderr(&r));
    let (w, h, _) = rift_render::film::read_exr_rgb(&dir.path().join("img.0001.exr")).unwrap();
    assert_eq!((w, h), (40, 30));
    let png = std::fs::read(dir.path().join("img.0001.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let be = |i: usize| u32::from_be_bytes(png[i..i + 4].try_into().unwrap());
    assert_eq!((be(16), be(20)), (40, 30), "IHDR width and height");
    let bad = rift(
        dir.path(),
        &["render", "shot.toml", "--res", "0", "30", "-o", "x.exr"],
    );
    assert_eq!(bad.status.code(), Some(1));
    assert!(stderr(&bad).contains("--res"));
}
