#!/usr/bin/env bash
# What the test suite needs beyond Rust: Python packages (Pixar's USD validators, the Open Job
# Description CLI), Node packages for the browser tests (playwright-core, driving Debian's
# Chromium) and, as root on Debian, Slurm and munge for the farm test, which starts a
# single-node cluster of its own, and Chromium (without them those tests are skipped, and say
# so).
set -euo pipefail
cd "$(dirname "$0")/.."
# On a processor older than the optimised builds' target, say so before anything is built.
tests/processor_check.sh
python3 -m pip install --quiet --disable-pip-version-check --root-user-action=ignore -r tests/requirements.txt
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
