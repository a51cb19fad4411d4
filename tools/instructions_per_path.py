#!/usr/bin/env python3
"""Instructions a camera path costs, by stage and by function, counted by callgrind: a measure
that does not move with the load of a shared machine, so two versions of the code compare in
one run each with no alternation. On the render core time follows it (about three
instructions a cycle on the Cornell box: the profile-guided build runs 12% fewer there and
takes 10% less time than one built without the profile), but not where memory decides (big
trees, strands) or a chain of divisions and square roots waits: confirm a gain with
`farm-bench --vs`.

    python3 tools/instructions_per_path.py [SHOT] [--spp N] [--frame F] [--res W H]
        [--rift BINARY] [--vs BINARY] [--top N] [--inlined FUNCTION [--depth D]]

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

Most of the render core is inlined into a few functions (`integrator::trace` holds the BSDFs,
light sampling and offsets), so `--inlined integrator::trace` also splits that function's own
instructions by the functions inlined into it, as a tree `--depth` levels deep (build A only):
callgrind counts each instruction and `addr2line -i` (binutils) names the inlined calls it
came from.

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


def self_costs(callgrind_out, by_address_of=None):
    """Each function's own instructions, from a callgrind output file; and, for the functions
    whose names end with `by_address_of`, their instructions by address (the output must
    then hold addresses: callgrind's `--dump-instr=yes`)."""
    costs = Counter()
    at_address = Counter()
    names = {}
    function = None
    after_call = False
    columns = ["line"]
    last = {}
    with open(callgrind_out) as f:
        for line in f:
            if line.startswith("positions:"):
                columns = line.split()[1:]
            elif line.startswith(("fn=", "cfn=")):
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
                fields = line.split()
                # Positions are absolute, or relative to the last cost line's ("+3", "-2",
                # "*" the same): followed even through the calls' lines.
                for column, field in zip(columns, fields):
                    last[column] = position(field, last.get(column, 0))
                if after_call:
                    after_call = False
                    continue
                if len(fields) > len(columns) and function is not None:
                    costs[function] += int(fields[len(columns)])
                    if by_address_of and function.endswith(by_address_of):
                        at_address[last["instr"]] += int(fields[len(columns)])
    return costs, at_address


def position(field, last):
    """A callgrind position: decimal or hexadecimal, absolute or relative to `last`."""
    if field == "*":
        return last
    if field[0] in "+-":
        return last + (1 if field[0] == "+" else -1) * int(field[1:], 0)
    return int(field, 0)


def inlined_tree(binary, at_address):
    """Instructions by inlined call path (outermost first, the function itself left out),
    from the addresses' inlining as `addr2line -i` reports it."""
    addresses = sorted(at_address)
    try:
        done = subprocess.run(["addr2line", "-e", binary, "-f", "-i", "-C", "-a"],
                              input="\n".join(hex(a) for a in addresses), check=True,
                              capture_output=True, text=True)
    except FileNotFoundError:
        sys.exit("tools/instructions_per_path.py: addr2line is not installed "
                 "(Debian: apt-get install binutils)")
    stacks = {}
    current = None
    for line in done.stdout.splitlines():
        if line.startswith("0x"):
            current = stacks.setdefault(int(line, 16), [])
        elif current is not None and not line.startswith(("/", "??")):
            current.append(short_name(line))
    tree = Counter()
    for address, n in at_address.items():
        path = []
        for name in reversed(stacks.get(address, [])):
            if not path or path[-1] != name:
                path.append(name)
        for depth in range(len(path)):
            tree[tuple(path[1:depth + 1])] += n
    return tree


def short_name(function):
    """`module::function` of a demangled name, without its generic arguments."""
    return "::".join(re.sub(r"<.*>", "", function).split("::")[-2:])


def count(rift, args, tmp):
    """(camera paths, own instructions by function, those of `--inlined` by address) for one
    build; the addresses only for build A."""
    out = Path(tmp) / "callgrind.out"
    dump = ["--dump-instr=yes"] if args.inlined and rift == args.rift else []
    command = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", *dump, rift,
               "render", args.shot, "-o", str(Path(tmp) / "image.exr"), "--spp", str(args.spp),
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
    return paths, *self_costs(out, args.inlined if dump else None)


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
    parser.add_argument("--inlined", metavar="FUNCTION",
                        help="split the own instructions of the function whose name ends so "
                             "(integrator::trace) by what is inlined into it")
    parser.add_argument("--depth", type=int, default=3, help="levels of the --inlined tree")
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
    at_address = counted[builds[0]][2]
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
    if args.inlined:
        print_inlined(args, inlined_tree(args.rift, at_address), paths[args.rift])


def print_inlined(args, tree, paths):
    """The --inlined tree, instructions a path, branches under 1% of the whole left out."""
    whole = tree[()]
    if not whole:
        sys.exit(f"tools/instructions_per_path.py: no function of A ends with {args.inlined}")
    print(f"inlined into {args.inlined} (A), instructions a path:")
    print(f"{whole / paths:>8,.0f}  {args.inlined}")

    def children(path, level):
        below = [(p, n) for p, n in tree.items() if len(p) == len(path) + 1 and p[:-1] == path]
        for p, n in sorted(below, key=lambda item: -item[1]):
            if n >= whole / 100:
                print(f"{n / paths:>8,.0f}  {'  ' * level}{p[-1]}")
                if level < args.depth:
                    children(p, level + 1)

    children((), 1)


if __name__ == "__main__":
    main()
