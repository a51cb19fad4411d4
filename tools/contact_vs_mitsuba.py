#!/usr/bin/env python3
"""Surfaces that touch, rift against Mitsuba 3: the Cornell box of the reference pack with its
small box made of smooth glass (ior 1.5) resting on the floor (its bottom face in the floor's
plane), and the same block lifted by a gap. Each renderer draws each scene with two seeds; the
script prints the image means per channel, in the whole image and in the region around the
block, rift's difference to Mitsuba's in per cent, and the noise (the two seeds' difference
in the mean, as a standard error of their average). The resting block is drawn by rift with
each `contact` the glass can take ("gap", the default, and "optical", which is how Mitsuba
breaks the tie between the two planes); a lifted block touches nothing, so only once.

    python3 tools/contact_vs_mitsuba.py --spp 1024 [--gaps 0 0.001] [--rift target/release/rift]

Needs `pip install mitsuba numpy OpenEXR`; the LLVM variant wants libLLVM 16 or newer (see
tools/cornell_vs_mitsuba.py).
"""
import argparse
import os
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from cornell_vs_mitsuba import load_mitsuba
from images import read_rgb

ROOT = Path(__file__).resolve().parent.parent
CORNELL = ROOT / "examples" / "cornell.obj"
# Pixels (x0, y0, x1, y1) of the 256x256 image around the small box and its shadow.
BLOCK_REGION = (120, 150, 230, 245)


def obj_groups(path):
    """The OBJ's vertices, its `o` groups' faces (1-based global indices) by name, and each
    group's material."""
    vertices, groups, materials, name = [], {}, {}, None
    for line in path.read_text().splitlines():
        words = line.split()
        if not words:
            continue
        if words[0] == "o":
            name = words[1]
            groups[name] = []
        elif words[0] == "usemtl":
            materials[name] = words[1]
        elif words[0] == "v":
            vertices.append([float(w) for w in words[1:4]])
        elif words[0] == "f":
            groups[name].append([int(w.split("/")[0]) for w in words[1:]])
    return vertices, groups, materials


def write_obj(path, vertices, faces, lift=0.0, material=None):
    """Writes `faces` (global 1-based indices into `vertices`) as an OBJ of their own, moved up
    by `lift`."""
    used = sorted({i for face in faces for i in face})
    index = {old: new + 1 for new, old in enumerate(used)}
    lines = ["mtllib cornell.mtl"] if material else []
    lines += [f"v {x:.7f} {y + lift:.7f} {z:.7f}" for x, y, z in (vertices[i - 1] for i in used)]
    if material:
        lines.append(f"usemtl {material}")
    lines += ["f " + " ".join(str(index[i]) for i in face) for face in faces]
    path.write_text("\n".join(lines) + "\n")


def write_scene(tmp, lift, contact):
    """The room (every group but the small box, with its MTL) and the glass block, touching as
    `contact` says, as OBJs in `tmp`, and rift's shot for them; returns the shot's path."""
    vertices, groups, materials = obj_groups(CORNELL)
    # The room keeps each group's material: one OBJ per group, all with the MTL.
    (tmp / "cornell.mtl").write_text((ROOT / "examples" / "cornell.mtl").read_text())
    for name, faces in groups.items():
        if name != "small-box":
            write_obj(tmp / f"{name}.obj", vertices, faces, material=materials[name])
    write_obj(tmp / "block.obj", vertices, groups["small-box"], lift=lift)
    shot = (ROOT / "examples" / "cornell.toml").read_text()
    shot = shot.split("[[object]]")[0]
    objects = "".join(
        f'[[object]]\nname = "{name}"\nmesh = "{name}.obj"\n\n'
        for name in groups if name != "small-box")
    objects += '[[object]]\nname = "block"\nmesh = "block.obj"\nmaterial = "glass"\n\n'
    materials_toml = (
        '[[material]]\nname = "light"\ntype = "diffuse"\n'
        'reflectance = [0.885809, 0.698859, 0.666422]\n'
        'emission = [18.387, 13.9873, 6.75357]\none_sided = true\n\n'
        '[[material]]\nname = "glass"\ntype = "dielectric"\nior = 1.5\nroughness = 0.0\n'
        f'contact = "{contact}"\n')
    path = tmp / f"contact_{lift}_{contact}.toml"
    path.write_text(shot + objects + materials_toml)
    return path


def render_rift(rift, shot, spp, seed, out):
    subprocess.run([rift, "render", str(shot), "-o", str(out), "--spp", str(spp),
                    "--seed", str(seed)], check=True, capture_output=True)
    return read_rgb(out)


def mitsuba_scene(mi, tmp):
    """Mitsuba's own Cornell box with the small box replaced by `tmp`'s glass block."""
    scene = mi.cornell_box()
    scene["sensor"]["film"]["rfilter"] = {"type": "box"}
    scene["integrator"] = {"type": "path", "max_depth": -1}
    scene["glass"] = {"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.0}
    scene["small-box"] = {"type": "obj", "filename": str(tmp / "block.obj"),
                          "face_normals": True, "bsdf": {"type": "ref", "id": "glass"}}
    return mi.load_dict(scene)


def means(img):
    x0, y0, x1, y1 = BLOCK_REGION
    return {"image": img.mean((0, 1)), "block region": img[y0:y1, x0:x1].mean((0, 1))}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rift", default=str(ROOT / "target/release/rift"))
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--gaps", type=float, nargs="+", default=[0.0, 0.001])
    ap.add_argument("--variant", default="llvm_ad_rgb")
    args = ap.parse_args()
    mi = load_mitsuba(args.variant)
    import drjit as dr

    for gap in args.gaps:
        contacts = ["gap", "optical"] if gap == 0 else ["gap"]
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            shots = {contact: write_scene(tmp, gap, contact) for contact in contacts}
            scene = mitsuba_scene(mi, tmp)
            runs = {"mitsuba": []}
            for seed in (1, 2):
                img = mi.render(scene, spp=args.spp, seed=seed)
                dr.eval(img)
                runs["mitsuba"].append(np.asarray(img, dtype=np.float64)[..., :3])
            for contact, shot in shots.items():
                runs[f"rift, {contact}"] = [
                    render_rift(args.rift, shot, args.spp, seed, tmp / f"r{seed}.exr")
                    for seed in (1, 2)]
        print(f"\nglass block {'resting on the floor' if gap == 0 else f'lifted {gap} m'}, "
              f"{args.spp} spp x 2 seeds, Mitsuba {mi.__version__} {args.variant}")
        for region in ("image", "block region"):
            m = {who: [means(img)[region] for img in imgs] for who, imgs in runs.items()}
            avg = {who: np.mean(v, axis=0) for who, v in m.items()}
            # The standard error of a two-seed average: half the seeds' difference.
            noise = {who: np.abs(v[0] - v[1]) / 2 for who, v in m.items()}
            print(f"  {region}: mitsuba {np.round(avg['mitsuba'], 5)}")
            for who in runs:
                if who == "mitsuba":
                    continue
                diff = (avg[who] / avg["mitsuba"] - 1) * 100
                sigma = np.hypot(noise[who], noise["mitsuba"]) / avg["mitsuba"] * 100
                print(f"    {who:13} {np.round(avg[who], 5)}: {np.round(diff, 2)} % "
                      f"(noise {np.round(sigma, 2)} %)")

if __name__ == "__main__":
    main()
