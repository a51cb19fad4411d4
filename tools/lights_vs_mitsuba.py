#!/usr/bin/env python3
"""rift's `[[light]]` kinds against Mitsuba 3's emitters, one light at a time, in a small room
corner: a diffuse floor and two walls (reflectance 0.5), seen by the same camera, all bounces.

Conversions (UsdLux units in rift, see docs/materials-and-lights.md):
- point, radius 0, intensity I: a quarter of I each way -> Mitsuba `point`, intensity I/4;
- sphere of radius r, radiance I (normalize off), seen by the camera -> a Mitsuba `sphere`
  with an `area` emitter;
- spot with a hard cone (softness 0) -> Mitsuba `spot` with beam_width = cutoff_angle;
- rect w x w and disk of radius r, radiance I, aimed by look_at -> Mitsuba `rectangle` and
  `disk` shapes (which emit along their +Z, aimed the same way) with `area` emitters;
- distant of angle 0, intensity E -> Mitsuba `directional`, irradiance E.

The script prints the whole image's difference per channel and the worst of a 4 x 4 grid of
regions, with the noise (the two seeds' spread, both renderers), all in per cent.

    python3 tools/lights_vs_mitsuba.py --rift target/release/rift [--spp 256]
"""
import tempfile
from pathlib import Path

import numpy as np

from bsdf_vs_mitsuba import render_rift
from textures_vs_mitsuba import arguments, report
from cornell_vs_mitsuba import load_mitsuba

SIZE = 64
CAMERA = ([2.5, 1.6, 3.5], [-0.3, 0.5, -0.3], 50.0)
TARGET = [0.0, 0.0, 0.0]


def room(out):
    """Floor (y = 0) and two walls (x = -1.5, z = -1.5), faces towards the room."""
    out.joinpath("room.obj").write_text(
        "v -1.5 0 -1.5\nv 3 0 -1.5\nv 3 0 3\nv -1.5 0 3\n"
        "v -1.5 3 -1.5\nv -1.5 3 3\nv 3 3 -1.5\n"
        "f 1 4 3\nf 1 3 2\n"      # floor, up
        "f 1 5 6\nf 1 6 4\n"      # x = -1.5 wall, facing +x
        "f 1 2 7\nf 1 7 5\n")     # z = -1.5 wall, facing +z


CASES = {
    # name: (rift light keys, position, Mitsuba emitter dict maker)
    "point": ('type = "point"\nintensity = 8.0', [0.4, 2.0, 0.6]),
    "sphere": ('type = "point"\nradius = 0.2\nintensity = 6.0\nvisibility = { camera = true }',
               [0.4, 1.8, 0.6]),
    "spot": ('type = "spot"\nintensity = 40.0\ncone_angle = 30.0\ncone_softness = 0.0',
             [0.8, 2.4, 0.9]),
    "rect": ('type = "rect"\nwidth = 0.6\nheight = 0.6\nintensity = 5.0', [0.5, 2.5, 0.5]),
    "disk": ('type = "disk"\nradius = 0.35\nintensity = 5.0', [0.5, 2.5, 0.5]),
    "distant": ('type = "distant"\nangle = 0.0\nintensity = 2.0', [1.0, 2.0, 1.4]),
}


def rift_shot(name):
    keys, position = CASES[name]
    p, l, fov = CAMERA
    return (f'[shot]\nname = "{name}"\nfps = 24.0\nframes = [1, 1]\nshutter = [0.0, 0.0]\n'
            f'[camera]\nresolution = [{SIZE}, {SIZE}]\nfov_degrees = {fov}\n'
            f'[camera.transform]\nposition = {p}\nlook_at = {l}\nup = [0.0, 1.0, 0.0]\n'
            f'[render]\nmax_bounces = 16\n'
            f'[[material]]\nname = "wall"\ntype = "diffuse"\nreflectance = [0.5, 0.5, 0.5]\n'
            f'[[object]]\nname = "room"\nmesh = "room.obj"\nmaterial = "wall"\n'
            f'[[light]]\nname = "{name}"\n{keys}\n'
            f'transform = {{ position = {position}, look_at = {TARGET} }}\n')


def mitsuba_emitter(name):
    import mitsuba as mi

    _, position = CASES[name]
    rgb = lambda v: {"type": "rgb", "value": [v] * 3}
    aim = mi.ScalarTransform4f().look_at(origin=position, target=TARGET, up=[0, 1, 0])
    area = lambda radiance: {"type": "area", "radiance": rgb(radiance)}
    if name == "point":
        return {"type": "point", "position": position, "intensity": rgb(8.0 / 4)}
    if name == "sphere":
        return {"type": "sphere", "center": position, "radius": 0.2, "emitter": area(6.0)}
    if name == "spot":
        return {"type": "spot", "to_world": aim, "intensity": rgb(40.0 / 4),
                "cutoff_angle": 30.0, "beam_width": 30.0}
    if name == "rect":
        return {"type": "rectangle", "to_world": aim @ mi.ScalarTransform4f().scale([0.3, 0.3, 1]),
                "emitter": area(5.0)}
    if name == "disk":
        return {"type": "disk", "to_world": aim @ mi.ScalarTransform4f().scale([0.35, 0.35, 1]),
                "emitter": area(5.0)}
    d = np.array(TARGET) - np.array(position)
    return {"type": "directional", "direction": (d / np.linalg.norm(d)).tolist(),
            "irradiance": rgb(2.0)}


def mitsuba_scene(name, out, spp):
    import mitsuba as mi

    p, l, fov = CAMERA
    return {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 17},
        "sensor": {"type": "perspective", "fov": fov, "fov_axis": "x",
                   "to_world": mi.ScalarTransform4f().look_at(origin=p, target=l, up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": SIZE, "height": SIZE,
                            "rfilter": {"type": "box"}, "pixel_format": "rgb"},
                   "sampler": {"type": "independent", "sample_count": spp}},
        "room": {"type": "obj", "filename": str(out / "room.obj"), "face_normals": True,
                 "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.5] * 3}}},
        "light": mitsuba_emitter(name),
    }


def main():
    args = arguments(__doc__)
    mi = load_mitsuba(args.variant)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        room(out)
        print(f"lights, rift against Mitsuba {mi.__version__} {args.variant}: "
              f"{args.spp} spp x 2 seeds, {SIZE} x {SIZE}")
        print(f"{'light':<20} {'image %':>22} {'worst region %':>15} {'noise %':>8}")
        for name in CASES:
            if args.only and name not in args.only:
                continue
            shot = out / f"{name}.toml"
            shot.write_text(rift_shot(name))
            rift = [render_rift(args.rift, shot, args.spp, seed, out)[0] for seed in (1, 2)]
            scene = mi.load_dict(mitsuba_scene(name, out, args.spp))
            mits = [np.asarray(mi.render(scene, seed=seed), dtype=np.float64)[..., :3]
                    for seed in (1, 2)]
            report(name, rift, mits)

if __name__ == "__main__":
    main()
