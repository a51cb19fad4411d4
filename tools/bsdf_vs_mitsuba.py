#!/usr/bin/env python3
"""rift's BSDFs side by side with Mitsuba 3, material by material.

One small scene per case: a faceted sphere and an upright slab of the material under test on a
checkered floor, lit either by a square lamp overhead ("lamp") or by a sky map that varies with
elevation ("sky"). The same OBJ meshes, the same sky EXR and the same camera go to both
renderers (Mitsuba with face normals, as rift uses for meshes without normals), so the only
difference left is the BSDF and the light transport.

Cases: diffuse; a conductor of reflectance 1 at roughness 0, 0.1, 0.3, 0.7; dielectrics smooth
and at the same roughnesses, ior 1.33 and 1.5, seen from outside and from inside (the inside
cases swap the indices: rift's `ior` below 1, Mitsuba's int_ior 1 and ext_ior the glass); the
named metals and one explicit complex index, whose η and k go to Mitsuba's `roughconductor`
as given. rift's GGX masking-shadowing is height-correlated and Mitsuba's separable, so rough
cases differ by that model choice too (see render/src/microfacet.rs).

`generate` writes tests/data/bsdf/: the meshes, the sky, one rift shot per case and lighting,
Mitsuba's renders at 64 x 40 (half-float EXR) and `references.toml` with each render's region
means and their noise (spread over seeds). tests/bsdf_vs_mitsuba.rs renders the shots with rift
and compares. `compare` renders both at high sample counts and prints the table for the notes.

    pip install mitsuba openexr numpy
    python3 tools/bsdf_vs_mitsuba.py generate [--spp 1024 --seeds 4]
    python3 tools/bsdf_vs_mitsuba.py compare --rift target/release/rift [--spp 1024]
    python3 tools/bsdf_vs_mitsuba.py cornell [--spp 256 --gap 0.001]   # the glass Cornell box
"""
import argparse
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from images import read_rgb

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "tests" / "data" / "bsdf"
WIDTH, HEIGHT = 64, 40
GRID = (4, 4)  # regions: rows, columns
ROUGHNESSES = (0.0, 0.1, 0.3, 0.7)
METALS = {  # rift's metal name -> (eta, k) from render/src/scene/metals.rs, passed to Mitsuba
    "gold": ([0.0918, 0.4118, 1.8510], [14.2313, 2.3766, 1.9709]),
    "silver": ([0.1293, 0.1253, 0.1513], [4.1103, 3.3512, 2.4125]),
    "copper": ([0.1689, 0.9762, 1.2114], [3.6378, 2.6212, 2.3663]),
    "aluminium": ([1.4274, 0.9294, 0.5916], [7.7359, 6.6056, 5.3648]),
}


def cases(shadowing="separable"):
    """(name, rift material keys, Mitsuba BSDF dict). Rough lobes use rift's `shadowing` mode:
    "separable" is Mitsuba's own term, so any difference left is a defect."""
    g = f'\nshadowing = "{shadowing}"'

    out = [("diffuse", 'type = "diffuse"\nreflectance = [0.7, 0.5, 0.3]',
            {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.7, 0.5, 0.3]}})]
    for r in ROUGHNESSES:
        mitsuba = ({"type": "conductor", "material": "none"} if r == 0 else
                   {"type": "roughconductor", "material": "none", "distribution": "ggx",
                    "alpha": r * r, "sample_visible": True})
        out.append((f"conductor_r{r}", f'type = "conductor"\nroughness = {r}{g}', mitsuba))
    for ior in (1.33, 1.5):
        for side in ("outside", "inside"):
            rift_ior = ior if side == "outside" else 1.0 / ior
            int_ior, ext_ior = (ior, 1.0) if side == "outside" else (1.0, ior)
            for r in ROUGHNESSES:
                mitsuba = ({"type": "dielectric", "int_ior": int_ior, "ext_ior": ext_ior}
                           if r == 0 else
                           {"type": "roughdielectric", "int_ior": int_ior, "ext_ior": ext_ior,
                            "distribution": "ggx", "alpha": r * r, "sample_visible": True})
                out.append((f"dielectric_{ior}_{side}_r{r}",
                            f'type = "dielectric"\nior = {rift_ior!r}\nroughness = {r}{g}', mitsuba))
    for (name, (eta, k)), r in zip(METALS.items(), (0.0, 0.1, 0.3, 0.7)):
        out.append((f"{name}_r{r}", f'type = "conductor"\nmetal = "{name}"\nroughness = {r}{g}',
                    conductor(eta, k, r)))
    eta, k = [1.2, 0.9, 0.6], [2.0, 3.0, 4.0]
    out.append(("eta_k_r0.3", f'type = "conductor"\neta = {eta}\nk = {k}\nroughness = 0.3{g}',
                conductor(eta, k, 0.3)))
    return out


