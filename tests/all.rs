//! The command-line program's integration tests, one module per file beside this one, built as
//! one test binary: each binary links the whole renderer, and one link instead of twenty-one
//! saves minutes of a fresh build. Run one file's tests with `cargo test --release --test all
//! cornell::` (its module name).

mod common;

mod bsdf_vs_mitsuba;
mod character;
mod checkpoint;
mod cli_fx;
mod cli_render;
mod cornell;
mod cryptomatte;
mod denoise;
mod docs;
mod farm;
mod fuzz_corpora;
mod golden;
mod layout;
mod light_groups;
mod merge;
mod module_graph;
mod pgo_wrapper;
mod processor_check;
mod python_env;
mod reveal;
mod set_assets;
mod usd;
mod usd_scenes;
