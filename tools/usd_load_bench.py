"""Load time and peak memory of a 10^6-triangle mesh read from a usdc stage against the same
mesh as a binary PLY: a grid of quads (the stage's faces are quads, triangulated on load; the
PLY's are the same triangles), rendered at 32x32 with one sample a pixel so the load dominates.
Runs of the two alternate; medians are printed.

    tests/.venv/bin/python3 tools/usd_load_bench.py [RIFT] [ROUNDS]
"""
import os
import statistics
import sys
import tempfile

import numpy as np
from timed_run import timed_run
from pxr import Usd, UsdGeom, Vt

RIFT = sys.argv[1] if len(sys.argv) > 1 else "target/release/rift"
ROUNDS = int(sys.argv[2]) if len(sys.argv) > 2 else 3
N = 708  # quads a side: 2 * 708^2 = 1.0e6 triangles

SHOT = """[shot]
name = "load"
fps = 24.0
frames = [1, 1]
[camera]
resolution = [32, 32]
fov_degrees = 60.0
[camera.transform]
position = [0.0, 2.0, 2.0]
look_at = [0.0, 0.0, 0.0]
[render]
spp = 1
[environment]
radiance = [1.0, 1.0, 1.0]
[[material]]
name = "grey"
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]
"""


def grid():
    xs = np.linspace(-1, 1, N + 1, dtype=np.float32)
    x, z = np.meshgrid(xs, xs)
    y = 0.05 * np.sin(7 * x) * np.cos(5 * z)
    points = np.stack([x.ravel(), y.ravel(), z.ravel()], -1).astype(np.float32)
    i = np.arange(N)
    a = (i[:, None] * (N + 1) + i[None, :]).ravel()
    quads = np.stack([a, a + N + 1, a + N + 2, a + 1], -1).astype(np.int32)
    return points, quads


def write(folder):
    points, quads = grid()
    stage = Usd.Stage.CreateNew(os.path.join(folder, "grid.usdc"))
    mesh = UsdGeom.Mesh.Define(stage, "/Grid")
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(quads), 4, np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(quads.ravel()))
    mesh.CreateSubdivisionSchemeAttr("none")
    stage.GetRootLayer().Save()
    tris = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    with open(os.path.join(folder, "grid.ply"), "wb") as f:
        f.write(f"ply\nformat binary_little_endian 1.0\nelement vertex {len(points)}\n"
                "property float x\nproperty float y\nproperty float z\n"
                f"element face {len(tris)}\nproperty list uchar int vertex_indices\nend_header\n".encode())
        f.write(points.tobytes())
        rows = np.zeros(len(tris), dtype=[("n", "u1"), ("v", "<i4", 3)])
        rows["n"], rows["v"] = 3, tris
        f.write(rows.tobytes())
    with open(os.path.join(folder, "usd.toml"), "w") as f:
        f.write(SHOT + '\n[[usd]]\nfile = "grid.usdc"\n')
    with open(os.path.join(folder, "ply.toml"), "w") as f:
        f.write(SHOT + '\n[[object]]\nname = "/Grid"\nmesh = "grid.ply"\nmaterial = "grey"\n')
    return len(tris)


with tempfile.TemporaryDirectory() as folder:
    triangles = write(folder)
    sizes = {k: os.path.getsize(os.path.join(folder, f"grid.{k}")) >> 20 for k in ("usdc", "ply")}
    times = {"usd": [], "ply": []}
    for _ in range(ROUNDS):
        for kind in ("usd", "ply"):
            times[kind].append(timed_run(RIFT, folder, f"{kind}.toml"))
    print(f"{triangles} triangles; usdc {sizes['usdc']} MiB, PLY {sizes['ply']} MiB; medians of {ROUNDS}, alternated")
    print("| input | wall s (load + 32x32 at 1 spp) | peak RSS MiB |")
    print("|---|---|---|")
    for kind in ("usd", "ply"):
        wall = statistics.median(t for t, _ in times[kind])
        rss = statistics.median(r for _, r in times[kind])
        print(f"| {kind} | {wall:.2f} | {rss:.0f} |")
