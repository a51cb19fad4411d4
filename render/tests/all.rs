//! The renderer's integration tests, one module per file beside this one, built as one test
//! binary (one link of the renderer instead of one a file). `fuzz_smoke.rs` stays a binary of its
//! own: it waits for the fuzz targets' background build, and runs after this one. Run one file's
//! tests with `cargo -p rift-render test --release --test all through::`.

mod common;

mod analytic;
mod bounce_guide;
mod branches;
mod deforming;
mod grid_media;
mod guides;
mod light_guide;
mod lights;
mod media;
mod motion;
mod portals;
mod recursion;
mod ring_edge;
mod shading_normals;
mod stereo;
mod strands;
mod textures;
mod through;
mod touching;
mod visibility;
