#!/usr/bin/env python3
"""A render's noise and time, as issue 18 measures the main job: the shot rendered with two
seeds, and the median over pixels of the relative standard deviation of a pixel's luminance
(|a - b| / sqrt(2), over the pair's mean; pixels darker than 1e-3 left out), with the wall-clock
seconds of each render. Extra arguments go to `rift render` (for example --spp 8, --res 640
360, --target-error 0.08, --time-limit 30).

    python3 tools/noise_two_seeds.py [SHOT] [--frame F] [--repeats N] [--rift BINARY]
        [--vs BINARY] [--target PERCENT] [-- RENDER ARGS...]

`--target 10.5` also reports the seconds a render would take to reach that noise: the set-up
(wall-clock less the render's own time, as rift reports it) plus the render time scaled by
(noise / target)^2, since the variance falls as one over the samples. `--vs` measures a second
build the same way, the two alternating seed pair by seed pair (seeds 1 and 2, then 3 and 4,
...) so that both see the same state of a shared machine; compare the medians and the ratios of
the pairs. Issue 18's figure is the showcase at 1280x720 and 8 spp, three pairs:

    python3 tools/noise_two_seeds.py --repeats 3 --target 10.5 --vs OLD_BUILD -- --spp 8

Needs a release build and the `openexr` and `numpy` Python packages.
"""
import argparse
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from images import read_rgb

ROOT = Path(__file__).resolve().parent.parent
RENDER_SECONDS = re.compile(r" in ([0-9.]+) s \(")


def luminance(path):
    return read_rgb(path) @ np.array([0.2126, 0.7152, 0.0722])


def render(rift, shot, frame, seed, out, extra):
    """Renders one seed: (wall-clock seconds, the render's own seconds as rift reports them)."""
    start = time.perf_counter()
    done = subprocess.run([rift, "render", shot, "--frame", str(frame),
                           "--seed", str(seed), "-o", str(out), *extra],
                          check=True, capture_output=True, text=True)
    wall = time.perf_counter() - start
    found = RENDER_SECONDS.findall(done.stdout + done.stderr)
    return wall, sum(map(float, found)) if found else wall


def measure_pair(rift, args, extra, seeds, tmp):
    """One seed pair: (noise, wall seconds a render, render seconds a render)."""
    outs = [Path(tmp) / f"seed{seed}.exr" for seed in seeds]
    times = [render(rift, args.shot, args.frame, seed, out, extra)
             for seed, out in zip(seeds, outs)]
    # A stereo shot writes each eye beside the name given: the left eye is measured.
    outs = [out if out.exists() else out.with_suffix(".left.exr") for out in outs]
    la, lb = (luminance(out) for out in outs)
    mean = (la + lb) / 2
    lit = mean > 1e-3
    noise = float(np.median(np.abs(la - lb)[lit] / np.sqrt(2) / mean[lit]))
    return noise, statistics.mean(t[0] for t in times), statistics.mean(t[1] for t in times)


def seconds_to(target, noise, wall, rendering):
    """What a render would take to reach `target` noise (a fraction)."""
    return (wall - rendering) + rendering * (noise / target) ** 2


def report(name, pairs, target):
    noise = [p[0] for p in pairs]
    wall = [p[1] for p in pairs]
    line = (f"{name}: median relative standard deviation {statistics.median(noise) * 100:.2f}% "
            f"({' '.join(f'{n * 100:.2f}' for n in noise)}); seconds a render "
            f"{statistics.median(wall):.1f} ({' '.join(f'{s:.1f}' for s in wall)})")
    if target is not None:
        to = [seconds_to(target, *p) for p in pairs]
        line += (f"; seconds to {target * 100:g}%: {statistics.median(to):.1f} "
                 f"({' '.join(f'{s:.1f}' for s in to)})")
    print(line)


def main():
    argv = sys.argv[1:]
    extra = argv[argv.index("--") + 1:] if "--" in argv else []
    argv = argv[:argv.index("--")] if "--" in argv else argv
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("shot", nargs="?", default=str(ROOT / "examples/shots/showcase.toml"))
    parser.add_argument("--frame", type=int, default=12)
    parser.add_argument("--repeats", type=int, default=1, help="seed pairs per build")
    parser.add_argument("--rift", default=str(ROOT / "target/release/rift"),
                        help="the rift binary to measure")
    parser.add_argument("--vs", help="a second rift binary, measured alternately with --rift")
    parser.add_argument("--target", type=float,
                        help="a noise level in percent: also report the seconds to reach it")
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error("--repeats: expected 1 or more")
    target = args.target / 100 if args.target is not None else None
    if target is not None and not target > 0:
        parser.error("--target: expected a noise level above 0 (in percent)")
    builds = [args.rift] + ([args.vs] if args.vs else [])
    pairs = {rift: [] for rift in builds}
    print(f"{args.shot} frame {args.frame} {' '.join(extra)}", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.repeats):
            for rift in builds:
                try:
                    pairs[rift].append(measure_pair(rift, args, extra, (2 * r + 1, 2 * r + 2), tmp))
                except subprocess.CalledProcessError as failed:
                    sys.exit(f"{rift} render failed:\n{failed.stderr}")
    for rift in builds:
        report(rift, pairs[rift], target)
    if args.vs and target is not None:
        ratios = [seconds_to(target, *a) / seconds_to(target, *b)
                  for a, b in zip(pairs[args.rift], pairs[args.vs])]
        print(f"seconds to {args.target:g}%, {args.rift} over {args.vs}, pair by pair: "
              f"{' '.join(f'{q:.3f}' for q in ratios)} (median {statistics.median(ratios):.3f})")


if __name__ == "__main__":
    main()
