#!/usr/bin/env bash
# What the test suite needs beyond Rust: Python packages (Pixar's USD validators, the Open Job
# Description CLI) and, as root on Debian, Slurm and munge for the farm test, which starts a
# single-node cluster of its own (without them that one test is skipped, and says so).
set -euo pipefail
cd "$(dirname "$0")/.."
python3 -m pip install --quiet --disable-pip-version-check --root-user-action=ignore -r tests/requirements.txt
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null && ! command -v slurmctld >/dev/null; then
  { apt-get update -qq &&
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
      slurmctld slurmd slurm-client munge >/dev/null; } ||
    echo "tests/setup.sh: Slurm could not be installed; the Slurm farm test will be skipped" >&2
fi
