"""A client's files: the set tests/support/blender_set.py builds in Blender (image-textured floor,
gold metal sphere, clay cube, 300 instanced pebbles, point, spot, area and sun lights), rendered
by Cycles from the .blend and by rift from the USD Blender's own exporter writes, framed by the
same camera (rift reads Blender's animated camera from the stage) at frame 1, no denoising,
clamping off, 12 bounces. Each light alone too, so that a difference is traced to one light;
and "flat", the point light alone where the material models agree (Lambertian non-metals, the
floor's texture replaced by a flat colour). Per region (a 3x3 grid) and channel: rift / Cycles - 1, and
the noise (half the difference between two seeds of each, combined).

    tests/.venv/bin/python3 tools/blender_vs_cycles.py [RIFT] [SPP]
"""
import os
import subprocess
import sys
import tempfile

import numpy as np
import OpenEXR

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
GRID = 3

# Run inside Blender's Python (bpy): renders the .blend with Cycles, each light alone as well,
# exporting each variant's USD beside it.
CYCLES = r'''
import os, sys
import bpy
import addon_utils  # importable once bpy has set up Blender's paths
blend, folder, spp = sys.argv[-3], sys.argv[-2], int(sys.argv[-1])
addon_utils.enable("cycles", default_set=True)
bpy.ops.wm.open_mainfile(filepath=blend)
s = bpy.context.scene
s.render.engine = "CYCLES"
c = s.cycles
c.device, c.samples, c.use_adaptive_sampling, c.use_denoising = "CPU", spp, False, False
c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = 12
c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
s.view_settings.view_transform = "Standard"
s.render.image_settings.file_format = "OPEN_EXR"
s.render.image_settings.color_depth = "32"
lights = [o for o in bpy.data.objects if o.type == "LIGHT"]
energy = {o.name: o.data.energy for o in lights}

def flatten():
    """Where the material models agree: Lambertian non-metals (IOR 1, no specular layer) and
    the floor's texture replaced by its orange."""
    for m in bpy.data.materials:
        b = m.node_tree.nodes.get("Principled BSDF")
        if b and b.inputs["Metallic"].default_value == 0.0:
            b.inputs["IOR"].default_value = 1.0
    floor = bpy.data.materials["Floor"].node_tree
    for link in list(floor.links):
        if link.to_socket.name == "Base Color":
            floor.links.remove(link)
    floor.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.79, 0.216, 0.0103, 1)


for variant in ["all"] + [o.name for o in lights] + ["flat"]:
    if variant == "flat":
        flatten()
    only = "Point" if variant == "flat" else variant
    for o in lights:
        o.data.energy = energy[o.name] if only in ("all", o.name) else 0.0
    out = os.path.join(folder, variant)
    os.makedirs(out, exist_ok=True)
    bpy.ops.wm.usd_export(filepath=os.path.join(out, "blender.usda"), export_materials=True,
                          use_instancing=True, export_animation=True)
    for seed in (1, 2):
        c.seed = seed
        s.render.filepath = os.path.join(out, f"cycles{seed}.exr")
        bpy.ops.render.render(write_still=True)
'''

SHOT = """[shot]
name = "blender"
fps = 24.0
frames = [1, 1]
shutter = [0.0, 0.0]
[camera]
resolution = [160, 90]
usd = "/root/Camera/Camera"
[render]
spp = {spp}
seed = {seed}
max_bounces = 12
[[usd]]
file = "blender.usda"
"""


def image(path):
    return np.asarray(OpenEXR.File(path).parts[0].channels["RGBA"].pixels)[..., :3].astype(np.float64)


def regions(img):
    h, w, _ = img.shape
    return np.array([[img[j * h // GRID:(j + 1) * h // GRID, i * w // GRID:(i + 1) * w // GRID]
                      .reshape(-1, 3).mean(0) for i in range(GRID)] for j in range(GRID)])


def compare(folder):
    rift = [regions(image(os.path.join(folder, f"rift{s}.exr"))) for s in (1, 2)]
    cycles = [regions(image(os.path.join(folder, f"cycles{s}.exr"))) for s in (1, 2)]
    r, c = (rift[0] + rift[1]) / 2, (cycles[0] + cycles[1]) / 2
    noise = np.hypot((rift[0] - rift[1]) / 2, (cycles[0] - cycles[1]) / 2) / np.maximum(c, 1e-6)
    return r / np.maximum(c, 1e-6) - 1, noise, r.mean(axis=(0, 1)) / c.mean(axis=(0, 1)) - 1


def main():
    """Renders the set with Cycles and rift, each light alone too, and prints the table."""
    rift = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "target/release/rift"))
    spp = int(sys.argv[2]) if len(sys.argv) > 2 else 256
    with tempfile.TemporaryDirectory() as folder:
        python = sys.executable
        subprocess.run([python, os.path.join(ROOT, "tests/support/blender_set.py"), folder],
                       check=True, capture_output=True)
        script = os.path.join(folder, "render_with_cycles.py")
        with open(script, "w") as f:
            f.write(CYCLES)
        subprocess.run([python, script, os.path.join(folder, "blender.blend"), folder, str(spp)],
                       check=True, capture_output=True)
        print(f"rift / Cycles - 1 per region ({GRID}x{GRID}, rows top first) and channel; "
              f"noise in brackets; {spp} spp each, two seeds")
        for variant in ["all", "Point", "Spot", "Area", "Sun", "flat"]:
            out = os.path.join(folder, variant)
            for name in os.listdir(folder):
                if name.endswith(".png"):
                    os.symlink(os.path.join(folder, name), os.path.join(out, name))
            for seed in (1, 2):
                with open(os.path.join(out, f"shot{seed}.toml"), "w") as f:
                    f.write(SHOT.format(spp=spp, seed=seed))
                subprocess.run([rift, "render", f"shot{seed}.toml", "-o", f"rift{seed}.exr"],
                               cwd=out, check=True, capture_output=True)
            diff, noise, whole = compare(out)
            print(f"\n{variant}: whole image R/G/B {whole[0]:+.3f} {whole[1]:+.3f} {whole[2]:+.3f}")
            for j in range(GRID):
                print("  " + "   ".join(
                    "/".join(f"{diff[j, i, k]:+.3f}" for k in range(3))
                    + f" ({max(noise[j, i]):.3f})" for i in range(GRID)))


if __name__ == "__main__":
    main()
