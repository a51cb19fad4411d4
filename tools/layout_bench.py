#!/usr/bin/env python3
"""The layout page's speed in headless Chromium (software WebGL), as issue 15 asks it measured:
frames drawn per second at 1280x720 for each preview depth, and the time from moving something
(a drag, through the page's API) to the redrawn view through the openings, and to the server's
answer. Medians over repeated page loads, each a fresh browser.

    python3 tools/layout_bench.py [SHOT] [--frame F] [--depths 0,1,4] [--repeats 5]

Needs what tests/setup.sh installs (Debian's chromium, tests/browser/node_modules) and a
release build (cargo build --release).
"""
import argparse
import json
import re
import statistics
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PAGE = ROOT / "tests/browser/layout.mjs"


def page(url, *args):
    out = subprocess.run(["node", str(PAGE), url, *args], capture_output=True, text=True,
                         check=True)
    return json.loads(out.stdout)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("shot", nargs="?", default=str(ROOT / "examples/shots/showcase.toml"))
    parser.add_argument("--frame", type=int, default=12)
    parser.add_argument("--depths", default="0,1,4")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    server = subprocess.Popen([str(ROOT / "target/release/rift"), "layout", args.shot,
                               "--port", "0", "--no-browser"], stdout=subprocess.PIPE, text=True)
    try:
        port = re.search(r"127\.0\.0\.1:(\d+)", server.stdout.readline()).group(1)
        base = f"http://127.0.0.1:{port}/?frame={args.frame}"
        print(f"rift layout {args.shot} frame {args.frame}, 1280x720, medians of {args.repeats}")
        print(f"{'depth':>6} {'fps':>8}   (each run)")
        for depth in [int(d) for d in args.depths.split(",")]:
            url = f"{base}&depth={depth}"
            runs = [page(url, "--fps")["fps"] for _ in range(args.repeats)]
            print(f"{depth:>6} {statistics.median(runs):>8.1f}   "
                  + " ".join(f"{r:.1f}" for r in runs))
        # Moving the camera (the view through the openings follows at the next frame drawn),
        # then an object through the edit API (drawn live, then answered by the server). The
        # edits are not saved.
        depth = max(int(d) for d in args.depths.split(","))
        camera, drawn, answered = [], [], []
        for k in range(args.repeats):
            x = 0.3 + 0.1 * k
            steps = json.dumps([
                ["setCamera", {"position": [x, 1.5, 1.0], "lookAt": [0.0, 1.4, -3.0]}],
                ["select", {"kind": "object", "name": "pillar"}],
                ["move", {"position": [-1.9 + 0.1 * k, 0.4, -1.4], "rotation": [0, 0, 0, 1],
                          "scale": 0.8}],
                ["revert"],
            ])
            results = page(f"{base}&depth={depth}", "--steps", steps)["results"]
            camera.append(results[0])
            drawn.append(results[2]["drawMs"])
            answered.append(results[2]["answerMs"])
        print(f"depth {depth}: camera moved to redrawn view {statistics.median(camera):.0f} ms; "
              f"object moved to redrawn view {statistics.median(drawn):.0f} ms, to the server's "
              f"answer (edited shot built and sent) {statistics.median(answered):.0f} ms")
    finally:
        server.terminate()
        server.wait()


if __name__ == "__main__":
    main()
