#![no_main]
//! Fuzz target `ply_mesh`: see `rift_render::untrusted`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| rift_render::untrusted::ply_mesh(data));
