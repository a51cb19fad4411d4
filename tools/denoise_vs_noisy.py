#!/usr/bin/env python3
"""Denoised against noisy frames, error against time: a shot rendered at a few sample counts
with --denoise (its noisy beauty is the `noisy` layer of the same file) and without, each
compared with a converged render (relMSE with the usual 0.01 floor), with wall-clock seconds.
Also the mean absolute error in a band of pixels along the bright emitters' edges (the pixels
within two of one whose directly seen emission is above 1), denoised against noisy: edges a
denoiser must keep sharp. And, where the camera sees through an opening (portalDepth of the
converged render at least 0.99), the mean absolute error there and how much of the converged
image's fine detail survives: the energy of a 3x3 Laplacian against the converged render's,
1 when texture detail is kept, below 1 when smoothed away, above 1 when noise remains.

    tests/.venv/bin/python3 tools/denoise_vs_noisy.py SHOT [--frame F] [--crop x0,x1,y0,y1] [--res W H]
        [--spp 4,16,64] [--reference-spp 1024] [--rift BINARY]

RIFT_OIDN_LIBRARY must point at libOpenImageDenoise.so.2 unless the python3 on the path has
pyoidn (tests/setup.sh installs it in tests/.venv). The converged render is kept beside the
shot's name in the temporary folder only for the run.
"""
import argparse
import os
import subprocess
import tempfile
import time

import numpy as np
import OpenEXR

from images import rel_mse


def layer(path, name):
    channels = OpenEXR.File(path).channels()
    name = name.rstrip(".")
    group = channels.get(name) or channels.get(name + "A")
    return group.pixels[..., :3].astype(np.float64)


def render(rift, shot, out, spp, extra):
    started = time.perf_counter()
    subprocess.run([rift, "render", shot, "-o", out, "--spp", str(spp), *extra], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - started


def laplacian(image):
    luminance = image @ np.array([0.2126, 0.7152, 0.0722])
    return 4 * luminance - (np.roll(luminance, 1, 0) + np.roll(luminance, -1, 0)
                            + np.roll(luminance, 1, 1) + np.roll(luminance, -1, 1))


def through_region(path):
    channels = OpenEXR.File(path).channels()
    depth = channels.get("portalDepth")
    if depth is None:
        return None
    inside = depth.pixels.reshape(depth.pixels.shape[:2]) >= 0.99
    # Away from the image's border, where the Laplacian wraps round.
    inside[:1, :] = inside[-1:, :] = inside[:, :1] = inside[:, -1:] = False
    return inside if inside.any() else None


def through_metrics(image, reference, region):
    if region is None:
        return "-"
    error = float(np.abs(image - reference)[region].mean())
    detail = float(np.mean(laplacian(image)[region] ** 2) / np.mean(laplacian(reference)[region] ** 2))
    return f"{error:.4f} {detail:.2f}"


def edge_band(emission):
    bright = emission.max(-1) > 1.0
    band = np.zeros_like(bright)
    for dy in range(-2, 3):
        for dx in range(-2, 3):
            band |= np.roll(np.roll(bright, dy, 0), dx, 1)
    return band & ~bright


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("shot")
    parser.add_argument("--frame")
    parser.add_argument("--crop")
    parser.add_argument("--res", nargs=2)
    parser.add_argument("--spp", default="4,16,64")
    parser.add_argument("--reference-spp", type=int, default=1024)
    parser.add_argument("--rift", default=os.path.join(os.path.dirname(__file__), "../target/release/rift"))
    args = parser.parse_args()
    extra = (["--crop", args.crop] if args.crop else []) + (["--res", *args.res] if args.res else [])
    extra += ["--frame", args.frame] if args.frame else []
    with tempfile.TemporaryDirectory() as d:
        reference_file = os.path.join(d, "reference.exr")
        seconds = render(args.rift, args.shot, reference_file, args.reference_spp, extra)
        reference = layer(reference_file, "RGB")
        # The emission layer groups as "emission"; the beauty as "RGBA".
        band = edge_band(layer(reference_file, "emission."))
        region = through_region(reference_file)
        print(f"{args.shot}: reference {args.reference_spp} spp in {seconds:.1f} s; "
              f"edge band {band.sum()} pixels; through an opening "
              f"{0 if region is None else region.sum()} pixels")
        print("spp  noisy relMSE (s)    denoised relMSE (s)   4x spp noisy relMSE (s)   "
              "edge MAE noisy / denoised   through MAE detail: noisy / denoised / 4x")
        for spp in map(int, args.spp.split(",")):
            out = os.path.join(d, f"d{spp}.exr")
            t_denoised = render(args.rift, args.shot, out, spp, extra + ["--denoise"])
            noisy, denoised = layer(out, "noisy."), layer(out, "RGB")
            t_noisy = render(args.rift, args.shot, os.path.join(d, f"n{spp}.exr"), spp, extra)
            more = os.path.join(d, f"m{spp}.exr")
            t_more = render(args.rift, args.shot, more, 4 * spp, extra)
            edge = lambda image: float(np.abs(image - reference)[band].mean()) if band.any() else float("nan")
            print(f"{spp:4d}  {rel_mse(noisy, reference):.5f} ({t_noisy:5.1f})   "
                  f"{rel_mse(denoised, reference):.5f} ({t_denoised:5.1f})   "
                  f"{rel_mse(layer(more, 'RGB'), reference):.5f} ({t_more:5.1f})   "
                  f"{edge(noisy):.4f} / {edge(denoised):.4f}   "
                  f"{through_metrics(noisy, reference, region)} / "
                  f"{through_metrics(denoised, reference, region)} / "
                  f"{through_metrics(layer(more, 'RGB'), reference, region)}")


if __name__ == "__main__":
    main()
