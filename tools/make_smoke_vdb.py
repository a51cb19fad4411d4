"""Writes examples/assets/smoke.vdb, the smoke column of examples/shots/smoky_portal.toml.

A column of soft, billowing smoke (three octaves of smoothed value noise, thinned at its edges
and towards its top) as an OpenVDB half-float density grid, with OpenVDB's own writer from the
`bpy` wheel. 48 x 96 x 48 voxels of 2.5 cm: 1.2 m wide and 2.4 m tall, its base centred on the
origin. Deterministic (fixed seed).

Run from the project root:  python3 tools/make_smoke_vdb.py
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from make_vdb_fixtures import load_openvdb  # noqa: E402

SIZE = np.array([48, 96, 48])
VOXEL = 0.025


def smooth_noise(rng, cells, size):
    """Value noise: random values on a coarse lattice, trilinearly interpolated to `size`."""
    lattice = rng.random(tuple(cells + 2))
    axes = [np.linspace(0, cells[a], size[a]) for a in range(3)]
    i = [np.minimum(np.floor(ax).astype(int), cells[a] - 1) for a, ax in enumerate(axes)]
    f = [ax - ii for ax, ii in zip(axes, i)]
    out = np.zeros(tuple(size))
    for corner in range(8):
        d = [(corner >> 2) & 1, (corner >> 1) & 1, corner & 1]
        w = [np.where(d[a], f[a], 1 - f[a]) for a in range(3)]
        values = lattice[np.ix_(i[0] + d[0], i[1] + d[1], i[2] + d[2])]
        out += values * w[0][:, None, None] * w[1][None, :, None] * w[2][None, None, :]
    return out


def main():
    rng = np.random.default_rng(7)
    noise = sum(smooth_noise(rng, np.array([3, 6, 3]) * 2 ** o, SIZE) * 0.5 ** o
                for o in range(3)) / 1.75
    x, y, z = np.meshgrid(*[np.linspace(-1, 1, n) for n in SIZE], indexing="ij")
    height = (y + 1) / 2
    radius = np.sqrt(x ** 2 + z ** 2) / (0.45 + 0.45 * height)
    envelope = np.clip(1 - radius, 0, 1) * np.clip(1.2 - height, 0, 1) * np.clip(height * 8, 0, 1)
    density = np.clip((noise - 0.35) * 2.5, 0, None) * envelope
    density = (density / density.max()).astype(np.float32)
    vdb = load_openvdb()
    grid = vdb.FloatGrid()
    grid.name = "density"
    grid.copyFromArray(density, ijk=(-int(SIZE[0]) // 2, 0, -int(SIZE[2]) // 2), tolerance=1e-3)
    grid.transform = vdb.createLinearTransform(voxelSize=VOXEL)
    grid.saveFloatAsHalf = True
    out = os.path.join("examples", "assets", "smoke.vdb")
    vdb.write(out, grids=[grid])
    print(out, os.path.getsize(out), "bytes,", grid.activeVoxelCount(), "active voxels")


if __name__ == "__main__":
    main()
