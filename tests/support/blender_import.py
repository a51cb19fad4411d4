"""Imports a USD stage with Blender's importer (pip `bpy`) and checks that its curves play as an
animation: at each frame every imported curves object has points, and they move from frame to
frame. Prints one line per frame and object; exits non-zero on a problem.

    python3 tests/support/blender_import.py STAGE.usda FRAME [...]
"""
import sys

import bpy


def main(path, frames):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if bpy.ops.wm.usd_import(filepath=path) != {"FINISHED"}:
        return ["the importer failed"]
    scene = bpy.context.scene
    curves = [ob for ob in bpy.data.objects if ob.type == "CURVES"]
    if not curves:
        return ["no curves objects imported"]
    problems = []
    last = {}
    for frame in frames:
        scene.frame_set(frame)
        graph = bpy.context.evaluated_depsgraph_get()
        for ob in curves:
            data = ob.evaluated_get(graph).data
            position = data.attributes.get("position")
            if position is None or len(position.data) == 0:
                problems.append(f"frame {frame}: {ob.name} has no points")
                continue
            first = tuple(position.data[0].vector)
            print(f"frame {frame}: {ob.name}: {len(data.points)} points in {len(data.curves)} curves, first at {first}")
            if last.get(ob.name) == first:
                problems.append(f"frame {frame}: {ob.name} did not move")
            last[ob.name] = first
    return problems


if __name__ == "__main__":
    found = main(sys.argv[1], [int(f) for f in sys.argv[2:]])
    for p in found:
        print("problem:", p)
    sys.exit(1 if found else 0)
