#!/usr/bin/env bash
# The README's main job: frame 12 of the showcase (1280x720) to out/showcase.0012.exr and .png,
# at 16 samples a pixel denoised with Open Image Denoise, which makes it cleaner than 48 noisy
# samples in a third of the time (docs/rendering.md, Denoising). OIDN's official binaries come
# from PyPI (pyoidn, the version tests/requirements.txt names): the tests' environment's if
# tests/setup.sh has made it, else one of the job's own under target/, made on the first run;
# where that cannot be made (no network, no Python venv module),
# the job renders the shot's own 48 noisy samples instead, and says so. Arguments are passed
# on to `rift render` (`--frame 24`, `--res 640 360`); RIFT_BINARY runs that rift instead of
# building one with cargo (the tests give theirs).
set -euo pipefail
cd "$(dirname "$0")/.."
if [ -n "${RIFT_BINARY:-}" ]; then rift=("$RIFT_BINARY"); else rift=(cargo run --release --); fi
venv=target/oidn-venv
library() {
  for v in "$venv" tests/.venv; do
    compgen -G "$v/lib/python3*/site-packages/pyoidn/oidn/lib/libOpenImageDenoise.so.2" | head -n 1
  done | head -n 1
}
if [ -z "$(library)" ]; then
  rm -rf "$venv"
  mkdir -p target
  requirement=$(grep -i '^pyoidn' tests/requirements.txt)
  # Debian's python3 keeps venv's pip in a package of its own: as tests/setup.sh does, root
  # installs it and tries again.
  if ! python3 -m venv "$venv" >/dev/null 2>&1 && [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    rm -rf "$venv"
    { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
        --no-install-recommends python3-venv; } >&2 || true
  fi
  { { [ -x "$venv/bin/python3" ] || python3 -m venv "$venv"; } &&
    "$venv/bin/python3" -m pip install --quiet --disable-pip-version-check "$requirement"; } >&2 ||
    echo "main job: Open Image Denoise could not be installed (python3 -m venv and pip install $requirement)" >&2
fi
shot=examples/shots/showcase.toml
if [ -n "$(library)" ]; then
  RIFT_OIDN_LIBRARY="$(library)" exec "${rift[@]}" render "$shot" --frame 12 --png --spp 16 --denoise "$@"
fi
echo "main job: rendering without denoising, at the shot's 48 samples a pixel" >&2
exec "${rift[@]}" render "$shot" --frame 12 --png "$@"
