#!/usr/bin/env bash
# Whether this processor runs what optimised builds target: x86-64-v3 (AVX2, FMA, BMI1/2, LZCNT,
# MOVBE, F16C), set in .cargo/config.toml. The `rift` binary refuses an older processor itself
# (src/processor.rs); the test binaries of the other crates would die with SIGILL and no word,
# so tests/setup.sh asks here first. Exits 1, naming the missing features and the build for any
# x86-64, when they are missing. Passes on other architectures, without a cpuinfo that lists
# flags, and when RUSTFLAGS is set: it replaces the config's flags, so that build targets the
# baseline unless it says otherwise.
#   tests/processor_check.sh [CPUINFO]   (default /proc/cpuinfo)
set -euo pipefail
cpuinfo=${1:-/proc/cpuinfo}
if [ "$(uname -m)" != x86_64 ] || [ ! -r "$cpuinfo" ] ||
  [ -n "${RUSTFLAGS:-}${CARGO_ENCODED_RUSTFLAGS:-}" ]; then
  exit 0
fi
# No flags line (some sandboxes' cpuinfo): nothing to judge by, so pass, as without the file.
line=$(grep -m1 '^flags' "$cpuinfo") || exit 0
flags=" ${line#*:} "
missing=""
# Linux's names: abm is LZCNT, xsave the state saving AVX needs.
for feature in avx avx2 bmi1 bmi2 fma f16c movbe abm popcnt sse4_2 xsave; do
  case "$flags" in
    *" $feature "*) ;;
    *) missing="$missing $feature" ;;
  esac
done
if [ -n "$missing" ]; then
  echo "tests/processor_check.sh: this processor lacks${missing}, which optimised builds" \
    "target (x86-64-v3, .cargo/config.toml). Build and test for any x86-64 instead:" \
    "RUSTFLAGS=\"-C target-cpu=x86-64\" cargo test --release --workspace" >&2
  exit 1
fi