def standard_cases(shadowing="separable"):
    """rift's standard layered material against Mitsuba's nearest: `plastic`/`roughplastic`
    for a dielectric base (Mitsuba's keeps the light the coat reflects back down inside the
    layer, rift's scales the base by the coat's albedo, so colours differ by that model) and
    `principled` for metals and blends (Disney's base, with Schlick's Fresnel for metals)."""
    g = f'\nshadowing = "{shadowing}"'
    base = [0.7, 0.5, 0.3]
    rgb = lambda v: {"type": "rgb", "value": v}
    out = []
    for r in (0.0, 0.3, 0.7):
        mitsuba = ({"type": "plastic", "diffuse_reflectance": rgb(base), "int_ior": 1.5,
                    "nonlinear": False} if r == 0 else
                   {"type": "roughplastic", "diffuse_reflectance": rgb(base), "int_ior": 1.5,
                    "distribution": "ggx", "alpha": r * r, "nonlinear": False})
        out.append((f"standard_plastic_r{r}",
                    f'type = "standard"\nbase_color = {base}\nroughness = {r}{g}', mitsuba))
    for metallic, r in ((1.0, 0.3), (0.5, 0.4), (0.0, 0.5)):
        out.append((f"standard_metallic{metallic}_r{r}",
                    f'type = "standard"\nbase_color = {base}\nmetallic = {metallic}\n'
                    f'roughness = {r}{g}',
                    {"type": "principled", "base_color": rgb(base), "metallic": metallic,
                     "roughness": r, "specular": 0.5}))
    return out


def conductor(eta, k, r):
    rgb = lambda v: {"type": "rgb", "value": v}
    if r == 0:
        return {"type": "conductor", "eta": rgb(eta), "k": rgb(k)}
    return {"type": "roughconductor", "eta": rgb(eta), "k": rgb(k), "distribution": "ggx",
            "alpha": r * r, "sample_visible": True}


# ---------------------------------------------------------------------------------------------
# Geometry, written once and shared by both renderers.

