#!/usr/bin/env bash
# Makes the training profile that optimised builds use (pgo/rift.profdata, added to each rustc
# call by pgo/rustc-wrapper): builds rift instrumented, renders small versions of the example
# shots and runs the ray and strand benchmarks with it, and merges the counts. Run it after
# changing hot code (traversal, integrator, light selection, strands); functions changed since
# the last training simply go without profile data until then. Workspace crates rebuild on
# their own when the profile changes; `cargo clean --release` rebuilds the dependencies too.
# To compare two versions of the code fairly, build both without the profile
# (`RUSTC_WRAPPER= cargo build --release`, each in its own CARGO_TARGET_DIR) or train for each.
#
#   rustup component add llvm-tools   # once: llvm-profdata matching rustc's LLVM
#   tools/pgo_profile.sh
set -euo pipefail
cd "$(dirname "$0")/.."

profdata=$(find "$(rustc --print sysroot)/lib/rustlib" -name llvm-profdata -type f | head -n 1)
if [ -z "$profdata" ]; then
  echo "tools/pgo_profile.sh: no llvm-profdata for this rustc; run: rustup component add llvm-tools" >&2
  exit 1
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

echo "building rift instrumented (target/pgo-train)..."
# The instrumentation goes in as a config entry, which cargo joins to `.cargo/config.toml`'s
# flags (the x86-64-v3 target); RUSTFLAGS would replace them, and a profile trained on another
# target's code matches fewer functions.
CARGO_TARGET_DIR=target/pgo-train cargo build --release --quiet --bin rift \
  --config "target.'cfg(all())'.rustflags = ['-Cprofile-generate=$work/build']"
rift=target/pgo-train/release/rift

# Only the training runs' counts: the build scripts wrote theirs to $work/build.
export LLVM_PROFILE_FILE="$work/train/rift-%p-%m.profraw"
# A run's output is shown only when it fails.
quietly() {
  "$@" >"$work/log" 2>&1 || { cat "$work/log" >&2; echo "tools/pgo_profile.sh: failed: $*" >&2; exit 1; }
}
render() { quietly "$rift" render "$@" -o "$work/out.exr"; }
echo "training..."
# The Cornell box at 128 spp: how hot the plain loop looks against the other shots decides how
# the compiler treats it. At 32 spp the plain loop had been losing ground as heavier shots joined
# the training: the Cornell box took 14.32 s at 128 spp against 13.69 s with this weight and
# 13.38 s at 512 spp (medians of five alternated, 2 threads), and 512 cost the showcase 4%.
render examples/cornell.toml --spp 128
render examples/shots/showcase.toml --frame 12 --res 640 360 --spp 2
for shot in foggy_portal hall_of_mirrors lit_through ring_on_wall ring_wall; do
  render "examples/shots/$shot.toml" --res 240 135 --spp 8
done
render examples/shots/through_portal.toml --frame 12 --res 240 135 --spp 8
render examples/shots/textured_set.toml --res 240 135 --spp 8
render examples/shots/portal_pair.toml --frame 1001 --res 320 180 --spp 4
render examples/shots/heavy_rings.toml --frame 1001 --res 320 180 --spp 2
quietly "$rift" fx examples/shots/showcase.toml --frames 12 -o "$work/fx"
quietly "$rift" bench rays --cells 512 --rays 500000 --repeats 1
quietly "$rift" bench strands --strands 50 --segments 500 --rays 300000 --repeats 1

# Merged into a file beside it and renamed into place whole: a profile cut short by a failed or
# interrupted merge would stop every optimised build.
trap 'rm -rf "$work" pgo/rift.profdata.tmp' EXIT
"$profdata" merge --sparse -o pgo/rift.profdata.tmp "$work"/train/*.profraw
mv pgo/rift.profdata.tmp pgo/rift.profdata
echo "wrote pgo/rift.profdata ($(du -h pgo/rift.profdata | cut -f1))"
