#!/usr/bin/env python3
"""Instructions a camera path costs, by stage and by function, counted by callgrind: a measure
that does not move with the load of a shared machine, so two versions of the code compare in
one run each with no alternation. On the render core time follows it (about three
instructions a cycle on the Cornell box: the profile-guided build runs 12% fewer there and
takes 10% less time than one built without the profile), but not where memory decides (big
trees, strands) or a chain of divisions and square roots waits: confirm a gain with
`farm-bench --vs`.

    python3 tools/instructions_per_path.py [SHOT] [--spp N] [--frame F] [--res W H]
        [--rift BINARY] [--vs BINARY] [--top N]

The shot renders on one thread under `valgrind --tool=callgrind` (about fifty times slower
than native: keep it small, the default is the Cornell box at 4 spp). Every function's own
instructions (what it runs itself, with whatever the compiler inlined into it) are summed
into stages by name and divided by the camera paths (pixels x samples); set-up (loading,
building trees, baking rings), writing the image and the rest (library copies, allocation
and iterators, mostly gathering the image's channels) are reported whole, since they hardly
grow with the samples. A shot whose light selection is learned traces its training paths
through the same functions before rendering (160 pixels across, 4 samples each): they count
in the per-path figures, a large share of a small render, so compare builds at the same
settings. `--vs` counts a second build the same way and prints the ratios.

Needs valgrind (Debian: `apt-get install valgrind`) and a release build.
"""
import argparse
import re
import subprocess
import sys
import tempfile
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

# Stages by a function's name, first match wins. Functions the compiler inlined are counted
# in the one they were inlined into: `integrator::trace` holds the BSDFs and the light
# sample's arrival, `Accel::intersect` the triangle tests.
R = "rift_render::"
STAGES = [
    ("writing the image", ("miniz", "exr::", "png::", "deflate", "crc32", "adler")),
    # Building trees before the ray queries, whose modules hold the builders too.
    ("set-up", ("obvhs", "clap", "toml", "tobj", "serde", "noise::", "rift_fx::", "::build",
                "light_guide::train", "huge_pages")),
    ("ray queries", (R + "geometry::", "Scene::intersect", "Scene::occluded", "cpu::run_avx2")),
    ("openings", (R + "portal::", R + "mask::", R + "aperture", R + "opening")),
    ("light selection", (R + "lights::", R + "light_tree::", R + "light_guide::")),
    ("integrator", (R + "integrator::", R + "material::", R + "microfacet::",
                    R + "multiscatter::", R + "through::", R + "medium::", R + "volumes::",
                    R + "voxels::", R + "grid_medium::", R + "environment::")),
    ("sample numbers", (R + "sampling::", R + "sobol::")),
    ("pixel loop and film", (R + "render::", R + "film::", R + "camera::", R + "cryptomatte::",
                             "call_mut")),
    # The rest of the scene module is loading it.
    ("set-up", (R + "scene::",)),
]
PER_PATH = [name for name, _ in STAGES if name not in ("writing the image", "set-up")]


def stage_of(function):
    for name, keys in STAGES:
        if any(key in function for key in keys):
            return name
    return "other"


def self_costs(callgrind_out):
    """Each function's own instructions, from a callgrind output file."""
    costs = Counter()
    names = {}
    function = None
    after_call = False
    with open(callgrind_out) as f:
        for line in f:
            if line.startswith(("fn=", "cfn=")):
                # A name is given once, with its number, wherever it first appears (a
                # function or a callee); later lines give the number alone.
                m = re.match(r"c?fn=\((\d+)\)(?: (.*))?", line.rstrip("\n"))
                if m and m.group(2):
                    names[m.group(1)] = m.group(2)
                if line.startswith("fn="):
                    function = names.get(m.group(1), m.group(1)) if m else line[3:].rstrip()
            elif line.startswith("calls="):
                # The next cost line is what the call cost, already counted in the callee.
                after_call = True
            elif line[:1].isdigit() or line[:1] in "+-*":
                if after_call:
                    after_call = False
                    continue
                fields = line.split()
                if len(fields) >= 2 and function is not None:
                    costs[function] += int(fields[1])
    return costs


