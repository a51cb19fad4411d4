#!/usr/bin/env python3
"""rift's participating media against Mitsuba 3's volpath on the Cornell box filled with fog.

The Cornell reference pack (../shared/reference/cornell) in a homogeneous medium that fills the
scene: Mitsuba attaches it to the sensor and to both sides of every shape, rift declares it in
`[[medium]]`. With --grid, a heterogeneous puff instead (the OpenVDB fixture
tests/data/vdb/puff.vdb, scaled to 0.6 m across its radius, in the middle of the box): rift
reads the VDB file; Mitsuba gets the same voxels (the fixture's closed form, as
tools/make_vdb_fixtures.py writes them) as a trilinear gridvolume inside a null-BSDF cube. Both render with several seeds; the script prints per-channel means over the image
and over a 4 x 4 grid of regions, the difference rift - Mitsuba relative to Mitsuba, the noise
of that difference (from the spread over seeds), and each renderer's seconds and relMSE against the
other's mean, so efficiency can be compared. Exit status 1 when a region differs by more than
0.5% plus three times its noise.

    pip install mitsuba openexr numpy
    python3 tools/media_vs_mitsuba.py --rift target/release/rift --spp 256 --mitsuba-spp 1024
    python3 tools/media_vs_mitsuba.py --grid --variant scalar_rgb --sigma-t 8 --albedo 0.8
"""
import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import host
from images import read_rgb, rel_mse

ROOT = Path(__file__).resolve().parent.parent
PACK = ROOT.parent / "shared" / "reference" / "cornell"


PUFF = ROOT / "tests" / "data" / "vdb" / "puff.vdb"
# The puff's placement: its centre voxel (3, -2, 5), at (1.15, 1.9, 3.25) in the file, moved to
# PUFF_AT and scaled by PUFF_SCALE.
PUFF_SCALE = 1.5
PUFF_AT = np.array([0.0, -0.3, 0.0])
PUFF_POSITION = PUFF_AT - PUFF_SCALE * np.array([1.15, 1.9, 3.25])


def fog_keys(args):
    """The medium as rift's [[medium]] keys."""
    sigma_s = args.sigma_t * args.albedo
    sigma_a = args.sigma_t - sigma_s
    keys = (f'name = "fog"\nabsorption = [{sigma_a}, {sigma_a}, {sigma_a}]\n'
            f'scattering = [{sigma_s}, {sigma_s}, {sigma_s}]\nanisotropy = {args.g}\n')
    if args.grid:
        p = ", ".join(str(x) for x in PUFF_POSITION)
        keys += (f'vdb = "{PUFF}"\n'
                 f'transform = {{ position = [{p}], scale = {PUFF_SCALE} }}\n')
    return keys


def puff_volume(mi):
    """The puff's voxels and the map from Mitsuba's unit cube to the world: voxel centres at
    the texel centres, so trilinear lookups match rift's."""
    sys.path.insert(0, str(ROOT / "tools"))
    import make_vdb_fixtures as fixtures

    lo, values = fixtures.puff_values()  # values[i, j, k] at index lo + (i, j, k)
    n = np.array(values.shape)
    # Unit cube u -> index lo - 0.5 + n u -> file world 0.05 index + (1, 2, 3) -> placed.
    scale = PUFF_SCALE * 0.05 * n
    offset = PUFF_POSITION + PUFF_SCALE * (np.array([1.0, 2.0, 3.0]) + 0.05 * (lo - 0.5))
    to_world = mi.ScalarTransform4f.translate(offset.tolist()) @ mi.ScalarTransform4f.scale(
        scale.tolist())
    # Mitsuba's grids are indexed [z, y, x].
    grid = mi.VolumeGrid(np.ascontiguousarray(values.transpose(2, 1, 0))[..., None])
    return grid, to_world


def render_rift(args, tmp, seed):
    """rift on the pack plus the medium: (image H x W x 3, seconds)."""
    for name in ("cornell.obj", "cornell.mtl"):
        shutil.copy(ROOT / "examples" / name, tmp / name)
    shot = (ROOT / "examples" / "cornell.toml").read_text() + "\n[[medium]]\n" + fog_keys(args)
    (tmp / "fog.toml").write_text(shot)
    out = tmp / f"rift_{seed}.exr"
    t = time.perf_counter()
    subprocess.run([args.rift, "render", str(tmp / "fog.toml"), "-o", str(out), "--spp",
                    str(args.spp), "--seed", str(seed)], check=True, capture_output=True)
    return read_rgb(out), time.perf_counter() - t


