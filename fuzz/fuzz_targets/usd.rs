#![no_main]
//! Fuzz target `usd`: see `rift_render::untrusted`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| rift_render::untrusted::usd(data));
