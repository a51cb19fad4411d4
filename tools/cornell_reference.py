#!/usr/bin/env python3
"""A Cornell box reference with many times the pack's samples. The pack's reference
(../shared/reference/cornell, Mitsuba, 16,384 samples a pixel) has noise of its own, relMSE
about 1.7e-5: a sixth of rift's error at 256 samples and most of it at 1024, so relMSE measured
against it understates every renderer that converges past it. This renders the same scene the
same way (Mitsuba 3's `cornell_box()`, the box filter, unlimited depth, as
`tools/cornell_vs_mitsuba.py` renders it) in chunks with seeds of their own, and after every
chunk writes their mean (float32 RGB EXR), so a run can stop at any time and still leave an
image. It prints the result's own noise (the chunks' spread: the regularised variance of their
mean, as relMSE weighs it), its mean against the pack's per channel, and the pack's noise as
this measures it (relMSE of the pack against the result, less the result's noise).

    python3 tools/cornell_reference.py [--minutes 40] [--chunk-spp 1024]
        [--out examples/cornell_reference.exr]

The `multijitter` sampler is unbiased and the most efficient of Mitsuba's here; chunks with
different seeds are independent, so the noise of their mean follows from their spread. Needs
`pip install mitsuba` (and libLLVM, as tools/cornell_vs_mitsuba.py says).
"""
import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

import host
from cornell_vs_mitsuba import PACK, ROOT, load_mitsuba, mitsuba_render
from images import read_rgb, rel_mse

FIRST_SEED = 1_000_000


def write_rgb(path, rgb):
    """`rgb` (float, height x width x 3) as a float32 RGB EXR, written beside and moved into
    place, so a stopped run never leaves half an image."""
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    part = Path(str(path) + ".part.exr")
    OpenEXR.File(header, {"RGB": np.ascontiguousarray(rgb, dtype=np.float32)}).write(str(part))
    os.replace(part, path)


def regularised_noise(chunks, mean):
    """relMSE's measure of the noise of the mean of `chunks`: the mean over pixels and channels
    of the variance of the mean (the chunks' sample variance over their count), over
    mean² + 0.01."""
    n = len(chunks)
    if n < 2:
        return float("inf")
    squares = sum((c - mean) ** 2 for c in chunks) / (n - 1)
    return float(np.mean(squares / n / (mean ** 2 + 0.01)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--minutes", type=float, default=40.0)
    ap.add_argument("--chunk-spp", type=int, default=1024)
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--out", default=str(ROOT / "examples" / "cornell_reference.exr"))
    args = ap.parse_args()

    mi = load_mitsuba(args.variant)
    import drjit as dr
    if args.variant.startswith("llvm"):
        dr.set_thread_count(args.threads)
    scene = mi.cornell_box()
    scene["sensor"]["film"]["rfilter"] = {"type": "box"}
    scene["sensor"]["sampler"] = {"type": "multijitter", "sample_count": args.chunk_spp}
    scene["integrator"] = {"type": "path", "max_depth": -1}
    built = mi.load_dict(scene)
    spp = built.sensors()[0].sampler().sample_count()
    pack = read_rgb(PACK / "reference.exr")
    print(f"Mitsuba {mi.__version__} {args.variant}, multijitter, {spp} spp a chunk, "
          f"{args.threads} threads; host: {host.describe()}", flush=True)

    chunks = []
    stop = time.monotonic() + 60 * args.minutes
    while time.monotonic() < stop:
        image, seconds = mitsuba_render(mi, built, spp, FIRST_SEED + len(chunks))
        chunks.append(image)
        mean = sum(chunks) / len(chunks)
        write_rgb(args.out, mean)
        noise = regularised_noise(chunks, mean)
        print(f"chunk {len(chunks)} ({seconds:.1f} s): {len(chunks) * spp} spp, own noise "
              f"{noise:.3e}", flush=True)

    if not chunks:
        sys.exit("tools/cornell_reference.py: no chunk finished within --minutes")
    against = (mean.mean((0, 1)) / pack.mean((0, 1)) - 1) * 100
    print(f"\n{args.out}: {len(chunks) * spp} spp, own noise (relMSE) {noise:.3e}")
    print(f"mean against the pack's reference (%): {np.round(against, 3)}")
    print(f"the pack's own noise as this measures it: {rel_mse(pack, mean) - noise:.3e}")


if __name__ == "__main__":
    main()
