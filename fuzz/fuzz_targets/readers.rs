#![no_main]
//! Every reader in one binary, the one named by `RIFT_FUZZ_TARGET` (a name of
//! `rift_render::untrusted::TARGETS`): the test command's short fuzzing runs build this one
//! binary rather than one per reader. Long campaigns may use either:
//! `RIFT_FUZZ_TARGET=usd cargo +nightly fuzz run -O -a readers` or `cargo +nightly fuzz run -O -a usd`.

use rift_render::untrusted::{Reader, TARGETS};
use std::sync::OnceLock;

fn reader() -> Reader {
    static READER: OnceLock<Reader> = OnceLock::new();
    *READER.get_or_init(|| {
        let name = std::env::var("RIFT_FUZZ_TARGET").unwrap_or_default();
        let names: Vec<&str> = TARGETS.iter().map(|t| t.0).collect();
        match TARGETS.iter().find(|t| t.0 == name) {
            Some(&(_, reader)) => reader,
            None => panic!("set RIFT_FUZZ_TARGET to one of {names:?} (it is {name:?})"),
        }
    })
}

libfuzzer_sys::fuzz_target!(|data: &[u8]| reader()(data));
