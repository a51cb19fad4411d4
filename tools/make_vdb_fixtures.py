"""Writes the OpenVDB files rift's tests read (tests/data/vdb/), with OpenVDB's own writer.

OpenVDB's Python module ships inside Blender's `bpy` wheel (tests/requirements.txt installs
it); this script finds it there. The values follow closed forms that the Rust tests evaluate
again at every voxel, so the files need no sidecar data:

  puff(i, j, k)  = max(0, 1 - r / 8) * (0.75 + 0.25 sin(0.4 i)),  r = |(i, j, k) - (3, -2, 5)|
  slab           = 1 over x in [-8, 40), y in [-8, 24), z in [0, 16) (tiles and leaves)

Run from the project root:  python3 tools/make_vdb_fixtures.py
"""
import glob
import math
import os
import sys

import numpy as np


def load_openvdb():
    """OpenVDB's Python module, from inside Blender's bpy wheel."""
    import bpy  # loads the libraries the bundled openvdb module needs

    # bpy/4.5/scripts/modules/bpy/__init__.py -> bpy/4.5/python/lib/python3.x/site-packages
    version_dir = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(bpy.__file__))))
    sys.path += glob.glob(os.path.join(version_dir, "python", "lib", "python3*", "site-packages"))
    import openvdb

    return openvdb


OUT = os.path.join("tests", "data", "vdb")
CENTRE = np.array([3, -2, 5])


def puff_values():
    """The puff's voxels as (origin, dense array) over a box holding all of it."""
    lo = CENTRE - 9
    n = 19
    i, j, k = np.meshgrid(*[np.arange(lo[a], lo[a] + n) for a in range(3)], indexing="ij")
    r = np.sqrt((i - CENTRE[0]) ** 2 + (j - CENTRE[1]) ** 2 + (k - CENTRE[2]) ** 2)
    values = np.maximum(0.0, 1.0 - r / 8.0) * (0.75 + 0.25 * np.sin(0.4 * i))
    return lo, values.astype(np.float32)


def puff_grid(vdb, name="density", half=False):
    lo, values = puff_values()
    g = vdb.FloatGrid()
    g.name = name
    g.copyFromArray(values, ijk=tuple(int(x) for x in lo), tolerance=0.0)
    g.saveFloatAsHalf = half
    return g


def main():
    vdb = load_openvdb()
    os.makedirs(OUT, exist_ok=True)
    # Blosc (OpenVDB's default), float, voxels 5 cm from (1, 2, 3).
    g = puff_grid(vdb)
    g.transform = vdb.createLinearTransform(voxelSize=0.05)
    g.transform.postTranslate((1.0, 2.0, 3.0))
    vdb.write(os.path.join(OUT, "puff.vdb"), grids=[g])
    # Half precision, under a rotating affine map, beside other grids.
    h = puff_grid(vdb, half=True)
    c, s = math.cos(0.5), math.sin(0.5)
    h.transform = vdb.createLinearTransform(
        [[0.1 * c, 0.1 * s, 0, 0], [-0.1 * s, 0.1 * c, 0, 0], [0, 0, 0.2, 0], [0.5, 0, -1, 1]]
    )
    temperature = puff_grid(vdb, "temperature")
    velocity = vdb.Vec3SGrid()
    velocity.name = "vel"
    vdb.write(os.path.join(OUT, "puff_half.vdb"), grids=[temperature, h, velocity])
    # A slab of constant density: filled, so OpenVDB keeps tiles where it can.
    slab = vdb.FloatGrid()
    slab.name = "density"
    slab.fill((-8, -8, 0), (39, 23, 15), 1.0, True)
    slab.transform = vdb.createLinearTransform(voxelSize=0.25)
    vdb.write(os.path.join(OUT, "slab.vdb"), grids=[slab])
    for f in sorted(os.listdir(OUT)):
        print(f, os.path.getsize(os.path.join(OUT, f)), "bytes")


if __name__ == "__main__":
    main()
