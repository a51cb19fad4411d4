#![no_main]
//! Fuzz target `exr_layer`: see `rift_render::untrusted`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| rift_render::untrusted::exr_layer(data));
