#![no_main]
//! Fuzz target `texture`: see `rift_render::untrusted`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| rift_render::untrusted::texture(data));
