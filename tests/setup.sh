#!/usr/bin/env bash
# What the test suite needs beyond Rust, each from the project's own lists:
# - Python packages (Pixar's USD library and validators, OpenEXR, the Open Job Description CLI,
#   Blender as a module) in a virtual environment of the suite's own, tests/.venv, made from
#   tests/requirements.txt alone: a package someone installed by hand elsewhere is never seen,
#   so a missing line fails here as it would on a fresh machine. Every test that runs Python
#   runs tests/.venv/bin/python3 (tests/common/mod.rs).
# - Node packages for the browser tests (playwright-core, driving Debian's Chromium), from the
#   lockfile in tests/browser.
# - As root on Debian: Slurm and munge for the farm test, which starts a single-node cluster of
#   its own, and Chromium (without them those tests are skipped, and say so).
set -euo pipefail
cd "$(dirname "$0")/.."
# On a processor older than the optimised builds' target, say so before anything is built.
tests/processor_check.sh

# The test command's build (`cargo test --release --workspace` builds exactly this), started in
# the background so that it runs while the packages below download and install (a minute or
# more on a fresh machine, mostly waiting on the network); the `cargo test` that follows waits
# for it on cargo's lock and finds everything built. Its log is target/setup-build.log; a
# failure shows again, in full, when `cargo test` builds.
mkdir -p target
cargo test --release --workspace --no-run </dev/null >target/setup-build.log 2>&1 &

venv=tests/.venv
# A virtual environment whose interpreter no longer runs (Python upgraded or moved) is made anew.
if [ -e "$venv" ] && ! "$venv/bin/python3" -c 'import sys' 2>/dev/null; then
  echo "tests/setup.sh: $venv no longer runs; making it again" >&2
  rm -rf "$venv"
fi
if [ ! -e "$venv" ]; then
  if ! python3 -m venv "$venv" 2>/dev/null; then
    rm -rf "$venv"
    # Debian's own python3 keeps venv and ensurepip in a package of their own.
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
      apt-get update -qq &&
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
          python3-venv >/dev/null
    fi
    python3 -m venv "$venv" || {
      echo "tests/setup.sh: python3 -m venv failed; install Python's venv module (Debian: apt-get install python3-venv)" >&2
      exit 1
    }
  fi
fi
"$venv/bin/python3" -m pip install --quiet --disable-pip-version-check -r tests/requirements.txt

if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null && ! command -v slurmctld >/dev/null; then
  { apt-get update -qq &&
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
      slurmctld slurmd slurm-client munge >/dev/null; } ||
    echo "tests/setup.sh: Slurm could not be installed; the Slurm farm test will be skipped" >&2
fi
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null && ! command -v chromium >/dev/null; then
  { apt-get update -qq &&
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
      chromium >/dev/null; } ||
    echo "tests/setup.sh: Chromium could not be installed; the browser tests will be skipped" >&2
fi
if command -v npm >/dev/null; then
  (cd tests/browser && npm ci --silent --no-audit --no-fund) ||
    echo "tests/setup.sh: npm ci failed; the browser tests will be skipped" >&2
fi

# The fuzz targets' build for the smoke test (render/tests/fuzz_smoke.rs runs the same script),
# started in the background at the lowest priority: it takes the processor time the main build
# and the tests leave idle, and the smoke test, among the last to run, waits for it. Its log is
# fuzz/target/smoke-build.log. Without the nightly toolchain the smoke test skips, and says so.
if cargo +nightly --version >/dev/null 2>&1; then
  mkdir -p fuzz/target
  # nice passes its priority on to cargo and every compiler it starts.
  nice -n 19 fuzz/build_smoke.sh </dev/null >fuzz/target/smoke-build.log 2>&1 &
fi
