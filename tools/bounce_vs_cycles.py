"""Bounce light through an opening, rift against Cycles: `examples/shots/bounce_through.toml` (a
dark room lit only by light that bounced in a far room before it came through a window) rendered
by rift through its portal pair, with bounces aimed at openings on and off, and by Cycles (bpy)
from the same rooms joined in space, with path guiding on and off.

The pair maps the dark room's window onto the far room's by a translation (DESIGN.md's
T = P_T · P_H⁻¹ with the two frames half a turn apart), so the physical twin moves the far room
by that translation until the two windows coincide, and the two rooms share one wall in the
window's plane (3 cm in front of rift's walls), with the window's hole: plaster on the dark
room's side, sand on the far room's (a mix on Cycles' Backfacing). A ray through the hole goes on
into the other room as it does through the portal. (Two walls 6 cm apart, each transparent from
the other room, did not agree: Cycles' dark room came out far darker, its light pooled round the
hole; not looked into.) The panel is a
Cycles area light of the same radiance (Cycles' L = P / (A·π), checked against a directly seen
light) and the same one-sided emission; bounces are not cut short (Cycles 32, rift unlimited
with roulette), no denoising, no clamping, no adaptive sampling.

Efficiency is 1/(relMSE·s) over the camera's room (the pixels rift's reference records no
teleport for), each renderer against its own converged reference, relMSE as `rift bench`
measures it, seconds the wall time of a render (rift: the whole process, loading and training
included; Cycles: the render call, scene sync included). Medians of two seeds. The means of the
two references over the same pixels show that the two scenes are the same.

    tests/.venv/bin/python3 tools/bounce_vs_cycles.py [RIFT] [RIFT_SPP] [CYCLES_SPP] [CYCLES_REFERENCE_SPP]
"""
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
import OpenEXR

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RIFT = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "target/release/rift"))
RIFT_SPP = int(sys.argv[2]) if len(sys.argv) > 2 else 32
CYCLES_SPP = int(sys.argv[3]) if len(sys.argv) > 3 else 256
CYCLES_REFERENCE_SPP = int(sys.argv[4]) if len(sys.argv) > 4 else 8192
SHOT = os.path.join(ROOT, "examples/shots/bounce_through.toml")
WIDTH, HEIGHT = 160, 90
RIFT_REFERENCE_SPP = 2048
SEEDS = (1, 2)