def count(rift, args, tmp):
    """(camera paths, own instructions by function) for one build."""
    out = Path(tmp) / "callgrind.out"
    command = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", rift, "render",
               args.shot, "-o", str(Path(tmp) / "image.exr"), "--spp", str(args.spp),
               "--threads", "1"]
    if args.frame is not None:
        command += ["--frame", str(args.frame)]
    if args.res:
        command += ["--res", str(args.res[0]), str(args.res[1])]
    try:
        done = subprocess.run(command, check=True, capture_output=True, text=True)
    except FileNotFoundError:
        sys.exit("tools/instructions_per_path.py: valgrind is not installed "
                 "(Debian: apt-get install valgrind)")
    except subprocess.CalledProcessError as failed:
        sys.exit(f"tools/instructions_per_path.py: {rift} render failed:\n{failed.stderr}")
    frames = re.findall(r"(\d+)x(\d+) at ([0-9.]+) spp", done.stdout + done.stderr)
    if not frames:
        sys.exit(f"tools/instructions_per_path.py: {rift} did not report its frame size")
    paths = sum(int(w) * int(h) * float(spp) for w, h, spp in frames)
    return paths, self_costs(out)


def by_stage(costs):
    stages = Counter()
    for function, n in costs.items():
        stages[stage_of(function)] += n
    return stages


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("shot", nargs="?", default=str(ROOT / "examples/cornell.toml"))
    parser.add_argument("--spp", type=int, default=4)
    parser.add_argument("--frame", type=int)
    parser.add_argument("--res", type=int, nargs=2, metavar=("W", "H"))
    parser.add_argument("--rift", default=str(ROOT / "target/release/rift"))
    parser.add_argument("--vs", help="a second build, counted the same way")
    parser.add_argument("--top", type=int, default=12, help="functions listed")
    args = parser.parse_args()
    if args.spp < 1:
        parser.error("--spp: expected 1 or more")
    builds = [args.rift] + ([args.vs] if args.vs else [])
    counted = {}
    with tempfile.TemporaryDirectory() as tmp:
        for rift in builds:
            counted[rift] = count(rift, args, tmp)

    names = "AB"
    print(f"{args.shot}, {args.spp} spp, one thread: instructions a camera path")
    for name, rift in zip(names, builds):
        print(f"  {name}: {rift}")
    print(f"{'':<24}" + "".join(f"{name:>14}" for name in names[:len(builds)])
          + (f"{'B/A':>8}" if args.vs else ""))

    def cells(values, scale, digits=0):
        text = "".join(f"{v / scale:>14,.{digits}f}" for v in values)
        if args.vs:
            text += f"{values[1] / values[0]:>8.3f}" if values[0] >= 1 else f"{'':>8}"
        return text

    stages = {b: by_stage(counted[b][1]) for b in builds}
    paths = {b: counted[b][0] for b in builds}
    for name in PER_PATH:
        print(f"{name:<24}" + cells([stages[b][name] / paths[b] for b in builds], 1))
    total = [sum(stages[b][n] for n in PER_PATH) / paths[b] for b in builds]
    print(f"{'a camera path':<24}" + cells(total, 1))
    print("whole run, millions of instructions:")
    for name in ("set-up", "writing the image", "other"):
        print(f"{name:<24}" + cells([stages[b][name] for b in builds], 1e6, 1))
    print(f"the {args.top} costliest functions of A, instructions a path:")
    for function, _ in counted[builds[0]][1].most_common(args.top):
        values = [counted[b][1][function] / paths[b] for b in builds]
        print(f"{'':<24}" + cells(values, 1) + f"  {function[:90]}")


if __name__ == "__main__":
    main()
