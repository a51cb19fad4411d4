"""Checks the shot stage `rift fx` writes against rift's own output, with Pixar's usd-core:

- the stage's camera at each frame's shutter open equals the inverse of the worldToCamera matrix
  `rift render` wrote into that frame's EXR (within 1e-6; the EXR holds single precision);
- each opening's transform at each frame equals the one in that frame's own .usda (within 1e-9);
- each ring's curves at each frame are that frame's file's, and they move from frame to frame.

    python3 tests/support/usd_stage_check.py STAGE.usda EXR_PATTERN SHUTTER_OPEN FRAME [...]

EXR_PATTERN has a `{frame}` field; SHUTTER_OPEN is in frames (such as -0.25). Exits non-zero on
any difference.
"""
import sys

import numpy as np
import OpenEXR
from pxr import Usd, UsdGeom


def matrix(gf):
    return np.array([[gf[i][j] for j in range(4)] for i in range(4)])


def main(stage_path, exr_pattern, shutter_open, frames):
    problems = []
    stage = Usd.Stage.Open(stage_path)
    name = stage.GetDefaultPrim().GetName()
    camera = UsdGeom.Xformable(stage.GetPrimAtPath(f"/{name}/camera"))
    if not camera or not stage.GetPrimAtPath(f"/{name}/camera").IsA(UsdGeom.Camera):
        return [f"no camera at /{name}/camera"]
    openings = [p for p in stage.GetDefaultPrim().GetChildren() if p.GetTypeName() == "Xform"]
    if not openings:
        problems.append("no opening Xforms")
    previous = {}
    for frame in frames:
        exr = OpenEXR.File(exr_pattern.format(frame=frame)).header()
        world_to_camera = np.array(exr["worldToCamera"], dtype=float).reshape(4, 4)
        at_open = camera.ComputeLocalToWorldTransform(frame + shutter_open)
        worst = np.abs(np.linalg.inv(matrix(at_open)) - world_to_camera).max()
        print(f"frame {frame}: camera differs from the EXR's by {worst:.2e}")
        if worst > 1e-6:
            problems.append(f"frame {frame}: camera differs from the EXR's by {worst}")
        frame_file = stage_path.replace(f"{name}.usda", f"{name}.{frame:04d}.usda")
        own = Usd.Stage.Open(frame_file)
        for opening in openings:
            path = opening.GetPath()
            mine = UsdGeom.Xformable(opening).ComputeLocalToWorldTransform(frame)
            ring = stage.GetPrimAtPath(path.AppendChild("ring"))
            if not ring:
                continue
            theirs = UsdGeom.Xformable(own.GetPrimAtPath(path)).ComputeLocalToWorldTransform(frame)
            worst = np.abs(matrix(mine) - matrix(theirs)).max()
            if worst > 1e-9:
                problems.append(f"frame {frame}: {path} differs from its frame file by {worst}")
            points = np.array(UsdGeom.BasisCurves(ring).GetPointsAttr().Get(frame))
            counts = list(UsdGeom.BasisCurves(ring).GetCurveVertexCountsAttr().Get(frame))
            own_curves = UsdGeom.BasisCurves(own.GetPrimAtPath(path.AppendChild("ring")))
            if counts != list(own_curves.GetCurveVertexCountsAttr().Get(frame)) or not np.array_equal(
                points, np.array(own_curves.GetPointsAttr().Get(frame))
            ):
                problems.append(f"frame {frame}: {path}/ring is not its frame file's")
            if path in previous and previous[path].shape == points.shape and np.array_equal(previous[path], points):
                problems.append(f"frame {frame}: {path}/ring did not move")
            previous[path] = points
    return problems


if __name__ == "__main__":
    if len(sys.argv) < 5:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    found = main(sys.argv[1], sys.argv[2], float(sys.argv[3]), [int(f) for f in sys.argv[4:]])
    for p in found:
        print("problem:", p)
    sys.exit(1 if found else 0)
