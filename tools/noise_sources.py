#!/usr/bin/env python3
"""Where a render's noise comes from: two renders of one shot with different seeds, split by
the EXR's light-group layers (`lightgroup.*`) and its `throughOpenings` / `notThroughOpenings`
AOVs, over the whole image and over pixel boxes.

    python3 tools/noise_sources.py A.exr B.exr [--box NAME X0 X1 Y0 Y1]... [--against C.exr D.exr]

For each layer it prints its share of the image's light, its share of the summed pixel
variance (what the bright pixels carry), and the median over pixels of its variance over the
image's (what the typical pixel carries, as issue 18's median noise measures it). A layer's
variance is its two seeds' squared difference over two.

`--against C D` also prints the noise of A and B measured against the mean of another pair
(the same shot rendered another way). A variant that changes the image (strand shadows off, a
light removed) changes the means the relative noise divides by; a brighter image then reads as
less noisy though its pixels vary as much. Compare against one mean.

Light groups come from `light_group` keys in the shot (on objects, the sky, and
`[portal.surface.strands]`). Needs the `openexr` and `numpy` Python packages.
"""
import argparse

import numpy as np
import OpenEXR

WEIGHTS = np.array([0.2126, 0.7152, 0.0722])
DARK = 1e-3


def layers(path):
    """The image and its light layers (first part), as luminance."""
    try:
        channels = OpenEXR.File(str(path)).parts[0].channels
    except RuntimeError as error:
        raise SystemExit(f"{path}: {error}")
    out = {}
    for name, channel in channels.items():
        pixels = channel.pixels
        light = name in ("RGBA", "RGB") or name.startswith("lightgroup.") \
            or name in ("throughOpenings", "notThroughOpenings")
        if light and pixels.ndim == 3 and pixels.shape[2] >= 3:
            out["image" if name in ("RGBA", "RGB") else name] = \
                pixels[..., :3].astype(np.float64) @ WEIGHTS
    if "image" not in out:
        raise SystemExit(f"{path}: no RGB or RGBA layer")
    return out


def report(a, b, region, label):
    image = (a["image"] + b["image"]) / 2
    lit = (image > DARK)[region]
    total = ((a["image"] - b["image"]) ** 2 / 2)[region][lit]
    mean = image[region][lit]
    if total.size == 0:
        print(f"{label}: no lit pixels")
        return
    relative = np.sqrt(total) / mean
    print(f"{label}: {total.size} lit pixels, mean {mean.mean():.4g}, "
          f"median relative standard deviation {np.median(relative) * 100:.2f}%")
    print(f"  {'layer':<24} {'light':>7} {'summed var':>11} {'median var':>11}")
    for name in sorted(a):
        if name == "image" or name not in b:
            continue
        part = ((a[name] + b[name]) / 2)[region][lit]
        var = ((a[name] - b[name]) ** 2 / 2)[region][lit]
        print(f"  {name:<24} {part.mean() / mean.mean():7.3f} {var.sum() / total.sum():11.3f} "
              f"{np.median(var / mean ** 2) / np.median(total / mean ** 2):11.3f}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("a")
    parser.add_argument("b")
    parser.add_argument("--box", nargs=5, action="append", default=[],
                        metavar=("NAME", "X0", "X1", "Y0", "Y1"),
                        help="a pixel box to report on its own (x from X0 to X1, y from Y0 to Y1)")
    parser.add_argument("--against", nargs=2, metavar=("C", "D"),
                        help="also measure A and B's noise against this pair's mean")
    args = parser.parse_args()
    a, b = layers(args.a), layers(args.b)
    if a["image"].shape != b["image"].shape:
        raise SystemExit(f"{args.a} and {args.b} differ in size")
    report(a, b, (slice(None), slice(None)), "whole image")
    for name, *bounds in args.box:
        x0, x1, y0, y1 = (int(v) for v in bounds)
        report(a, b, (slice(y0, y1), slice(x0, x1)), f"box {name} ({x0}-{x1}, {y0}-{y1})")
    if args.against:
        c, d = layers(args.against[0]), layers(args.against[1])
        if c["image"].shape != a["image"].shape:
            raise SystemExit(f"{args.against[0]} differs in size from {args.a}")
        reference = (c["image"] + d["image"]) / 2
        lit = reference > DARK
        own = np.abs(a["image"] - b["image"])[lit] / np.sqrt(2)
        theirs = np.abs(c["image"] - d["image"])[lit] / np.sqrt(2)
        print(f"against {args.against[0]}'s mean: median relative standard deviation "
              f"{np.median(own / reference[lit]) * 100:.2f}% (theirs "
              f"{np.median(theirs / reference[lit]) * 100:.2f}%)")


if __name__ == "__main__":
    main()
