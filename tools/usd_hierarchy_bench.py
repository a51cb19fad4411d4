#!/usr/bin/env python3
"""Load time and peak memory of a stage of many small meshes under a hierarchy: 5,000 quads
(usdc) under one Xform that turns through three time samples around the frame, and the same
quads under six levels of Xforms, rendered at 32x32 with one sample a pixel so the load
dominates. Every quad's world transform composes its ancestors' at each time code rift reads
(and halfway between where the turn bends its path), so this measures how often ancestors are
read. With two binaries, their runs alternate; medians are printed.

    tests/.venv/bin/python3 tools/usd_hierarchy_bench.py [RIFT [RIFT_B]] [--rounds N]
"""
import argparse
import os
import statistics
import tempfile

from timed_run import timed_run
from pxr import Gf, Usd, UsdGeom

QUADS = 5000

SHOT = """[shot]
name = "hierarchy"
fps = 24.0
frames = [1, 1]
[camera]
resolution = [32, 32]
fov_degrees = 60.0
[camera.transform]
position = [0.0, 0.0, 20.0]
look_at = [0.0, 0.0, 0.0]
[render]
spp = 1
[environment]
radiance = [1.0, 1.0, 1.0]
"""


def write(folder, name, depth):
    """A stage of QUADS quads in a 70-wide grid under `depth` levels of Xforms, the top one
    turning a quarter a time code, and its shot file."""
    stage = Usd.Stage.CreateNew(os.path.join(folder, f"{name}.usdc"))
    stage.SetStartTimeCode(0)
    stage.SetEndTimeCode(2)
    parent = "/World"
    turn = UsdGeom.Xform.Define(stage, parent).AddRotateYOp()
    for code, angle in ((0, 0.0), (1, 90.0), (2, 180.0)):
        turn.Set(angle, code)
    for level in range(depth - 1):
        parent += f"/Level{level}"
        UsdGeom.Xform.Define(stage, parent).AddTranslateOp().Set(Gf.Vec3d(0.01, 0, 0))
    for i in range(QUADS):
        mesh = UsdGeom.Mesh.Define(stage, f"{parent}/Quad{i}")
        mesh.CreatePointsAttr([(0, 0, 0), (0.1, 0, 0), (0.1, 0.1, 0), (0, 0.1, 0)])
        mesh.CreateFaceVertexCountsAttr([4])
        mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
        mesh.AddTranslateOp().Set(Gf.Vec3d((i % 70) * 0.2 - 7, (i // 70) * 0.2 - 7, 0))
    stage.GetRootLayer().Save()
    with open(os.path.join(folder, f"{name}.toml"), "w") as f:
        f.write(SHOT + f'\n[[usd]]\nfile = "{name}.usdc"\n')


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("rift", nargs="*", default=["target/release/rift"])
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    stages = (("one level", "flat", 1), ("six levels", "deep", 6))
    with tempfile.TemporaryDirectory() as folder:
        for _, name, depth in stages:
            write(folder, name, depth)
        runs = {(rift, name): [] for rift in args.rift for _, name, _ in stages}
        for _ in range(args.rounds):
            for rift in args.rift:
                for _, name, _ in stages:
                    runs[(rift, name)].append(timed_run(rift, folder, f"{name}.toml"))
    print(f"{QUADS} quads under a turning Xform; medians of {args.rounds} rounds, alternated")
    print("| rift | stage | wall s (load + 32x32 at 1 spp) | peak RSS MiB |")
    print("|---|---|---|---|")
    for rift in args.rift:
        for label, name, _ in stages:
            wall = statistics.median(t for t, _ in runs[(rift, name)])
            rss = statistics.median(r for _, r in runs[(rift, name)])
            print(f"| {rift} | {label} | {wall:.2f} | {rss:.0f} |")


if __name__ == "__main__":
    main()
