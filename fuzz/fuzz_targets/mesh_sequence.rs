#![no_main]
//! Fuzz target `mesh_sequence`: see `rift_render::untrusted`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| rift_render::untrusted::mesh_sequence(data));
