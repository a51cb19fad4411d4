"""Memory and time of a PointInstancer of 10^5 instances (usdc) against the same stage with one
instance, and against the same 10^5 instances moving (their positions sampled at three time codes
around the frame, so each is keyed three times): the prototype is a wavy grid of 20,000 triangles, the instances a random field of
rotated, uniformly scaled copies on a plane, rendered at 64x64 with 4 samples a pixel. Shared
instances should cost their prototype's triangles once and a few hundred bytes each; as copies,
10^5 instances would be 2x10^9 triangles. Runs alternate; medians are printed.

    tests/.venv/bin/python3 tools/usd_instancer_bench.py [RIFT] [ROUNDS] [INSTANCES]
"""
import os
import statistics
import sys
import tempfile

import numpy as np
from timed_run import timed_run
from pxr import Gf, Usd, UsdGeom, Vt

RIFT = sys.argv[1] if len(sys.argv) > 1 else "target/release/rift"
ROUNDS = int(sys.argv[2]) if len(sys.argv) > 2 else 3
INSTANCES = int(sys.argv[3]) if len(sys.argv) > 3 else 100_000
N = 100  # quads a side of the prototype: 2 * 100^2 = 20,000 triangles

SHOT = """[shot]
name = "instances"
fps = 24.0
frames = [1, 1]
[camera]
resolution = [64, 64]
fov_degrees = 60.0
[camera.transform]
position = [0.0, 40.0, 60.0]
look_at = [0.0, 0.0, 0.0]
[render]
spp = 4
[environment]
radiance = [1.0, 1.0, 1.0]
"""


def prototype():
    xs = np.linspace(-0.5, 0.5, N + 1, dtype=np.float32)
    x, z = np.meshgrid(xs, xs)
    y = 0.1 * np.sin(9 * x) * np.cos(7 * z) + 0.2
    points = np.stack([x.ravel(), y.ravel(), z.ravel()], -1).astype(np.float32)
    i = np.arange(N)
    a = (i[:, None] * (N + 1) + i[None, :]).ravel()
    quads = np.stack([a, a + 1, a + N + 2, a + N + 1], -1).astype(np.int32)
    return points, quads


def write(folder, count, name, moving=False):
    stage = Usd.Stage.CreateNew(os.path.join(folder, name))
    pi = UsdGeom.PointInstancer.Define(stage, "/Field")
    mesh = UsdGeom.Mesh.Define(stage, "/Field/Prototypes/Tile")
    points, quads = prototype()
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(quads), 4, np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(quads.ravel()))
    mesh.CreateSubdivisionSchemeAttr("none")
    pi.CreatePrototypesRel().SetTargets([mesh.GetPath()])
    rng = np.random.default_rng(1)
    side = 60.0
    positions = np.zeros((count, 3), np.float32)
    positions[:, 0] = rng.uniform(-side, side, count)
    positions[:, 2] = rng.uniform(-side, side, count)
    angles = rng.uniform(0, np.pi, count)
    orientations = [Gf.Quath(float(np.cos(a)), Gf.Vec3h(0.0, float(np.sin(a)), 0.0)) for a in angles]
    scales = np.repeat(rng.uniform(0.5, 1.5, count)[:, None], 3, 1).astype(np.float32)
    pi.CreateProtoIndicesAttr(Vt.IntArray.FromNumpy(np.zeros(count, np.int32)))
    if moving:
        drift = np.zeros((count, 3), np.float32)
        drift[:, 0] = rng.uniform(-0.5, 0.5, count)
        attribute = pi.CreatePositionsAttr()
        for code in (0.0, 1.0, 2.0):
            attribute.Set(Vt.Vec3fArray.FromNumpy(positions + code * drift), code)
    else:
        pi.CreatePositionsAttr(Vt.Vec3fArray.FromNumpy(positions))
    pi.CreateOrientationsAttr(Vt.QuathArray(orientations))
    pi.CreateScalesAttr(Vt.Vec3fArray.FromNumpy(scales))
    stage.GetRootLayer().Save()
    with open(os.path.join(folder, name.replace(".usdc", ".toml")), "w") as f:
        f.write(SHOT + f'\n[[usd]]\nfile = "{name}"\n')
    return 2 * N * N


with tempfile.TemporaryDirectory() as folder:
    triangles = write(folder, 1, "one.usdc")
    write(folder, INSTANCES, "many.usdc")
    write(folder, INSTANCES, "moving.usdc", moving=True)
    size = os.path.getsize(os.path.join(folder, "many.usdc")) >> 20
    results = {"one": [], "many": [], "moving": []}
    for _ in range(ROUNDS):
        for kind in ("one", "many", "moving"):
            results[kind].append(timed_run(RIFT, folder, f"{kind}.toml"))
    print(f"prototype of {triangles} triangles; {INSTANCES} instances ({size} MiB usdc) against one;"
          f" as copies they would be {triangles * INSTANCES:.2e} triangles; medians of {ROUNDS}, alternated")
    print("| stage | wall s (load + 64x64 at 4 spp) | peak RSS MiB |")
    print("|---|---|---|")
    rss = {}
    for kind, label in (("one", "1 instance"), ("many", f"{INSTANCES} instances"),
                        ("moving", f"{INSTANCES} instances, positions at 3 time codes")):
        wall = statistics.median(t for t, _ in results[kind])
        rss[kind] = statistics.median(r for _, r in results[kind])
        print(f"| {label} | {wall:.2f} | {rss[kind]:.0f} |")
    print(f"per instance: {(rss['many'] - rss['one']) * 1048576 / INSTANCES:.0f} bytes; "
          f"moving: {(rss['moving'] - rss['one']) * 1048576 / INSTANCES:.0f} bytes")