# Run inside Blender's Python (bpy): builds the joined rooms and renders them with Cycles.
CYCLES = r'''
import json, math, os, sys, time
import bpy
import addon_utils  # importable once bpy has set up Blender's paths
from mathutils import Matrix

root, folder, plan = sys.argv[-3], sys.argv[-2], json.loads(sys.argv[-1])
addon_utils.enable("cycles", default_set=True)
bpy.ops.wm.read_factory_settings(use_empty=True)
s = bpy.context.scene
s.render.engine = "CYCLES"
c = s.cycles
c.device, c.use_adaptive_sampling, c.use_denoising = "CPU", False, False
c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = 32
c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
c.pixel_filter_type, c.filter_width = "BOX", 1.0  # rift's film: one-pixel box
s.render.resolution_x, s.render.resolution_y = plan["width"], plan["height"]
s.render.resolution_percentage = 100
s.view_settings.view_transform = "Standard"
s.render.image_settings.file_format = "OPEN_EXR"
s.render.image_settings.color_depth = "32"
s.world = bpy.data.worlds.new("black")
s.world.use_nodes = True
s.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0

# rift is +Y up, Blender +Z up.
Y_UP = Matrix.Rotation(math.pi / 2, 4, "X")
SHIFT = plan["shift"]  # the far room's translation onto the dark room's window


def material(name, front, back=None):
    """A diffuse surface; with `back`, another colour on its back (the side its normal points
    away from)."""
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nodes, links = m.node_tree.nodes, m.node_tree.links
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    sides = []
    for rgb in [front] + ([back] if back else []):
        diffuse = nodes.new("ShaderNodeBsdfDiffuse")
        diffuse.inputs["Color"].default_value = (*rgb, 1.0)
        sides.append(diffuse)
    if back is None:
        links.new(sides[0].outputs[0], out.inputs["Surface"])
        return m
    mix = nodes.new("ShaderNodeMixShader")
    links.new(nodes.new("ShaderNodeNewGeometry").outputs["Backfacing"], mix.inputs[0])
    links.new(sides[0].outputs[0], mix.inputs[1])
    links.new(sides[1].outputs[0], mix.inputs[2])
    links.new(mix.outputs[0], out.inputs["Surface"])
    return m


def quad(axis, at, a0, a1, b0, b1, facing):
    """The rectangle where coordinate `axis` is `at` and the other two (in x, y, z order) span
    [a0, a1] × [b0, b1], wound so that its normal points along `facing` (±1) on `axis`."""
    corners = [(a0, b0), (a1, b0), (a1, b1), (a0, b1)]
    points = []
    for a, b in corners:
        p = [a, b]
        p.insert(axis, at)
        points.append(tuple(p))
    # (a, b) counter-clockwise: the normal is +axis for x and z, -axis for y (y's other axes
    # are x, z, whose cross product is -y).
    sign = -1 if axis == 1 else 1
    return points if sign == facing else points[::-1]


def room(x0, x1):
    """A room of the examples' `room.obj` (3 m high, z in [-3, 3]) between x0 and x1 with its
    plain surfaces, the ones facing into it: floor, ceiling, back, front and the ceiling's
    1.2 m square fitting (the shot gives the whole mesh one material)."""
    mid = (x0 + x1) / 2
    return [quad(1, 0.0, x0, x1, -3, 3, +1), quad(1, 3.0, x0, x1, -3, 3, -1),
            quad(2, -3.0, x0, x1, 0, 3, +1), quad(2, 3.0, x0, x1, 0, 3, -1),
            quad(1, 2.99, mid - 0.6, mid + 0.6, -0.6, 0.6, -1)]


def wall_with_hole(x, hole):
    """The wall x = const between the rooms around the window's hole (z0, z1, y0, y1), its
    normal along +x (into the dark room)."""
    z0, z1, y0, y1 = hole
    rects = [(0, 3, -3, z0), (0, 3, z1, 3), (0, y0, z0, z1), (y1, 3, z0, z1)]
    return [quad(0, x, lo, hi, a, b, +1) for lo, hi, a, b in rects]


def obj_faces(path):
    """The faces of a rift example OBJ (`v` and `f` only)."""
    verts, faces = [], []
    for line in open(path):
        w = line.split()
        if w and w[0] == "v":
            verts.append(tuple(float(x) for x in w[1:4]))
        elif w and w[0] == "f":
            faces.append([verts[int(i.split("/")[0]) - 1] for i in w[1:]])
    return faces


def add_mesh(name, faces, mat, world):
    verts, polys = [], []
    for f in faces:
        polys.append(list(range(len(verts), len(verts) + len(f))))
        verts.extend(f)
    me = bpy.data.meshes.new(name)
    me.from_pydata(verts, [], polys)
    me.materials.append(mat)
    o = bpy.data.objects.new(name, me)
    o.matrix_world = Y_UP @ world
    s.collection.objects.link(o)


plaster, sand = (0.72, 0.7, 0.66), (0.78, 0.72, 0.6)
ident = Matrix.Identity(4)
wall = plan["wall"]  # the window's plane: the dark room's left wall, the far room's right
add_mesh("dark_room", room(wall, 3.0) + [quad(0, 3.0, 0, 3, -3, 3, -1)],
         material("plaster", plaster), ident)
far_left = 37.0 + SHIFT
add_mesh("far_room", room(far_left, wall) + [quad(0, far_left, 0, 3, -3, 3, +1)],
         material("sand", sand), ident)
add_mesh("window_wall", wall_with_hole(wall, plan["hole"]),
         material("plaster_and_sand", plaster, sand), ident)
block = (Matrix.Translation((-0.6, 0.45, -0.9)) @ Matrix.Rotation(math.radians(30), 4, "Y")
         @ Matrix.Scale(0.9, 4))
add_mesh("block", obj_faces(os.path.join(root, "examples/assets/cube.obj")),
         material("clay", (0.75, 0.38, 0.18)), block)

panel = bpy.data.lights.new("panel", "AREA")
panel.shape, panel.size, panel.size_y = "RECTANGLE", 1.0, 0.6
panel.color = (1.0, 0.92, 0.8)
panel.energy = plan["radiance"] * 1.0 * 0.6 * math.pi  # Cycles: L = P / (A·π)
lamp = bpy.data.objects.new("panel", panel)
lamp.matrix_world = Y_UP @ (Matrix.Translation((41.8 + SHIFT, 1.6, 0.0))
                            @ Matrix.Rotation(math.radians(90), 4, "Y"))
s.collection.objects.link(lamp)

cam = bpy.data.cameras.new("camera")
cam.sensor_fit, cam.angle = "HORIZONTAL", math.radians(62.0)
camera = bpy.data.objects.new("camera", cam)
camera.matrix_world = Y_UP @ Matrix(plan["camera"])
s.collection.objects.link(camera)
s.camera = camera

times = {}
for name, guided, spp, seed in plan["renders"]:
    c.use_guiding = c.use_surface_guiding = guided
    c.samples, c.seed = spp, seed
    s.render.filepath = os.path.join(folder, name + ".exr")
    t = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    times[name] = time.perf_counter() - t
json.dump(times, open(os.path.join(folder, "times.json"), "w"))
'''


