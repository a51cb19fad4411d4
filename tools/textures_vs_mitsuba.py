#!/usr/bin/env python3
"""Textures, rift against Mitsuba 3 (its `bitmap` texture, bilinear, the same PNGs and UVs).

Four cases on a 4 x 4 m floor quad (UVs 0 to `repeat` across it), each rendered by both with
two seeds; the script prints, per case, the whole image's difference per channel and the
region (4 x 4 grid) furthest from Mitsuba's, both in per cent, with the noise (the two seeds'
spread as a standard error, rift's and Mitsuba's together):

rift renders each with its default filtering (trilinear in the mipmap, by the ray's footprint)
and with `filter = "bilinear"`, the filtering Mitsuba's bitmap has (the full image, the
pixel's samples doing the rest).

- plane: a diffuse floor with an sRGB colour map (a gradient under a coarse checker), under
  a sky map that varies with elevation;
- grazing: a fine black-and-white checker repeated 24 times, seen at grazing angles (rift
  filters by the ray's footprint in a mipmap, Mitsuba by supersampling the bilinear texture:
  the means must agree);
- roughness: a gold conductor whose roughness map holds 0.2 and 0.6 in halves (Mitsuba takes
  alpha = roughness^2 from its own map; rift's masking-shadowing set to Mitsuba's separable
  term);
- normal: a diffuse floor with a tangent-space normal map of round bumps under a sun
  (Mitsuba's `normalmap` BSDF and `directional` emitter; rift's `normal_map` and a distant
  light of angle 0).

    python3 tools/textures_vs_mitsuba.py --rift target/release/rift [--spp 256]

Needs `pip install mitsuba numpy OpenEXR`; the LLVM variant wants libLLVM 16 or newer.
"""
import argparse
import math
import os
import tempfile
import zlib
import struct
from pathlib import Path

import numpy as np

from bsdf_vs_mitsuba import METALS, regions, render_rift, write_sky
from cornell_vs_mitsuba import load_mitsuba

SIZE = 64
CAMERAS = {  # position, look_at, fov
    "plane": ([0.0, 3.0, 2.5], [0.0, 0.0, 0.0], 45.0),
    "grazing": ([0.0, 0.35, 2.0], [0.0, 0.0, -2.0], 40.0),
    "roughness": ([0.0, 2.0, 3.0], [0.0, 0.0, 0.0], 45.0),
    "normal": ([0.0, 3.0, 2.5], [0.0, 0.0, 0.0], 45.0),
}


def write_png(path, rgb):
    """An 8-bit RGB PNG of the uint8 array `rgb` (rows top first)."""
    h, w, _ = rgb.shape
    raw = b"".join(b"\x00" + rgb[y].tobytes() for y in range(h))
    chunk = lambda kind, data: (struct.pack(">I", len(data)) + kind + data
                                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))
    png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
           + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))
    Path(path).write_bytes(png)


