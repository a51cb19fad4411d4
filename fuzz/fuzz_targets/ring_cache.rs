#![no_main]
//! Fuzz target `ring_cache`: see `rift_render::untrusted`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| rift_render::untrusted::ring_cache(data));