def render_mitsuba(args, seed):
    """Mitsuba volpath on the same scene: (image H x W x 3, seconds)."""
    import mitsuba as mi

    mi.set_variant(args.variant)
    scene = mi.cornell_box()
    albedo = {"type": "rgb", "value": [args.albedo] * 3}
    phase = {"type": "hg", "g": args.g}
    if args.grid:
        grid, to_world = puff_volume(mi)
        scene["puff"] = {
            "type": "cube",
            "to_world": to_world @ mi.ScalarTransform4f.translate([0.5, 0.5, 0.5])
            @ mi.ScalarTransform4f.scale(0.5),
            "bsdf": {"type": "null"},
            "interior": {
                "type": "heterogeneous",
                "sigma_t": {"type": "gridvolume", "grid": grid, "to_world": to_world,
                            "filter_type": "trilinear"},
                "scale": args.sigma_t,
                "albedo": albedo,
                "phase": phase,
            },
        }
    else:
        scene["fog"] = {"type": "homogeneous", "sigma_t": args.sigma_t, "albedo": albedo,
                        "phase": phase}
        fog = {"type": "ref", "id": "fog"}
        for key, value in scene.items():
            if isinstance(value, dict) and value.get("type") in ("rectangle", "cube", "obj", "ply"):
                value["interior"] = fog
                value["exterior"] = fog
        scene["sensor"]["medium"] = fog
    scene["sensor"]["film"]["rfilter"] = {"type": "box"}
    scene["sensor"]["sampler"] = {"type": "independent", "sample_count": args.mitsuba_spp}
    scene["integrator"] = {"type": "volpath", "max_depth": -1}
    built = mi.load_dict(scene)
    t = time.perf_counter()
    image = mi.render(built, seed=seed)
    image = np.asarray(image, dtype=np.float64)[..., :3]
    return image, time.perf_counter() - t


def region_means(img, n=4):
    h, w, _ = img.shape
    return np.array([[img[i * h // n:(i + 1) * h // n, j * w // n:(j + 1) * w // n].mean((0, 1))
                      for j in range(n)] for i in range(n)])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rift", default=str(ROOT / "target" / "release" / "rift"))
    ap.add_argument("--spp", type=int, default=256, help="rift's samples per pixel")
    ap.add_argument("--mitsuba-spp", type=int, default=1024)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--sigma-t", type=float, default=0.25, help="extinction per metre")
    ap.add_argument("--albedo", type=float, default=0.8)
    ap.add_argument("--g", type=float, default=0.4, help="Henyey-Greenstein asymmetry")
    ap.add_argument("--seeds", type=int, default=4, help="renders per renderer (noise estimate)")
    ap.add_argument("--grid", action="store_true", help="a heterogeneous puff from a VDB file "
                    "instead of fog filling the box (sigma-t is then per unit density)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        runs = {"rift": [], "mitsuba": []}
        for seed in range(1, args.seeds + 1):
            runs["rift"].append(render_rift(args, tmp, seed))
            runs["mitsuba"].append(render_mitsuba(args, seed))
    means = {k: sum(img for img, _ in v) / len(v) for k, v in runs.items()}
    what = "a VDB puff" if args.grid else "fog"
    print(f"Cornell box with {what}: sigma_t {args.sigma_t}/m, albedo {args.albedo}, g {args.g}; "
          f"rift {args.spp} spp, Mitsuba {args.variant} volpath {args.mitsuba_spp} spp, "
          f"{args.seeds} seeds each")
    print(f"host: {host.describe()}")
    for who, pair in runs.items():
        other = means["mitsuba" if who == "rift" else "rift"]
        seconds = np.median([t for _, t in pair])
        print(f"  {who:<8} seconds (median) {seconds:7.2f}   image mean "
              f"{np.round(means[who].mean((0, 1)), 5)}   relMSE vs the other's mean "
              f"{rel_mse(pair[0][0], other):.3e}")
    failed = False
    grid = {k: region_means(v) for k, v in means.items()}
    # Noise of a region's mean difference: the standard errors of both renderers' means over
    # their seeds, combined.
    noise = np.zeros_like(grid["rift"])
    for renders in runs.values():
        regions = np.array([region_means(img) for img, _ in renders])
        noise += regions.var(axis=0, ddof=1) / len(renders)
    noise = np.sqrt(noise)
    whole = {k: v.mean((0, 1)) for k, v in means.items()}
    rel = (whole["rift"] - whole["mitsuba"]) / whole["mitsuba"]
    print(f"whole image: rift/mitsuba - 1 = {np.round(rel * 100, 3)} %")
    print("regions (row, col): rift/mitsuba - 1 in %, per channel, and noise in %")
    for i in range(4):
        for j in range(4):
            m = grid["mitsuba"][i, j]
            d = (grid["rift"][i, j] - m) / np.maximum(m, 1e-9)
            s = noise[i, j] / np.maximum(m, 1e-9)
            bad = np.any(np.abs(d) > 0.005 + 3 * s)
            failed |= bad
            print(f"  ({i},{j}) {np.round(d * 100, 2)} ± {np.round(s * 100, 2)}"
                  + ("   <- off" if bad else ""))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
