#!/usr/bin/env bash
# Builds the fuzz targets for the test command's short runs (render/tests/fuzz_smoke.rs) and
# prints the folder that holds them. `tests/setup.sh` starts it in the background; the smoke
# test runs it again (then a check that all is built) and runs the targets itself.
#
# The instrumentation is the one `cargo fuzz build --dev --sanitizer none` gives (cargo-fuzz
# 0.13: libFuzzer's coverage counters, comparison tracing and stack depth, `--cfg fuzzing`, debug
# assertions), passed to cargo directly: installing cargo-fuzz on a fresh machine compiles some
# hundred crates (79 s of processor time on two cores, nearly a fifth of the smoke run's share),
# and the short runs need nothing else from it. Long campaigns use cargo-fuzz (docs/testing.md).
# The dev profile is fuzz/Cargo.toml's: rift's crates at opt-level 1, others unoptimised but
# glam and libFuzzer, no AddressSanitizer.
set -euo pipefail
cd "$(dirname "$0")"
host=$(rustc +nightly -vV | sed -n 's/^host: //p')
coverage=(-Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4
  -Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table
  -Cllvm-args=-sanitizer-coverage-trace-compares -Cllvm-args=-sanitizer-coverage-stack-depth
  -Cllvm-args=-simplifycfg-branch-fold-threshold=0)
# The target is named so that the flags reach the targets' code and not build scripts or
# procedural macros (cargo applies RUSTFLAGS to the host's own builds only without --target).
RUSTFLAGS="${coverage[*]} --cfg fuzzing -Cdebug-assertions" \
  cargo +nightly build --bins --target "$host" >&2
echo "$PWD/target/$host/debug"
