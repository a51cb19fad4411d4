//! Every reader of user input as one function from bytes, for the fuzz targets in `fuzz/` and
//! the regression tests that replay their corpora on stable. Each must return, with or without
//! an error, and never panic, hang or allocate without bound, whatever the bytes.

use crate::prepare::Prepared;
use crate::scene::Overrides;
use rift_fx::Shot;
use std::path::Path;

/// The most strands a fuzzed shot may ask for before its scene is built: generating rings
/// costs time in proportion, which only slows the fuzzer down.
const MAX_FUZZED_STRANDS: u32 = 256;

/// The most openings a fuzzed shot may have before its scene is built: the measurements for
/// light through openings grow with their pairs (32 openings took 3.4 s under the
/// sanitizers), and a few such inputs would reach the fuzzer's timeout.
const MAX_FUZZED_OPENINGS: usize = 16;

/// A reader of untrusted bytes.
pub type Reader = fn(&[u8]);

/// The readers, by the name of their fuzz target.
pub const TARGETS: [(&str, Reader); 12] = [
    ("shot", shot),
    ("obj", obj),
    ("ply_mesh", ply_mesh),
    ("ring_ply", ring_ply),
    ("ring_cache", ring_cache),
    ("exr", exr),
    ("exr_layer", exr_layer),
    ("checkpoint", checkpoint),
    ("vdb", vdb),
    ("texture", texture),
    ("mesh_sequence", mesh_sequence),
    ("usd", usd),
];

/// A shot file: parsed, validated and, when it is small (few strands and openings), built into
/// a scene (meshes are looked up beside `fuzz.toml` in the working directory).
pub fn shot(bytes: &[u8]) {
    let Ok(text) = std::str::from_utf8(bytes) else {
        return;
    };
    let Ok(shot) = Shot::parse(text, Path::new("fuzz.toml")) else {
        return;
    };
    let strands: u32 = shot.rings.iter().flatten().map(|look| look.strands).sum();
    if strands <= MAX_FUZZED_STRANDS && shot.rig.openings.len() <= MAX_FUZZED_OPENINGS {
        let overrides = Overrides::default();
        let _ = Prepared::build(&shot, shot.frames.first, &overrides);
    }
}

/// An OBJ mesh, whose MTL files hold the same bytes.
pub fn obj(bytes: &[u8]) {
    let _ = crate::scene::mesh::parse_obj(bytes, |_| Some(bytes.to_vec()));
}

/// A PLY mesh.
pub fn ply_mesh(bytes: &[u8]) {
    let _ = crate::scene::ply::parse(bytes);
}

/// A mesh sequence: up to four frames (PLY, or OBJ where a frame does not start `ply`),
/// separated by lines `end_frame`, checked for one topology and built into a deformation, then
/// traced at times before, between and after the samples.
pub fn mesh_sequence(bytes: &[u8]) {
    crate::scene::sequence::fuzz_frames(bytes);
}

/// A ring point cloud (PLY) written by `rift fx`.
pub fn ring_ply(bytes: &[u8]) {
    let _ = rift_fx::export::ply::decode(bytes);
}

/// A ring cache, its checksum made to match first (otherwise almost every mutation would stop
/// there and the decoder behind it would go untested).
pub fn ring_cache(bytes: &[u8]) {
    let mut sealed = bytes.to_vec();
    if let Some(body_len) = sealed.len().checked_sub(8) {
        let sum = rift_fx::export::cache::fnv1a(&sealed[..body_len]);
        sealed[body_len..].copy_from_slice(&sum.to_le_bytes());
    }
    let _ = rift_fx::export::cache::decode(&sealed);
}

/// An EXR environment map, of at most 2^20 pixels: the real limit
/// ([`crate::texture::MAX_EXR_PIXELS`]) takes gigabytes to reach, which only slows the fuzzer.
pub fn exr(bytes: &[u8]) {
    let _ = crate::texture::decode_exr_rgb(bytes, 1 << 20);
}

/// An EXR read whole with every channel, as `rift merge` reads its parts, of at most 2^20
/// pixels.
pub fn exr_layer(bytes: &[u8]) {
    let _ = crate::frame::film::decode_exr_layer(bytes, 1 << 20);
}

/// A checkpoint `rift render --resume` continues from, of at most 2^20 pixels.
pub fn checkpoint(bytes: &[u8]) {
    let _ = crate::frame::checkpoint::Checkpoint::decode(bytes, 1 << 20);
}

/// An OpenVDB file's "density" grid, with at most 8 MiB of voxels (filling a table of that
/// size is legitimate work that only slows the fuzzer down).
pub fn vdb(bytes: &[u8]) {
    let _ = crate::media::vdb::read_grid(bytes, "density", 8 << 20);
}

/// A texture image (PNG, JPEG or EXR) with its mipmaps, within 64 MiB: decoding a larger image
/// is legitimate work that only slows the fuzzer down.
pub fn texture(bytes: &[u8]) {
    if let Ok(picture) = crate::texture::image::decode(bytes, 64 << 20) {
        let texture = crate::texture::Texture::new(picture, crate::texture::ColorSpace::Srgb);
        let _ = texture.lookup(glam::Vec2::new(0.3, 0.7), 0.01);
    }
}

/// A USD layer (usda, usdc or usdz, told by its first bytes), written to a scratch file (the
/// crate opens layers by path) and read into objects, materials and lights within 256 MiB, then
/// read for the shot's camera.
/// The reader catches a panic of the USD crate's parser and reports a malformed layer; the
/// fuzzer's own panic hook (which aborts, a finding) is passed over for panics inside that
/// crate only, so what is fuzzed is the contract (rift returns, whatever the bytes) and any
/// panic in rift's own code is still found.
pub fn usd(bytes: &[u8]) {
    let extension = match bytes {
        [b'P', b'X', b'R', b'-', b'U', b'S', b'D', b'C', ..] => "usdc",
        [b'P', b'K', ..] => "usdz",
        _ => "usda",
    };
    let path =
        std::env::temp_dir().join(format!("rift-fuzz-usd-{}.{extension}", std::process::id()));
    if std::fs::write(&path, bytes).is_err() {
        return;
    }
    let layer = crate::scene::usd::Layer {
        path: &path,
        key: "usd[0]",
        shot_file: Path::new("fuzz.toml"),
        root: None,
        shot_camera: None,
    };
    let mut out = crate::scene::usd::Imported::default();
    let previous = std::sync::Arc::new(std::panic::take_hook());
    let outside = previous.clone();
    std::panic::set_hook(Box::new(move |info| {
        if !info
            .location()
            .is_some_and(|l| l.file().contains("/openusd-"))
        {
            outside(info);
        }
    }));
    let _ =
        crate::scene::usd::read_layer(&layer, (0.0, 24.0), [0.0, 0.02], Some(256 << 20), &mut out);
    // The same layer as the shot's camera (the test set's, `/World/ShotCam`).
    let shot = format!(
        "[shot]\nname = \"fuzz\"\nfps = 24.0\nframes = [1, 2]\n[camera]\nresolution = [8, 8]\n\
         usd = \"/World/ShotCam\"\n[[usd]]\nfile = {:?}\n",
        path.display().to_string()
    );
    if let Ok(mut shot) = rift_fx::Shot::parse(&shot, Path::new("fuzz.toml")) {
        let _ = crate::scene::usd::camera::read_camera(&mut shot, Some(256 << 20));
    }
    let _ = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| previous(info)));
    let _ = std::fs::remove_file(&path);
}