def icosphere(subdivisions, radius, centre):
    t = (1 + 5 ** 0.5) / 2
    verts = [np.array(v, float) for v in [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0),
                                         (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
                                         (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]]
    verts = [v / np.linalg.norm(v) for v in verts]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
             (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
             (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(subdivisions):
        cache, new = {}, []

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                m = verts[a] + verts[b]
                verts.append(m / np.linalg.norm(m))
                cache[key] = len(verts) - 1
            return cache[key]

        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            new += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new
    return [v * radius + centre for v in verts], faces


def box(size, centre, yaw_degrees):
    """An axis-aligned box of `size` turned about +Y, outward-facing triangles."""
    s = np.array(size) / 2
    corners = [np.array([x, y, z]) * s for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
    a = math.radians(yaw_degrees)
    rot = np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])
    verts = [rot @ c + centre for c in corners]
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    return verts, [f for a_, b, c, d in quads for f in ((a_, b, c), (a_, c, d))]


def floor_tiles(dark):
    """Checkered floor at y = 0 (tiles of 1 m over x in [-4, 4], z in [-4, 3]); the dark or
    the light half."""
    verts, faces = [], []
    for i in range(-4, 4):
        for j in range(-4, 3):
            if ((i + j) % 2 == 1) != dark:
                continue
            n = len(verts)
            verts += [np.array(p, float) for p in
                      [(i, 0, j), (i, 0, j + 1), (i + 1, 0, j + 1), (i + 1, 0, j)]]
            faces += [(n, n + 1, n + 2), (n, n + 2, n + 3)]
    return verts, faces


def lamp():
    """A 1 m square at 3 m, facing down."""
    verts = [np.array(p, float) for p in [(0, 3, 1), (1, 3, 1), (1, 3, 2), (0, 3, 2)]]
    return verts, [(0, 1, 2), (0, 2, 3)]


def write_obj(path, mesh):
    verts, faces = mesh
    lines = [f"v {v[0]:.6f} {v[1]:.6f} {v[2]:.6f}" for v in verts]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")


def sky_row(elevation):
    """Sky radiance by elevation (radians): blue overhead, warm at the horizon, dark ground."""
    if elevation < 0:
        return np.array([0.15, 0.12, 0.10])
    t = elevation / (math.pi / 2)
    return (1 - t) * np.array([1.3, 1.1, 0.9]) + t * np.array([0.5, 0.7, 1.2])


def write_sky(path):
    import OpenEXR

    w, h = 16, 512  # fine rows: rift looks texels up, Mitsuba filters them bilinearly
    rows = [sky_row(math.pi / 2 - (y + 0.5) / h * math.pi) for y in range(h)]
    img = np.repeat(np.array(rows, dtype=np.float32)[:, None, :], w, axis=1)
    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                      {"RGB": img}) as f:
        f.write(str(path))


def write_scene(out):
    out.mkdir(parents=True, exist_ok=True)
    write_obj(out / "sphere.obj", icosphere(3, 0.7, np.array([-0.9, 0.7, 0.0])))
    write_obj(out / "slab.obj", box((1.2, 1.2, 0.25), np.array([0.9, 0.65, 0.0]), 30))
    write_obj(out / "floor_light.obj", floor_tiles(False))
    write_obj(out / "floor_dark.obj", floor_tiles(True))
    write_obj(out / "lamp.obj", lamp())
    write_sky(out / "sky.exr")


CAMERA = {"position": [0.0, 1.6, 4.5], "look_at": [0.0, 0.55, 0.0], "fov": 40.0}
FLOOR = {"floor_light": [0.75, 0.75, 0.75], "floor_dark": [0.15, 0.15, 0.15]}
LAMP_RADIANCE = [10.0, 10.0, 10.0]


def rift_shot(name, material, lighting):
    p, l = CAMERA["position"], CAMERA["look_at"]
    text = (f'# {name}, {lighting}: written by tools/bsdf_vs_mitsuba.py\n'
            f'[shot]\nname = "{name}_{lighting}"\nfps = 24.0\nframes = [1, 1]\n'
            f'shutter = [0.0, 0.0]\n\n[camera]\nresolution = [{WIDTH}, {HEIGHT}]\n'
            f'fov_degrees = {CAMERA["fov"]}\nfov_axis = "smaller"\n'
            f'[camera.transform]\nposition = {p}\nlook_at = {l}\nup = [0.0, 1.0, 0.0]\n\n'
            f'[render]\nspp = 256\nseed = 0\noutput = "out/{name}_{lighting}.exr"\n\n'
            f'[[material]]\nname = "test"\n{material}\n')
    for floor, colour in FLOOR.items():
        text += f'\n[[material]]\nname = "{floor}"\ntype = "diffuse"\nreflectance = {colour}\n'
    objects = [("sphere", "test"), ("slab", "test"), ("floor_light", "floor_light"),
               ("floor_dark", "floor_dark")]
    if lighting == "lamp":
        text += (f'\n[[material]]\nname = "lamp"\ntype = "diffuse"\nreflectance = [0.0, 0.0, 0.0]\n'
                 f'emission = {LAMP_RADIANCE}\n')
        objects.append(("lamp", "lamp"))
    else:
        text += '\n[environment]\nmap = "sky.exr"\n'
    for obj, material_name in objects:
        text += f'\n[[object]]\nname = "{obj}"\nmesh = "{obj}.obj"\nmaterial = "{material_name}"\n'
    return text


def mitsuba_scene(bsdf, lighting, spp, data):
    rgb = lambda v: {"type": "rgb", "value": v}
    scene = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": -1},
        "sensor": {
            "type": "perspective", "fov": CAMERA["fov"], "fov_axis": "smaller",
            "to_world": __import__("mitsuba").ScalarTransform4f().look_at(
                origin=CAMERA["position"], target=CAMERA["look_at"], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": WIDTH, "height": HEIGHT,
                     "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": spp},
        },
    }
    mesh = lambda f, b: {"type": "obj", "filename": str(data / f"{f}.obj"), "face_normals": True,
                         "bsdf": b}
    scene["sphere"] = mesh("sphere", bsdf)
    scene["slab"] = mesh("slab", bsdf)
    for floor, colour in FLOOR.items():
        scene[floor] = mesh(floor, {"type": "diffuse", "reflectance": rgb(colour)})
    if lighting == "lamp":
        scene["lamp"] = mesh("lamp", {"type": "diffuse", "reflectance": rgb([0, 0, 0])})
        scene["lamp"]["emitter"] = {"type": "area", "radiance": rgb(LAMP_RADIANCE)}
    else:
        scene["sky"] = {"type": "envmap", "filename": str(data / "sky.exr")}
    return scene


