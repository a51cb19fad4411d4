#!/usr/bin/env python3
"""A render's noise and time, as issue 18 measures the main job: the shot rendered with two
seeds, and the median over pixels of the relative standard deviation of a pixel's luminance
(|a - b| / sqrt(2), over the pair's mean; pixels darker than 1e-3 left out), with the wall-clock
seconds of each render. Extra arguments go to `rift render` (for example --spp 16, --res 640
360, --target-error 0.08, --time-limit 30).

    python3 tools/noise_two_seeds.py [SHOT] [--frame F] [--repeats N] [--rift BINARY] [-- RENDER ARGS...]

Needs a release build and the `openexr` and `numpy` Python packages.
"""
import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import OpenEXR

ROOT = Path(__file__).resolve().parent.parent


def luminance(path):
    channels = OpenEXR.File(str(path)).parts[0].channels
    rgb = next(channels[k].pixels for k in ("RGBA", "RGB") if k in channels)
    return rgb[..., :3].astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722])


def render(rift, shot, frame, seed, out, extra):
    start = time.perf_counter()
    subprocess.run([rift, "render", shot, "--frame", str(frame),
                    "--seed", str(seed), "-o", str(out), *extra],
                   check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - start


def main():
    argv = sys.argv[1:]
    extra = argv[argv.index("--") + 1:] if "--" in argv else []
    argv = argv[:argv.index("--")] if "--" in argv else argv
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("shot", nargs="?", default=str(ROOT / "examples/shots/showcase.toml"))
    parser.add_argument("--frame", type=int, default=12)
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--rift", default=str(ROOT / "target/release/rift"),
                        help="the rift binary to measure (to compare two builds)")
    args = parser.parse_args(argv)
    noise, seconds = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.repeats):
            a, b = Path(tmp) / "a.exr", Path(tmp) / "b.exr"
            seconds.append(render(args.rift, args.shot, args.frame, 2 * r + 1, a, extra))
            seconds.append(render(args.rift, args.shot, args.frame, 2 * r + 2, b, extra))
            la, lb = luminance(a), luminance(b)
            mean = (la + lb) / 2
            lit = mean > 1e-3
            relative = np.abs(la - lb)[lit] / np.sqrt(2) / mean[lit]
            noise.append(float(np.median(relative)))
    print(f"{args.shot} frame {args.frame} {' '.join(extra)}: median relative standard deviation "
          f"{statistics.median(noise) * 100:.2f}% ({' '.join(f'{n * 100:.2f}' for n in noise)}); "
          f"seconds a render {statistics.median(seconds):.1f} "
          f"({' '.join(f'{s:.1f}' for s in seconds)})")


if __name__ == "__main__":
    main()