def textures(out):
    """The cases' PNGs."""
    y, x = np.mgrid[0:128, 0:128]
    checker = ((x // 32 + y // 32) % 2).astype(float)
    colour = np.stack([0.2 + 0.7 * x / 127, 0.3 + 0.5 * y / 127, 0.6 - 0.4 * x / 127], -1)
    colour *= (0.55 + 0.45 * checker)[..., None]
    write_png(out / "plane.png", (colour * 255).round().astype(np.uint8))
    fine = ((np.mgrid[0:64, 0:64].sum(0) // 1) % 2 * 255).astype(np.uint8)
    write_png(out / "grazing.png", np.repeat(fine[..., None], 3, -1))
    left = np.zeros((32, 32), bool)
    left[:, :16] = True
    r = np.where(left, 0.2, 0.6)
    write_png(out / "roughness.png", np.repeat((r * 255).round().astype(np.uint8)[..., None], 3, -1))
    write_png(out / "alpha.png", np.repeat((r * r * 255).round().astype(np.uint8)[..., None], 3, -1))
    # Round bumps: the normal (-dh/du, -dh/dv, 1) of a height field of cosine domes, 4 x 4 over
    # the map; image rows run top first, and v = 0 is the bottom row.
    n = 128
    row, col = np.mgrid[0:n, 0:n]
    u, v = (col + 0.5) / n, 1 - (row + 0.5) / n
    k = 2 * math.pi * 4
    dh_du = -0.015 * k * np.sin(k * u) * np.cos(k * v)
    dh_dv = -0.015 * k * np.cos(k * u) * np.sin(k * v)
    normal = np.stack([-dh_du, -dh_dv, np.ones_like(u)], -1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    write_png(out / "normal.png", ((normal + 1) / 2 * 255).round().astype(np.uint8))


def floor_obj(path, repeat):
    r = repeat
    path.write_text(f"v -2 0 2\nv 2 0 2\nv 2 0 -2\nv -2 0 -2\nvt 0 0\nvt {r} 0\nvt {r} {r}\n"
                    f"vt 0 {r}\nvn 0 1 0\nf 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n")


REPEAT = {"plane": 1, "grazing": 24, "roughness": 1, "normal": 1}
SUN_TOWARDS = [0.6, 0.8, 0.3]  # towards the sun
SUN_IRRADIANCE = 3.0


def rift_shot(case, bilinear=False):
    p, l, fov = CAMERAS[case]
    materials = {
        "plane": 'type = "diffuse"\nreflectance = { texture = "plane.png" }',
        "grazing": 'type = "diffuse"\nreflectance = { texture = "grazing.png" }',
        "roughness": (f'type = "conductor"\nmetal = "gold"\nshadowing = "separable"\n'
                      'roughness = { texture = "roughness.png" }'),
        "normal": ('type = "diffuse"\nreflectance = [0.6, 0.6, 0.6]\n'
                   'normal_map = { texture = "normal.png" }'),
    }
    light = ('[environment]\nmap = "sky.exr"\n' if case != "normal" else
             f'[[light]]\nname = "sun"\ntype = "distant"\nintensity = {SUN_IRRADIANCE}\n'
             f'angle = 0.0\ntransform = {{ position = {SUN_TOWARDS}, look_at = [0.0, 0.0, 0.0] }}\n')
    return (f'[shot]\nname = "{case}"\nfps = 24.0\nframes = [1, 1]\nshutter = [0.0, 0.0]\n'
            f'[camera]\nresolution = [{SIZE}, {SIZE}]\nfov_degrees = {fov}\n'
            f'[camera.transform]\nposition = {p}\nlook_at = {l}\nup = [0.0, 1.0, 0.0]\n'
            f'[render]\nmax_bounces = 8\n{light}'
            f'[[material]]\nname = "floor"\n{materials[case]}\n'
            f'[[object]]\nname = "floor"\nmesh = "floor_{case}.obj"\nmaterial = "floor"\n'
            ).replace('.png" }', '.png", filter = "bilinear" }' if bilinear and case != "normal"
                      else '.png" }')


def mitsuba_scene(case, out, spp):
    import mitsuba as mi

    p, l, fov = CAMERAS[case]
    bitmap = lambda name, raw: {"type": "bitmap", "filename": str(out / name), "raw": raw,
                                "filter_type": "bilinear", "wrap_mode": "repeat"}
    eta, k = METALS["gold"]
    bsdf = {
        "plane": {"type": "diffuse", "reflectance": bitmap("plane.png", False)},
        "grazing": {"type": "diffuse", "reflectance": bitmap("grazing.png", False)},
        "roughness": {"type": "roughconductor", "distribution": "ggx", "sample_visible": True,
                      "eta": {"type": "rgb", "value": eta}, "k": {"type": "rgb", "value": k},
                      "alpha": bitmap("alpha.png", True)},
        "normal": {"type": "normalmap", "normalmap": bitmap("normal.png", True),
                   "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.6] * 3}}},
    }[case]
    scene = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 9},
        "sensor": {"type": "perspective", "fov": fov, "fov_axis": "x",
                   "to_world": mi.ScalarTransform4f().look_at(origin=p, target=l, up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": SIZE, "height": SIZE,
                            "rfilter": {"type": "box"}, "pixel_format": "rgb"},
                   "sampler": {"type": "independent", "sample_count": spp}},
        "floor": {"type": "obj", "filename": str(out / f"floor_{case}.obj"), "bsdf": bsdf},
    }
    if case == "normal":
        d = -np.array(SUN_TOWARDS) / np.linalg.norm(SUN_TOWARDS)
        scene["sun"] = {"type": "directional", "direction": d.tolist(),
                        "irradiance": {"type": "rgb", "value": [SUN_IRRADIANCE] * 3}}
    else:
        scene["sky"] = {"type": "envmap", "filename": str(out / "sky.exr")}
    return scene


def arguments(doc):
    """The comparison scripts' command line: rift's binary, samples per pixel, Mitsuba's
    variant, and the cases to run (all by default)."""
    ap = argparse.ArgumentParser(description=doc.split("\n")[0])
    ap.add_argument("--rift", default=str(Path(__file__).resolve().parent.parent
                                          / "target" / "release" / "rift"))
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--only", nargs="*")
    return ap.parse_args()


def main():
    args = arguments(__doc__)
    mi = load_mitsuba(args.variant)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        textures(out)
        write_sky(out / "sky.exr")
        print(f"textures, rift against Mitsuba 3.{mi.__version__.split('.', 1)[1]} "
              f"{args.variant}: {args.spp} spp x 2 seeds, {SIZE} x {SIZE}")
        print(f"{'case':<20} {'image %':>22} {'worst region %':>15} {'noise %':>8}")
        for case in CAMERAS:
            if args.only and case not in args.only:
                continue
            floor_obj(out / f"floor_{case}.obj", REPEAT[case])
            scene = mi.load_dict(mitsuba_scene(case, out, args.spp))
            mits = [np.asarray(mi.render(scene, seed=seed), dtype=np.float64)[..., :3]
                    for seed in (1, 2)]
            for filtering in (("trilinear", "bilinear") if case != "normal" else ("",)):
                shot = out / f"{case}_{filtering}.toml"
                shot.write_text(rift_shot(case, filtering == "bilinear"))
                rift = [render_rift(args.rift, shot, args.spp, seed, out)[0] for seed in (1, 2)]
                report(f"{case} {filtering}", rift, mits)


def report(name, rift, mits):
    """Prints the whole image's and the worst region's difference of the two seeds' means."""
    r, m = sum(rift) / 2, sum(mits) / 2
    image = (r.mean((0, 1)) / m.mean((0, 1)) - 1) * 100
    rr, mr = regions(r), regions(m)
    spread = lambda pair: np.abs(regions(pair[0]) - regions(pair[1])) / 2
    noise = np.sqrt(spread(rift) ** 2 + spread(mits) ** 2) / np.maximum(mr, 1e-6)
    rel = (rr - mr) / np.maximum(mr, 1e-6)
    lit = mr > 1e-3 * mr.max()
    i = np.unravel_index(np.argmax(np.where(lit, np.abs(rel) - 3 * noise, -1)), rel.shape)
    if os.environ.get("REGIONS"):
        print(np.round(rel.mean(-1) * 100, 2))
    print(f"{name:<20} {np.array2string(image, precision=2):>22} "
          f"{rel[i] * 100:>+14.2f}  {noise[i] * 100:>7.2f}", flush=True)

if __name__ == "__main__":
    main()