def render_mitsuba(bsdf, lighting, spp, seed, data, variant):
    import mitsuba as mi

    mi.set_variant(variant)
    scene = mi.load_dict(mitsuba_scene(bsdf, lighting, spp, data))
    t = time.perf_counter()
    img = np.asarray(mi.render(scene, seed=seed), dtype=np.float64)[..., :3]
    return img, time.perf_counter() - t


def render_rift(rift, shot, spp, seed, tmp):
    out = Path(tmp) / f"{shot.stem}_{seed}.exr"
    t = time.perf_counter()
    subprocess.run([rift, "render", str(shot), "-o", str(out), "--spp", str(spp), "--seed",
                    str(seed)], check=True, capture_output=True, cwd=tmp)
    return read_rgb(out), time.perf_counter() - t


def write_exr(path, img):
    import OpenEXR

    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                      {"RGB": img.astype(np.float16)}) as f:
        f.write(str(path))


def regions(img):
    rows, cols = GRID
    h, w, _ = img.shape
    return np.array([[img[i * h // rows:(i + 1) * h // rows, j * w // cols:(j + 1) * w // cols]
                      .mean((0, 1)) for j in range(cols)] for i in range(rows)])


def summarise(renders):
    """Mean image, its region means, their standard errors (over seeds), median seconds."""
    imgs = np.array([img for img, _ in renders])
    per_seed = np.array([regions(img) for img in imgs])
    sem = per_seed.std(axis=0, ddof=1) / math.sqrt(len(imgs))
    # The mean image's own noise in relMSE terms: per-pixel variance of the mean over seeds.
    mean = imgs.mean(0)
    noise = float(np.mean(imgs.var(axis=0, ddof=1) / len(imgs) / (mean ** 2 + 0.01)))
    return mean, regions(mean), sem, float(np.median([t for _, t in renders])), noise


def write_shots(out, shadowing, standard=False):
    """The scene and every rift shot into `out` (cheap; both commands start here); with
    `standard`, the standard material's too."""
    write_scene(out)
    for name, material, _ in cases(shadowing) + (standard_cases(shadowing) if standard else []):
        for lighting in ("lamp", "sky"):
            (out / f"{name}_{lighting}.toml").write_text(rift_shot(name, material, lighting))


def generate(args):
    write_shots(DATA, "separable")
    (DATA / "references").mkdir(exist_ok=True)
    toml = [f"# Mitsuba 3 {args.variant} (path tracer) at {args.spp} spp x {args.seeds} seeds, "
            f"written by tools/bsdf_vs_mitsuba.py generate.\n# regions: {GRID[0]} x {GRID[1]} "
            "means (rows top to bottom), region_sem: their standard errors over seeds, "
            "pixel_noise: the mean image's per-pixel variance as relMSE.\n"]
    for name, material, bsdf in cases():
        for lighting in ("lamp", "sky"):
            shot = DATA / f"{name}_{lighting}.toml"
            runs = [render_mitsuba(bsdf, lighting, args.spp, s, DATA, args.variant)
                    for s in range(args.seeds)]
            mean, reg, sem, seconds, noise = summarise(runs)
            write_exr(DATA / "references" / f"{name}_{lighting}.exr", mean)
            rows = lambda a: "[" + ", ".join(
                "[" + ", ".join(f"[{c[0]:.6g}, {c[1]:.6g}, {c[2]:.6g}]" for c in row) + "]"
                for row in a) + "]"
            toml.append(f'[[render]]\nshot = "{shot.name}"\npixel_noise = {noise:.6g}\n'
                        f'regions = {rows(reg)}\nregion_sem = {rows(sem)}\n')
            print(f"{name:<28} {lighting:<5} mean {np.round(mean.mean((0, 1)), 4)} "
                  f"({seconds:.1f} s per seed)", flush=True)
    (DATA / "references.toml").write_text("\n".join(toml))


def compare(args):
    """High-spp renders of both, per case: whole-image and worst-region differences with noise."""
    worst_all = 0.0
    print(f"{'case':<28} {'light':<5} {'image %':>20} {'worst region %':>15} {'noise %':>8} "
          f"{'rift s':>7} {'mitsuba s':>9}")
    every = cases() + (standard_cases() if args.standard else [])
    selected = [c for c in every if not args.only or any(o in c[0] for o in args.only)]
    with tempfile.TemporaryDirectory() as tmp:
        data = Path(tmp)
        write_shots(data, args.shadowing, args.standard)
        for name, material, bsdf in selected:
            for lighting in ("lamp", "sky"):
                shot = data / f"{name}_{lighting}.toml"
                r = [render_rift(args.rift, shot, args.spp, s + 1, tmp) for s in range(args.seeds)]
                m = [render_mitsuba(bsdf, lighting, args.spp, s + 1, data, args.variant)
                     for s in range(args.seeds)]
                (ri, rr, rs, rt, _), (mi_, mr, ms, mt, _) = summarise(r), summarise(m)
                image = (ri.mean((0, 1)) / mi_.mean((0, 1)) - 1) * 100
                rel = (rr - mr) / np.maximum(mr, 1e-6)
                noise = np.sqrt(rs ** 2 + ms ** 2) / np.maximum(mr, 1e-6)
                # The region furthest outside its noise (among regions with light), with that noise.
                lit = mr > 1e-3 * mr.max()
                i = np.unravel_index(np.argmax(np.where(lit, np.abs(rel) - 3 * noise, -1)), rel.shape)
                worst_all = max(worst_all, abs(rel[i]) - 3 * noise[i])
                print(f"{name:<28} {lighting:<5} {np.array2string(image, precision=2):>20} "
                      f"{rel[i] * 100:>+14.2f}  {noise[i] * 100:>7.2f} {rt:>7.2f} {mt:>9.2f}",
                      flush=True)
    print(f"largest |difference| beyond 3 noise: {worst_all * 100:.2f}%")


def cornell(args):
    """The Cornell pack with a rough glass block added, both renderers at the same spp,
    alternating seeds: means, regions, and efficiency 1/(relMSE x seconds) against the mean of
    all the other renders (both renderers' together, leaving the measured one out)."""
    import mitsuba as mi

    mi.set_variant(args.variant)
    pack = ROOT / "examples"
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for f in ("cornell.obj", "cornell.mtl"):
            (tmp / f).write_text((pack / f).read_text())
        half = 0.25
        write_obj(tmp / "block.obj", box((2 * half, 2 * half, 2 * half),
                                         np.array([0.45, -1.0 + half + args.gap, 0.35]), 25))
        r = args.roughness
        shot = ((pack / "cornell.toml").read_text()
                + f'\n[[material]]\nname = "glass"\ntype = "dielectric"\nior = 1.5\n'
                  f'roughness = {r}\nshadowing = "separable"\n'
                  '\n[[object]]\nname = "block"\nmesh = "block.obj"\nmaterial = "glass"\n')
        (tmp / "glass.toml").write_text(shot)
        scene = mi.cornell_box()
        scene["block"] = {"type": "obj", "filename": str(tmp / "block.obj"), "face_normals": True,
                          "bsdf": {"type": "roughdielectric", "distribution": "ggx",
                                   "alpha": r * r, "int_ior": 1.5, "ext_ior": 1.0,
                                   "sample_visible": True}}
        scene["sensor"]["film"]["rfilter"] = {"type": "box"}
        scene["sensor"]["sampler"] = {"type": "independent", "sample_count": args.spp}
        scene["integrator"] = {"type": "path", "max_depth": -1}
        built = mi.load_dict(scene)
        runs = {"rift": [], "mitsuba": []}
        for seed in range(1, args.seeds + 1):
            runs["rift"].append(render_rift(args.rift, tmp / "glass.toml", args.spp, seed, tmp))
            t = time.perf_counter()
            img = np.asarray(mi.render(built, seed=seed), dtype=np.float64)[..., :3]
            runs["mitsuba"].append((img, time.perf_counter() - t))
    everything = [img for pair in runs.values() for img, _ in pair]
    total = sum(everything)
    means = {k: sum(img for img, _ in v) / len(v) for k, v in runs.items()}
    print(f"Cornell + rough glass block (roughness {r}, gap {args.gap} m): {args.spp} spp, "
          f"{args.seeds} seeds each, Mitsuba {args.variant}")
    eff = {}
    for who, pair in runs.items():
        rel = [float(np.mean((img - (total - img) / (len(everything) - 1)) ** 2
                             / (((total - img) / (len(everything) - 1)) ** 2 + 0.01)))
               for img, _ in pair]
        seconds = float(np.median([t for _, t in pair]))
        eff[who] = 1.0 / (np.median(rel) * seconds)
        print(f"  {who:<8} mean {np.round(means[who].mean((0, 1)), 5)}  seconds {seconds:6.2f}  "
              f"relMSE {np.median(rel):.3e}  efficiency {eff[who]:.2f}")
    print(f"  image rift/mitsuba - 1: "
          f"{np.round((means['rift'].mean((0, 1)) / means['mitsuba'].mean((0, 1)) - 1) * 100, 3)} %"
          f"; efficiency rift/mitsuba {eff['rift'] / eff['mitsuba']:.2f}")
    sems = {k: np.array([regions(img) for img, _ in v]).std(0, ddof=1) / math.sqrt(len(v))
            for k, v in runs.items()}
    rel = (regions(means["rift"]) - regions(means["mitsuba"])) / regions(means["mitsuba"])
    noise = np.sqrt(sems["rift"] ** 2 + sems["mitsuba"] ** 2) / regions(means["mitsuba"])
    print("  regions: rift/mitsuba - 1 (%, mean of channels) and noise (%)")
    for i in range(GRID[0]):
        print("   " + "  ".join(f"{rel[i, j].mean() * 100:+6.2f} ±{noise[i, j].mean() * 100:4.2f}"
                               for j in range(GRID[1])))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="command", required=True)
    g = sub.add_parser("generate")
    g.add_argument("--spp", type=int, default=1024)
    g.add_argument("--seeds", type=int, default=4)
    g.add_argument("--variant", default="scalar_rgb")
    c = sub.add_parser("compare")
    c.add_argument("--rift", default=str(ROOT / "target" / "release" / "rift"))
    c.add_argument("--spp", type=int, default=1024)
    c.add_argument("--seeds", type=int, default=4)
    c.add_argument("--variant", default="scalar_rgb")
    c.add_argument("--only", nargs="*", help="case names containing any of these")
    c.add_argument("--standard", action="store_true",
                   help="also the standard material against plastic, roughplastic, principled")
    c.add_argument("--shadowing", default="separable", choices=("separable", "height-correlated"),
                   help="rift's GGX masking-shadowing; Mitsuba's is separable")
    k = sub.add_parser("cornell")
    k.add_argument("--rift", default=str(ROOT / "target" / "release" / "rift"))
    k.add_argument("--spp", type=int, default=256)
    k.add_argument("--seeds", type=int, default=4)
    k.add_argument("--variant", default="scalar_rgb")
    k.add_argument("--roughness", type=float, default=0.3)
    k.add_argument("--gap", type=float, default=0.0, help="metres between block and floor")
    args = ap.parse_args()
    {"generate": generate, "compare": compare, "cornell": cornell}[args.command](args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
