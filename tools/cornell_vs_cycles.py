#!/usr/bin/env python3
"""Cornell box efficiency, rift against Blender Cycles (CPU), in one run: rounds alternate rift
and Cycles with path guiding off and on (and each of Cycles' sampling patterns asked for) on
the reference pack (../shared/reference/cornell), each at the same samples per pixel and
thread count, and the medians are compared.

Efficiency is 1 / (relMSE x seconds) against the converged reference and from the variance two
seeds show, as `tools/cornell_vs_mitsuba.py` measures it (rift's figures are `rift bench
convergence`'s; the image means against the reference show the scenes agree). Cycles renders
the pack as its scene.json gives it: the OBJ in its own axes (the camera at the pack's pose),
Lambertian surfaces whose backs absorb (the pack's BSDFs are one-sided; only the light's back,
lit through the gap under the ceiling, can be met), the light's emission on its front only,
a one-pixel box filter, no denoising, clamping or adaptive sampling, bounces up to Cycles' most
(1,024, with its own roulette). Cycles' seconds are those of the render call after a warm-up
render (scene sync included, guiding's training too when it guides).

    tests/.venv/bin/python3 tools/cornell_vs_cycles.py --spp 256 --rounds 3

Needs bpy (tests/requirements.txt installs it in tests/.venv).
"""
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import host
from cornell_vs_mitsuba import (PACK, comparison_arguments, print_efficiencies, rift_round,
                                two_seed_figures)
from images import read_rgb

# Cycles' limit on every bounce count.
MOST_BOUNCES = 1024


def load_bpy():
    """Blender as a module, with Cycles enabled."""
    try:
        import bpy
        import addon_utils  # importable once bpy has set up Blender's paths
    except ImportError as e:
        sys.exit(f"bpy is needed (tests/.venv/bin/python3 has it): {e}")
    addon_utils.enable("cycles", default_set=True)
    return bpy


def material(bpy, name, look):
    """The pack's material `look` (scene.json): Lambertian on its front, black on its back,
    with its emission on the front only where it has one."""
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nodes, links = m.node_tree.nodes, m.node_tree.links
    nodes.clear()
    front = nodes.new("ShaderNodeBsdfDiffuse")
    front.inputs["Color"].default_value = (*look["reflectance"], 1.0)
    if "emission" in look:
        emission = nodes.new("ShaderNodeEmission")
        emission.inputs["Color"].default_value = (*look["emission"], 1.0)
        emission.inputs["Strength"].default_value = 1.0
        both = nodes.new("ShaderNodeAddShader")
        links.new(front.outputs[0], both.inputs[0])
        links.new(emission.outputs[0], both.inputs[1])
        front = both
        m.cycles.emission_sampling = "FRONT"
    back = nodes.new("ShaderNodeBsdfDiffuse")
    back.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    sides = nodes.new("ShaderNodeMixShader")
    links.new(nodes.new("ShaderNodeNewGeometry").outputs["Backfacing"], sides.inputs[0])
    links.new(front.outputs[0], sides.inputs[1])
    links.new(back.outputs[0], sides.inputs[2])
    links.new(sides.outputs[0], nodes.new("ShaderNodeOutputMaterial").inputs["Surface"])
    return m


def build_scene(bpy, threads):
    """The pack in an empty Blender scene, rendered by Cycles on the CPU with `threads`."""
    pack = json.loads((PACK / "scene.json").read_text())
    bpy.ops.wm.read_factory_settings(use_empty=True)
    # The file's own axes (no conversion to Blender's Z up): the camera is placed in them too.
    bpy.ops.wm.obj_import(filepath=str(PACK / pack["mesh"]), forward_axis="Y", up_axis="Z")
    looks = {name: material(bpy, name, look) for name, look in pack["materials"].items()}
    for o in bpy.context.scene.objects:
        for slot in o.material_slots:
            name = slot.material.name.split(".")[0]
            if name not in looks:
                sys.exit(f"{PACK / pack['mesh']}: material {name!r} is not in scene.json")
            slot.material = looks[name]
    s = bpy.context.scene
    s.camera = camera(bpy, pack["camera"], pack["film"])
    s.world = bpy.data.worlds.new("black")
    s.world.use_nodes = True
    s.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    s.render.engine = "CYCLES"
    s.render.threads_mode, s.render.threads = "FIXED", threads
    s.render.resolution_x, s.render.resolution_y = pack["film"]["width"], pack["film"]["height"]
    s.render.resolution_percentage = 100
    s.view_settings.view_transform = "Standard"
    s.render.image_settings.file_format = "OPEN_EXR"
    s.render.image_settings.color_depth = "32"
    c = s.cycles
    c.device, c.use_adaptive_sampling, c.use_denoising = "CPU", False, False
    for bounces in ("max_bounces", "diffuse_bounces", "glossy_bounces",
                    "transmission_bounces", "transparent_max_bounces"):
        setattr(c, bounces, MOST_BOUNCES)
    c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
    c.pixel_filter_type, c.filter_width = "BOX", 1.0
    return s


