"""Checks the characters in the shot stage `rift fx` writes, with Pixar's usd-core: each named
deforming object is a Mesh of triangles whose points are sampled at every frame and at its
shutter's open and close, they move between frames, and at FRAME the original's points are its
mesh sequence's file there (within 1e-5) while its copy's are those points carried by the
opening's teleport OFFSET (x y z, a translation for the showcase's paired openings). Its
face-varying `primvars:normals` are sampled at the same times, and at FRAME are the file's
vertex normals at each corner (within 1e-3: rift keeps them packed), the copy's the same.

    python3 tests/support/usd_character_check.py STAGE.usda ORIGINAL COPY FRAME PLY OFFSET_X OFFSET_Y OFFSET_Z

Exits non-zero on any difference.
"""
import struct
import sys

import numpy as np
from pxr import Usd, UsdGeom


def ply_triangles(path, columns=("x", "y", "z")):
    """The corners of a binary PLY's triangles: each vertex's `columns` (float properties)."""
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode().splitlines()
    vertices = int(next(l for l in header if l.startswith("element vertex")).split()[2])
    faces = int(next(l for l in header if l.startswith("element face")).split()[2])
    props = [l.split()[2] for l in header if l.startswith("property float")]
    stride = 4 * len(props)
    v = np.frombuffer(data, dtype="<f4", count=vertices * len(props), offset=end)
    v = v.reshape(vertices, len(props))[:, [props.index(c) for c in columns]]
    offset = end + vertices * stride
    corners = []
    for i in range(faces):
        n, a, b, c = struct.unpack_from("<B3i", data, offset + 13 * i)
        corners += [v[a], v[b], v[c]]
    return np.array(corners)


def main(stage_path, original, copy, frame, ply, offset):
    problems = []
    stage = Usd.Stage.Open(stage_path)
    root = stage.GetDefaultPrim().GetPath()
    meshes = {}
    for name in (original, copy):
        prim = stage.GetPrimAtPath(root.AppendChild(name))
        if not prim or not prim.IsA(UsdGeom.Mesh):
            problems.append(f"no Mesh {name}")
            continue
        mesh = UsdGeom.Mesh(prim)
        counts = list(mesh.GetFaceVertexCountsAttr().Get())
        if set(counts) != {3}:
            problems.append(f"{name}: faces of {set(counts)} corners, expected triangles")
        times = mesh.GetPointsAttr().GetTimeSamples()
        expected = sorted({f + s for f in (frame - 1, frame, frame + 1) for s in (-0.25, 0.0, 0.25)})
        if [round(t, 6) for t in times] != expected:
            problems.append(f"{name}: points sampled at {times}, expected {expected}")
        indices = np.array(mesh.GetFaceVertexIndicesAttr().Get())
        # Every triangle's corners, as the sequence's file lists them.
        at = {t: np.array(mesh.GetPointsAttr().Get(t))[indices] for t in times}
        if np.array_equal(at[frame - 1], at[frame]):
            problems.append(f"{name}: points do not move from frame {frame - 1} to {frame}")
        normals = mesh.GetPrim().GetAttribute("primvars:normals")
        if [round(t, 6) for t in normals.GetTimeSamples()] != expected:
            problems.append(f"{name}: normals sampled at {normals.GetTimeSamples()}")
        if UsdGeom.Primvar(normals).GetInterpolation() != "faceVarying":
            problems.append(f"{name}: normals are not face-varying")
        meshes[name] = (at[frame], np.array(normals.Get(frame)))
        print(f"{name}: {len(counts)} triangles at {len(times)} times")
    if problems:
        return problems
    own = ply_triangles(ply)
    worst = np.abs(meshes[original][0] - own).max()
    print(f"{original} at frame {frame} differs from {ply} by {worst:.2e}")
    if worst > 1e-5:
        problems.append(f"{original} differs from its file by {worst}")
    worst = np.abs(meshes[copy][0] - (own + np.array(offset))).max()
    print(f"{copy} at frame {frame} differs from the carried file by {worst:.2e}")
    if worst > 1e-4:
        problems.append(f"{copy} is not the file carried through the opening ({worst})")
    own_normals = ply_triangles(ply, ("nx", "ny", "nz"))
    for name in (original, copy):
        worst = np.abs(meshes[name][1] - own_normals).max()
        print(f"{name}'s normals at frame {frame} differ from the file's by {worst:.2e}")
        if worst > 1e-3:
            problems.append(f"{name}'s normals differ from the file's by {worst}")
    return problems


if __name__ == "__main__":
    if len(sys.argv) != 9:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    a = sys.argv
    found = main(a[1], a[2], a[3], int(a[4]), a[5], [float(x) for x in a[6:9]])
    for p in found:
        print("problem:", p)
    sys.exit(1 if found else 0)
