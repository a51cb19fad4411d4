"""Renders every example shot small and prints a checksum of each image's pixels, so a change
meant to keep every image (a restructure, a refactor) can be checked bit for bit:

    python3 tools/image_checksums.py [--rift target/release/rift] [--res 96 54] [--spp 4] > before.txt
    ... change ...
    python3 tools/image_checksums.py > after.txt && diff before.txt after.txt

Each shot renders at its first frame (and a middle one where it has more), both eyes of a stereo
shot, plus the Cornell box; the checksum covers every channel's pixels (beauty, AOVs, layers,
Cryptomatte) but not the header, whose render time changes from run to run. Needs OpenEXR
(tests/.venv has it: tests/.venv/bin/python3 tools/image_checksums.py).
"""

from pathlib import Path
import argparse
import hashlib
import subprocess
import sys
import tempfile

import OpenEXR

ROOT = Path(__file__).resolve().parent.parent


def frames_of(shot):
    """The first and middle frames of the shot's range (one when they coincide)."""
    for line in shot.read_text().splitlines():
        if line.startswith("frames = ["):
            first, last = (int(x) for x in line.split("[")[1].split("]")[0].split(","))
            return sorted({first, (first + last) // 2})
    sys.exit(f"{shot}: no `frames = [a, b]` line")


def pixels_digest(path):
    """SHA-256 over every channel's pixels of the EXR at `path`, channels in name order."""
    digest = hashlib.sha256()
    with OpenEXR.File(str(path), separate_channels=True) as f:
        for part in f.parts:
            for name in sorted(part.channels):
                digest.update(name.encode())
                digest.update(part.channels[name].pixels.tobytes())
    return digest.hexdigest()[:16]


def render(rift, shot, frame, extra, out_dir):
    """The EXR rift writes for `shot` at `frame` (named by rift: a stereo eye adds its name)."""
    out_dir.mkdir()
    args = [rift, "render", str(shot), "--frame", str(frame), "-o", str(out_dir / "image.exr")]
    run = subprocess.run(args + extra, capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"{' '.join(args + extra)} failed:\n{run.stderr}")
    (written,) = out_dir.glob("*.exr")
    return written


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--rift", default=str(ROOT / "target/release/rift"))
    p.add_argument("--res", nargs=2, default=["96", "54"])
    p.add_argument("--spp", default="4")
    a = p.parse_args()
    size = ["--res", *a.res, "--spp", a.spp, "--cryptomatte"]
    jobs = []
    for shot in sorted((ROOT / "examples/shots").glob("*.toml")):
        eyes = [["--eye", "left"], ["--eye", "right"]] if "[camera.stereo]" in shot.read_text() else [[]]
        for frame in frames_of(shot):
            jobs += [(shot, frame, size + eye) for eye in eyes]
    jobs.append((ROOT / "examples/cornell.toml", 1, ["--res", "64", "64", "--spp", a.spp]))
    with tempfile.TemporaryDirectory() as tmp:
        for i, (shot, frame, extra) in enumerate(jobs):
            out = render(a.rift, shot, frame, extra, Path(tmp) / str(i))
            label = " ".join([shot.name, str(frame)] + [x for x in extra if x in ("left", "right")])
            print(f"{pixels_digest(out)}  {label}", flush=True)


if __name__ == "__main__":
    main()