def look_at(eye, target):
    """The camera-to-world matrix of a camera at `eye` looking at `target`, +Y up (rift's and
    Blender's cameras both look along their local -Z)."""
    eye, target = np.array(eye, float), np.array(target, float)
    back = eye - target
    back /= np.linalg.norm(back)
    right = np.cross([0.0, 1.0, 0.0], back)
    right /= np.linalg.norm(right)
    up = np.cross(back, right)
    m = np.identity(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, up, back, eye
    return m.tolist()


def read(path, channel="RGBA"):
    pixels = np.asarray(OpenEXR.File(path).channels()[channel].pixels, dtype=np.float64)
    return pixels[..., :3] if pixels.ndim == 3 else pixels


def relative_mse(image, reference, keep):
    """`rift bench`'s error measure: the mean of (v − ref)² / (ref² + 0.01) over the kept
    pixels and the three channels."""
    d = (image - reference) ** 2 / (reference**2 + 0.01)
    return float(d[keep].mean())


def render_rift(folder, name, spp, seed, guided):
    out = os.path.join(folder, name + ".exr")
    switch = "--guide-through-openings" if guided else "--no-guide-through-openings"
    t = time.perf_counter()
    subprocess.run([RIFT, "render", SHOT, "--res", str(WIDTH), str(HEIGHT), "--spp", str(spp),
                    "--seed", str(seed), switch, "-o", out], check=True, capture_output=True)
    return time.perf_counter() - t


def table(rows, keep, references):
    """Median seconds and relMSE per variant, and efficiency against the first."""
    print(f"{'renderer':<8} {'variant':<34} {'spp':>5} {'seconds':>8} {'relMSE':>10} {'1/(relMSE·s)':>13}")
    for renderer, variant, spp, runs in rows:
        seconds = float(np.median([s for s, _ in runs]))
        error = float(np.median([relative_mse(img, references[renderer], keep) for _, img in runs]))
        print(f"{renderer:<8} {variant:<34} {spp:>5} {seconds:>8.2f} {error:>10.3e} "
              f"{1.0 / (error * seconds):>13.2f}")


def main():
    folder = tempfile.mkdtemp(prefix="bounce_vs_cycles.")
    # Portal pair: window at x = -2.97 (dark room), window_there at x = 42.97 (far room).
    shift = -2.97 - 42.97
    renders = [["reference", False, CYCLES_REFERENCE_SPP, 0]]
    for guided in (False, True):
        for seed in SEEDS:
            renders.append([f"cycles_{'guided' if guided else 'plain'}_{seed}", guided, CYCLES_SPP, seed])
    plan = {"width": WIDTH, "height": HEIGHT, "shift": shift, "wall": -2.97, "hole": [-0.3, 0.3, 1.25, 1.75],
            "radiance": 2000.0, "camera": look_at([2.4, 1.5, 2.3], [-2.0, 1.1, -0.6]),
            "renders": renders}
    script = os.path.join(folder, "cycles_scene.py")
    with open(script, "w") as f:
        f.write(CYCLES)
    print(f"Cycles: {len(renders)} renders at {WIDTH}x{HEIGHT} ...", flush=True)
    subprocess.run([sys.executable, script, ROOT, folder, json.dumps(plan)], check=True,
                   capture_output=True)
    cycles_times = json.load(open(os.path.join(folder, "times.json")))

    print("rift: reference and renders ...", flush=True)
    render_rift(folder, "rift_reference", RIFT_REFERENCE_SPP, 9999, True)
    rift_runs = {False: [], True: []}
    for seed in SEEDS:
        for guided in (False, True):  # alternated
            name = f"rift_{guided}_{seed}"
            seconds = render_rift(folder, name, RIFT_SPP, seed, guided)
            rift_runs[guided].append((seconds, read(os.path.join(folder, name + ".exr"))))

    keep = read(os.path.join(folder, "rift_reference.exr"), "portalDepth") == 0.0
    references = {"rift": read(os.path.join(folder, "rift_reference.exr")),
                  "Cycles": read(os.path.join(folder, "reference.exr"))}
    print(f"\n{WIDTH}x{HEIGHT}, {int(keep.sum())} pixels in the camera's room; references: rift "
          f"{RIFT_REFERENCE_SPP} spp, Cycles {CYCLES_REFERENCE_SPP} spp ({cycles_times['reference']:.0f} s)")
    rift_mean = references["rift"][keep].mean(axis=0)
    cycles_mean = references["Cycles"][keep].mean(axis=0)
    print("room means  rift " + " ".join(f"{v:.4f}" for v in rift_mean)
          + "   Cycles " + " ".join(f"{v:.4f}" for v in cycles_mean)
          + "   rift/Cycles - 1: " + " ".join(f"{v:+.2%}" for v in rift_mean / cycles_mean - 1))
    cycles = lambda guided: [
        (cycles_times[n], read(os.path.join(folder, n + ".exr")))
        for n, g, _, _ in renders[1:] if g == guided]
    table([("rift", "BSDF sampling", RIFT_SPP, rift_runs[False]),
           ("rift", "bounces aimed at openings", RIFT_SPP, rift_runs[True]),
           ("Cycles", "no guiding", CYCLES_SPP, cycles(False)),
           ("Cycles", "path guiding (Open PGL)", CYCLES_SPP, cycles(True))], keep, references)
    print(f"(renders in {folder})")


if __name__ == "__main__":
    main()