def camera(bpy, pose, film):
    """The pack's pinhole camera: at `pose`'s position, looking at its look_at, its up kept up,
    the field of view on the smaller axis."""
    from mathutils import Matrix, Vector

    eye, target, up = (Vector(pose[k]) for k in ("position", "look_at", "up"))
    back = (eye - target).normalized()  # a Blender camera looks down its -Z
    right = up.cross(back).normalized()
    true_up = back.cross(right)
    rotation = Matrix((right, true_up, back)).transposed().to_4x4()
    data = bpy.data.cameras.new("camera")
    data.sensor_fit = "AUTO"  # the angle spans the larger axis; square films agree
    width, height = film["width"], film["height"]
    fov = np.radians(pose["fov_degrees"])
    if width != height:
        fov = 2 * np.arctan(np.tan(fov / 2) * max(width, height) / min(width, height))
    data.angle = float(fov)
    data.clip_start, data.clip_end = 1e-3, 1e3
    o = bpy.data.objects.new("camera", data)
    o.matrix_world = Matrix.Translation(eye) @ rotation
    bpy.context.scene.collection.objects.link(o)
    return o


def configure(scene, guided, pattern):
    """Path guiding on or off (surfaces; the pack has no volumes) and the sampling pattern."""
    c = scene.cycles
    c.use_guiding = guided
    c.use_surface_guiding = guided
    c.use_volume_guiding = False
    c.sampling_pattern = pattern


def cycles_render(bpy, scene, spp, seed, out):
    """(image, seconds) of one render at `spp` with `seed`."""
    c = scene.cycles
    c.samples, c.seed, c.use_animated_seed = spp, seed, False
    scene.render.filepath = str(out)
    start = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    seconds = time.perf_counter() - start
    return read_rgb(out), seconds


def main():
    ap = comparison_arguments(__doc__)
    ap.add_argument("--patterns", default="TABULATED_SOBOL,BLUE_NOISE",
                    help="Cycles' sampling patterns to try, comma-separated (in Blender 4.5 "
                         "AUTOMATIC is BLUE_NOISE, the same images)")
    args = ap.parse_args()

    bpy = load_bpy()
    scene = build_scene(bpy, args.threads)
    patterns = args.patterns.split(",")
    for pattern in patterns:
        try:
            configure(scene, False, pattern)
        except TypeError as e:  # bpy names the patterns this Cycles has
            sys.exit(f"--patterns: {e}")
    configs = {f"{'guided' if g else 'plain'} {p.lower()}": (g, p)
               for p in patterns for g in (False, True)}
    reference = read_rgb(args.reference)
    print(f"reference: {args.reference}", flush=True)

    runs = {"rift": []} | {name: [] for name in configs}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for guided, pattern in configs.values():  # warm-up: kernels loaded, guiding set up
            configure(scene, guided, pattern)
            cycles_render(bpy, scene, 1, 0, tmp / "warm.exr")
        for k in range(args.rounds):
            seeds = (2 * k + 1, 2 * k + 2)
            runs["rift"].append(
                rift_round(args.rift, args.spp, args.threads, seeds[0], tmp, args.reference))
            line = f"round {k + 1}: rift {runs['rift'][-1][0]:.2f} s {runs['rift'][-1][1]:.4e}"
            for name, (guided, pattern) in configs.items():
                configure(scene, guided, pattern)
                renders = [cycles_render(bpy, scene, args.spp, seed, tmp / f"c{seed}.exr")
                           for seed in seeds]
                runs[name].append(two_seed_figures([r[0] for r in renders],
                                                   [r[1] for r in renders], reference))
                line += f" | {name} {runs[name][-1][0]:.2f} s {runs[name][-1][1]:.4e}"
            print(line, flush=True)

    print(f"\nCornell box, {args.threads} threads, {args.spp} spp, "
          f"Blender {bpy.app.version_string} Cycles (CPU), "
          f"medians of {args.rounds} rounds, two seeds each")
    print(f"host: {host.describe()}")
    print_efficiencies(runs, "Cycles")


if __name__ == "__main__":
    main()
