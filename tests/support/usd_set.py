"""Writes a small dressed set as USD with Pixar's usd-core, and the same set as rift's own shot
file, OBJ meshes and PNG texture, for tests/usd_scenes.rs:

    python3 tests/support/usd_set.py OUT_DIR

OUT_DIR gets set.usda, set.usdc and set.usdz (one scene in the three encodings; the usdz packs
its texture), checker.png, and the equivalent scene without USD: room.obj, box.obj, ball.obj,
blob.0001.obj / blob.0002.obj (a mesh sequence) and set_toml.toml. The USD shots are
set_usda.toml, set_usdc.toml and set_usdz.toml, which differ only in the layer they read.

The set exercises what the reader must get right: a room of quads whose walls take materials
from GeomSubsets; a box under a parent with a non-uniform scale, textured through a
UsdUVTexture on faceVarying UVs; a metal ball moving by time-sampled translate (motion blur),
shaded smoothly by its authored vertex normals (`vn` in ball.obj);
a deforming mesh (time-sampled points); two instanceable crates sharing a prototype; a
PointInstancer of pebbles and blocks (two prototypes under it, orientations in half precision,
uniform scales, one stretched, one mirrored, one hidden by invisibleIds, one moving by its
velocity); an emissive panel; a rect light turned to face down, a sphere light and a spot
(ShapingAPI cone); a shot camera (moving, with depth of field and a clipping range); and prims
rift must leave out (a proxy, an invisible mesh) or say it does not read (a camera).
"""
import math
import os
import struct
import sys
import zlib

from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, UsdUtils

OUT = sys.argv[1]
os.makedirs(OUT, exist_ok=True)


def write_png(path, size=64, squares=8):
    """A grey-and-orange checker, 8-bit RGB."""
    rows = []
    for y in range(size):
        row = bytearray([0])
        for x in range(size):
            on = ((x * squares // size) + (y * squares // size)) % 2
            row += bytes([230, 140, 40]) if on else bytes([60, 60, 60])
        rows.append(bytes(row))
    raw = zlib.compress(b"".join(rows))

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    header = struct.pack(">IIBBBBB", size, size, 8, 2, 0, 0, 0)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", raw) + chunk(b"IEND", b""))


# --- geometry, in each prim's own space ------------------------------------------------------

def room():
    """Floor, ceiling, back, left and right walls of a 4 x 2.5 x 4 room, facing inwards; the
    face index of each wall's quad and the part it belongs to."""
    v = [(-2, 0, 0), (2, 0, 0), (2, 0, -4), (-2, 0, -4),
         (-2, 2.5, 0), (2, 2.5, 0), (2, 2.5, -4), (-2, 2.5, -4)]
    faces = [
        (0, 1, 2, 3),  # floor (up)
        (4, 7, 6, 5),  # ceiling (down)
        (3, 2, 6, 7),  # back (towards +z)
        (0, 3, 7, 4),  # left (towards +x)
        (1, 5, 6, 2),  # right (towards -x)
    ]
    parts = {"white": [0, 1, 2], "red": [3], "green": [4]}
    return v, faces, parts


def cube():
    """A unit cube centred on the origin with faceVarying UVs (each face the whole texture)."""
    v = [(x, y, z) for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)]
    idx = {p: i for i, p in enumerate(v)}
    h = 0.5
    faces = [
        [(-h, -h, h), (h, -h, h), (h, h, h), (-h, h, h)],
        [(h, -h, -h), (-h, -h, -h), (-h, h, -h), (h, h, -h)],
        [(h, -h, h), (h, -h, -h), (h, h, -h), (h, h, h)],
        [(-h, -h, -h), (-h, -h, h), (-h, h, h), (-h, h, -h)],
        [(-h, h, h), (h, h, h), (h, h, -h), (-h, h, -h)],
        [(-h, -h, -h), (h, -h, -h), (h, -h, h), (-h, -h, h)],
    ]
    faces = [tuple(idx[p] for p in f) for f in faces]
    uv = [(0, 0), (1, 0), (1, 1), (0, 1)] * 6
    return v, faces, uv


def sphere(radius=0.35, rings=8, segments=12):
    """A UV sphere of quads and (at the poles) triangles."""
    v = [(0, radius, 0)]
    for r in range(1, rings):
        th = math.pi * r / rings
        for s in range(segments):
            ph = 2 * math.pi * s / segments
            v.append((radius * math.sin(th) * math.cos(ph), radius * math.cos(th), -radius * math.sin(th) * math.sin(ph)))
    v.append((0, -radius, 0))
    bottom = len(v) - 1
    ring = lambda r, s: 1 + (r - 1) * segments + s % segments
    faces = [(0, ring(1, s), ring(1, s + 1)) for s in range(segments)]
    for r in range(1, rings - 1):
        for s in range(segments):
            faces.append((ring(r, s), ring(r + 1, s), ring(r + 1, s + 1), ring(r, s + 1)))
    faces += [(ring(rings - 1, s), bottom, ring(rings - 1, s + 1)) for s in range(segments)]
    return v, faces


def sphere_normal(p):
    length = math.sqrt(sum(c * c for c in p))
    return tuple(c / length for c in p)


def blob(frame):
    """A tetrahedron whose top vertex rises between frames 1 and 2."""
    top = 0.4 if frame == 1 else 0.7
    v = [(-0.3, 0, 0.2), (0.3, 0, 0.2), (0, 0, -0.3), (0, top, 0)]
    faces = [(0, 1, 3), (1, 2, 3), (2, 0, 3), (0, 2, 1)]
    return v, faces


# --- the USD stage ----------------------------------------------------------------------------

def preview_material(stage, path, diffuse=None, metallic=None, roughness=None, emissive=None, texture=None,
                     occlusion=None):
    mat = UsdShade.Material.Define(stage, path)
    surf = UsdShade.Shader.Define(stage, path + "/Surface")
    surf.CreateIdAttr("UsdPreviewSurface")
    if texture:
        tex = UsdShade.Shader.Define(stage, path + "/Texture")
        tex.CreateIdAttr("UsdUVTexture")
        tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(texture)
        tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("sRGB")
        reader = UsdShade.Shader.Define(stage, path + "/UV")
        reader.CreateIdAttr("UsdPrimvarReader_float2")
        reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
        tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
        rgb = tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
        surf.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(rgb)
    elif diffuse is not None:
        surf.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*diffuse))
    if metallic is not None:
        surf.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(metallic)
    if roughness is not None:
        surf.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(roughness)
    if emissive is not None:
        surf.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*emissive))
    if occlusion is not None:
        # A real-time renderer's input, which rift does not read (and says so).
        surf.CreateInput("occlusion", Sdf.ValueTypeNames.Float).Set(occlusion)
    mat.CreateSurfaceOutput().ConnectToSource(surf.ConnectableAPI(), "surface")
    return mat


def mesh(stage, path, v, faces, material=None):
    m = UsdGeom.Mesh.Define(stage, path)
    m.CreatePointsAttr([Gf.Vec3f(*p) for p in v])
    m.CreateFaceVertexCountsAttr([len(f) for f in faces])
    m.CreateFaceVertexIndicesAttr([i for f in faces for i in f])
    m.CreateSubdivisionSchemeAttr("none")
    if material is not None:
        UsdShade.MaterialBindingAPI.Apply(m.GetPrim()).Bind(material)
    return m


BOX_PARENT = dict(translate=(-0.7, 0.0, -2.6), rotate_y=30.0, scale=(1.0, 1.5, 1.0))
BOX_LOCAL = (0.0, 0.4, 0.0)
BOX_SIZE = 0.8
BALL_KEYS = {1: (0.6, 0.4, -2.2), 2: (0.9, 0.4, -2.2)}
BLOB_AT = (0.9, 0.0, -3.3)
PANEL = dict(center=(0.0, 1.3, -3.99), width=0.6, height=0.4)
KEY_LIGHT = dict(position=(0.0, 2.45, -2.0), width=1.0, height=0.5, intensity=12.0)
FILL = dict(position=(-1.2, 1.8, -1.0), radius=0.1, intensity=30.0, color=(1.0, 0.85, 0.7))
CRATES = [(1.4, 0.0, -1.6), (1.5, 0.0, -2.6)]
CRATE_SIZE = 0.3
# PointInstancer instances: prototype (0 pebble, 1 block), position, orientation (w, x, y, z),
# scale. Instance 3 is hidden; instance 4 is stretched; instance 5 moves by PEBBLE_VELOCITY;
# instance 6 is mirrored.
PEBBLES = [
    (0, (-1.2, 0.1, -1.5), (1, 0, 0, 0), 1.0),
    (1, (-0.6, 0.0, -1.4), (0.9239, 0, 0.3827, 0), 1.2),
    (0, (0.0, 0.1, -1.6), (0.7071, 0.7071, 0, 0), 0.8),
    (1, (0.5, 0.0, -1.5), (1, 0, 0, 0), 1.0),
    (0, (1.0, 0.12, -1.8), (0.9659, 0, 0, 0.2588), (1.5, 0.6, 1.0)),
    (0, (-0.3, 0.1, -2.0), (1, 0, 0, 0), 1.0),
    (1, (0.9, 0.0, -2.4), (0.9659, 0, 0.2588, 0), (-1.0, 1.0, 1.0)),
]
PEBBLE_VELOCITY = (2.4, 0.0, 0.0)
SPOT = dict(position=(1.2, 2.2, -3.0), radius=0.05, intensity=60.0, cone=30.0, softness=0.2)


def point_instancer(stage, looks):
    """The pebbles: a PointInstancer whose prototypes live under it (not rendered on their own):
    a pebble mesh with a transform of its own, and a block (an Xform over a mesh)."""
    pi = UsdGeom.PointInstancer.Define(stage, "/World/Pebbles")
    v, faces = sphere(radius=0.1, rings=6, segments=8)
    pebble = mesh(stage, "/World/Pebbles/Prototypes/Pebble", v, faces, looks["clay"])
    pebble.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.02, 0.0))
    UsdGeom.Xform.Define(stage, "/World/Pebbles/Prototypes/Block")
    v, faces, _ = cube()
    mesh(stage, "/World/Pebbles/Prototypes/Block/Body", [tuple(0.2 * c + (0.1 if i == 1 else 0) for i, c in enumerate(p)) for p in v], faces, looks["gold"])
    pi.CreatePrototypesRel().SetTargets(["/World/Pebbles/Prototypes/Pebble", "/World/Pebbles/Prototypes/Block"])
    pi.CreateProtoIndicesAttr([p[0] for p in PEBBLES])
    pi.CreatePositionsAttr([Gf.Vec3f(*p[1]) for p in PEBBLES])
    pi.CreateOrientationsAttr([Gf.Quath(p[2][0], Gf.Vec3h(*p[2][1:])) for p in PEBBLES])
    pi.CreateScalesAttr([Gf.Vec3f(*(p[3] if isinstance(p[3], tuple) else (p[3],) * 3)) for p in PEBBLES])
    pi.CreateVelocitiesAttr([Gf.Vec3f(*(PEBBLE_VELOCITY if i == 5 else (0, 0, 0))) for i in range(len(PEBBLES))])
    pi.CreateIdsAttr([10 + i for i in range(len(PEBBLES))])
    pi.CreateInvisibleIdsAttr([13])


# The shot camera: moving during the shutter, a 35 mm lens on a 36 mm aperture (USD's tenths of
# a scene unit: 0.35 and 0.36 in this stage of metres), f/2.8 focused at 3 m, clipping range.
SHOT_CAMERA = dict(keys={1: (0.0, 1.25, 1.2), 2: (0.3, 1.25, 1.2)}, tilt=-5.0, focal=0.35,
                   aperture=0.36, f_stop=2.8, focus=3.0, clip=(0.5, 100.0))


# The same camera zooming from 35 to 70 mm while its focus is pulled from 2 to 4 m, both keyed
# at time codes 0 and 2: at frame 1 its lens is halfway (USD interpolates linearly), 52.5 mm
# focused at 3 m.
ZOOM = dict(focal={0: 0.35, 2: 0.70}, focus={0: 2.0, 2: 4.0}, at_frame_1=(0.525, 3.0))


def shot_camera(stage):
    for path in ["/World/ShotCam", "/World/ZoomCam"]:
        cam = UsdGeom.Camera.Define(stage, path)
        op = cam.AddTranslateOp()
        for frame, at in SHOT_CAMERA["keys"].items():
            op.Set(Gf.Vec3d(*at), frame)
        cam.AddRotateXOp().Set(SHOT_CAMERA["tilt"])
        cam.CreateHorizontalApertureAttr(SHOT_CAMERA["aperture"])
        cam.CreateFStopAttr(SHOT_CAMERA["f_stop"])
        cam.CreateClippingRangeAttr(Gf.Vec2f(*SHOT_CAMERA["clip"]))
        focal, focus = cam.CreateFocalLengthAttr(), cam.CreateFocusDistanceAttr()
        if path == "/World/ShotCam":
            focal.Set(SHOT_CAMERA["focal"])
            focus.Set(SHOT_CAMERA["focus"])
            continue
        for code, value in ZOOM["focal"].items():
            focal.Set(value, code)
        for code, value in ZOOM["focus"].items():
            focus.Set(value, code)


def camera_shots():
    """The set framed by its USD camera (cam_usda.toml), and by the same camera written as the
    shot file's own (cam_toml.toml, from set_toml.toml's scene); the zooming camera likewise
    (zoom_usda.toml), against the shot file's camera with its lens at frame 1 (zoom_toml.toml)."""
    header, usd = SHOT.split("[camera]")[0], "[camera]\nresolution = [96, 64]\n"
    render = "[render]" + SHOT.split("[render]")[1]
    c = SHOT_CAMERA
    keys = ", ".join(f"{{ frame = {f}, position = {list(p)}, rotation_degrees = [{c['tilt']}, 0.0, 0.0] }}"
                     for f, p in c["keys"].items())
    text = open(os.path.join(OUT, "set_toml.toml")).read()
    scene = text.split("[render]")[1]
    scene = scene[scene.index("\n[["):]
    for name, prim, (focal, focus) in [("cam", "ShotCam", (c["focal"], c["focus"])),
                                       ("zoom", "ZoomCam", ZOOM["at_frame_1"])]:
        with open(os.path.join(OUT, f"{name}_usda.toml"), "w") as f:
            f.write(header + usd + f'usd = "/World/{prim}"\n\n' + render + '\n[[usd]]\nfile = "set.usda"\n')
        own = (usd + f"focal_length_mm = {focal * 100}\nsensor_width_mm = {c['aperture'] * 100}\n"
               f"fstop = {c['f_stop']}\nfocus_distance = {focus}\n"
               f"[camera.clip]\nnear = {c['clip'][0]}\nfar = {c['clip'][1]}\n"
               f'[camera.transform]\ninterpolation = "linear"\nkeys = [{keys}]\n\n')
        with open(os.path.join(OUT, f"{name}_toml.toml"), "w") as f:
            f.write(header + own + render + scene)


def write_stage(path, texture):
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    stage.SetTimeCodesPerSecond(24)
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(2)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    looks = {
        "white": preview_material(stage, "/World/Looks/White", diffuse=(0.75, 0.75, 0.75)),
        "red": preview_material(stage, "/World/Looks/Red", diffuse=(0.65, 0.08, 0.06), occlusion=0.8),
        "green": preview_material(stage, "/World/Looks/Green", diffuse=(0.12, 0.5, 0.1)),
        "checker": preview_material(stage, "/World/Looks/Checker", texture=texture),
        "gold": preview_material(stage, "/World/Looks/Gold", diffuse=(1.0, 0.78, 0.34), metallic=1.0, roughness=0.3),
        "panel": preview_material(stage, "/World/Looks/Panel", diffuse=(0.0, 0.0, 0.0), emissive=(3.0, 2.5, 2.0)),
        "clay": preview_material(stage, "/World/Looks/Clay", diffuse=(0.5, 0.45, 0.4), roughness=0.8),
    }
    v, faces, parts = room()
    r = mesh(stage, "/World/Room", v, faces, looks["white"])
    for name in ("red", "green"):
        subset = UsdGeom.Subset.Define(stage, f"/World/Room/{name}")
        subset.CreateElementTypeAttr("face")
        subset.CreateFamilyNameAttr("materialBind")
        subset.CreateIndicesAttr(parts[name])
        UsdShade.MaterialBindingAPI.Apply(subset.GetPrim()).Bind(looks[name])

    props = UsdGeom.Xform.Define(stage, "/World/Props")
    props.AddTranslateOp().Set(Gf.Vec3d(*BOX_PARENT["translate"]))
    props.AddRotateYOp().Set(BOX_PARENT["rotate_y"])
    props.AddScaleOp().Set(Gf.Vec3f(*BOX_PARENT["scale"]))
    v, faces, uv = cube()
    box = mesh(stage, "/World/Props/Box", v, faces, looks["checker"])
    box.AddTranslateOp().Set(Gf.Vec3d(*BOX_LOCAL))
    box.AddScaleOp().Set(Gf.Vec3f(BOX_SIZE, BOX_SIZE, BOX_SIZE))
    st = UsdGeom.PrimvarsAPI(box).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
    st.Set([Gf.Vec2f(*t) for t in uv])

    v, faces = sphere()
    ball = mesh(stage, "/World/Ball", v, faces, looks["gold"])
    ball.CreateNormalsAttr([Gf.Vec3f(*sphere_normal(p)) for p in v])
    ball.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    op = ball.AddTranslateOp()
    for frame, at in BALL_KEYS.items():
        op.Set(Gf.Vec3d(*at), frame)

    blob1, blob_faces = blob(1)
    b = mesh(stage, "/World/Blob", blob1, blob_faces, looks["clay"])
    b.AddTranslateOp().Set(Gf.Vec3d(*BLOB_AT))
    points = b.GetPointsAttr()
    for frame in (1, 2):
        points.Set([Gf.Vec3f(*p) for p in blob(frame)[0]], frame)

    c, w, h = PANEL["center"], PANEL["width"] / 2, PANEL["height"] / 2
    mesh(stage, "/World/Panel", [(c[0] - w, c[1] - h, c[2]), (c[0] + w, c[1] - h, c[2]), (c[0] + w, c[1] + h, c[2]), (c[0] - w, c[1] + h, c[2])], [(0, 1, 2, 3)], looks["panel"])

    # Scene-graph instancing: two instanceable crates sharing one prototype (a class).
    proto = stage.CreateClassPrim("/Prototypes/Crate")
    v, faces, _ = cube()
    crate = mesh(stage, "/Prototypes/Crate/Body", [tuple(CRATE_SIZE * c + (CRATE_SIZE / 2 if i == 1 else 0) for i, c in enumerate(p)) for p in v], faces, looks["clay"])
    for i, at in enumerate(CRATES):
        inst = UsdGeom.Xform.Define(stage, f"/World/Crate{i}")
        inst.GetPrim().GetInherits().AddInherit(proto.GetPath())
        inst.GetPrim().SetInstanceable(True)
        inst.AddTranslateOp().Set(Gf.Vec3d(*at))

    point_instancer(stage, looks)

    # What a render leaves out: a proxy and an invisible mesh, both in the camera's view.
    proxy = mesh(stage, "/World/Proxy", [(-0.3, 0.5, -1.5), (0.3, 0.5, -1.5), (0, 1.0, -1.5)], [(0, 1, 2)], looks["red"])
    proxy.CreatePurposeAttr(UsdGeom.Tokens.proxy)
    hidden = mesh(stage, "/World/Hidden", [(-0.3, 1.2, -1.5), (0.3, 1.2, -1.5), (0, 1.7, -1.5)], [(0, 1, 2)], looks["red"])
    hidden.CreateVisibilityAttr(UsdGeom.Tokens.invisible)
    UsdGeom.Camera.Define(stage, "/World/Camera")
    shot_camera(stage)

    key = UsdLux.RectLight.Define(stage, "/World/Lights/Key")
    key.AddTranslateOp().Set(Gf.Vec3d(*KEY_LIGHT["position"]))
    key.AddRotateXOp().Set(-90.0)
    key.CreateWidthAttr(KEY_LIGHT["width"])
    key.CreateHeightAttr(KEY_LIGHT["height"])
    key.CreateIntensityAttr(KEY_LIGHT["intensity"])
    fill = UsdLux.SphereLight.Define(stage, "/World/Lights/Fill")
    fill.AddTranslateOp().Set(Gf.Vec3d(*FILL["position"]))
    fill.CreateRadiusAttr(FILL["radius"])
    fill.CreateIntensityAttr(FILL["intensity"])
    fill.CreateColorAttr(Gf.Vec3f(*FILL["color"]))
    spot = UsdLux.SphereLight.Define(stage, "/World/Lights/Spot")
    spot.AddTranslateOp().Set(Gf.Vec3d(*SPOT["position"]))
    spot.AddRotateXOp().Set(-90.0)
    spot.CreateRadiusAttr(SPOT["radius"])
    spot.CreateIntensityAttr(SPOT["intensity"])
    shaping = UsdLux.ShapingAPI.Apply(spot.GetPrim())
    shaping.CreateShapingConeAngleAttr(SPOT["cone"])
    shaping.CreateShapingConeSoftnessAttr(SPOT["softness"])
    stage.GetRootLayer().Save()
    return stage


# --- the same set without USD -----------------------------------------------------------------

def write_pebbles():
    """Each visible pebble as its own OBJ, placed by usd-core's own instance transforms (the
    moving one at the shutter's opening, keyed to where its velocity takes it at its close);
    their [[object]] sections."""
    stage = Usd.Stage.Open(os.path.join(OUT, "set.usda"))
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/World/Pebbles"))
    xforms = pi.ComputeInstanceTransformsAtTime(1.0, 1.0, UsdGeom.PointInstancer.IncludeProtoXform, UsdGeom.PointInstancer.IgnoreMask)
    prototypes = ["/World/Pebbles/Prototypes/Pebble", "/World/Pebbles/Prototypes/Block/Body"]
    sections = []
    for i, m in enumerate(xforms):
        if i == 3:
            continue
        kind = PEBBLES[i][0]
        body = UsdGeom.Mesh(stage.GetPrimAtPath(prototypes[kind]))
        inner = body.GetLocalTransformation() if kind == 1 else Gf.Matrix4d(1.0)
        points = [inner.Transform(Gf.Vec3d(p)) for p in body.GetPointsAttr().Get(1.0)]
        faces, counts = body.GetFaceVertexIndicesAttr().Get(), body.GetFaceVertexCountsAttr().Get()
        polys, at = [], 0
        for n in counts:
            polys.append(tuple(faces[at:at + n]))
            at += n
        material = "/World/Looks/Gold" if kind == 1 else "/World/Looks/Clay"
        name = f"pebble{i}"
        if i == 5:
            # Object space (its orientation and scale are the identity), keyed positions.
            t = m.ExtractTranslation()
            write_obj(os.path.join(OUT, f"{name}.obj"), [(material, [tuple(p) for p in points], polys, None)])
            end = [t[k] + PEBBLE_VELOCITY[k] * 0.5 / 24.0 for k in range(3)]
            keys = f"{{ frame = 1, position = {list(t)} }}, {{ frame = 1.5, position = {end} }}"
            sections.append(f'[[object]]\nname = "{name}"\nmesh = "{name}.obj"\ntransform = {{ interpolation = "linear", keys = [{keys}] }}\n')
        else:
            placed = [tuple(m.Transform(p)) for p in points]
            write_obj(os.path.join(OUT, f"{name}.obj"), [(material, placed, polys, None)])
            sections.append(f'[[object]]\nname = "{name}"\nmesh = "{name}.obj"\n')
    return "\n".join(sections)


def rotate_y(p, degrees):
    a = math.radians(degrees)
    return (p[0] * math.cos(a) + p[2] * math.sin(a), p[1], -p[0] * math.sin(a) + p[2] * math.cos(a))


def box_world(p):
    local = tuple(BOX_LOCAL[i] + BOX_SIZE * p[i] for i in range(3))
    scaled = tuple(local[i] * BOX_PARENT["scale"][i] for i in range(3))
    turned = rotate_y(scaled, BOX_PARENT["rotate_y"])
    return tuple(turned[i] + BOX_PARENT["translate"][i] for i in range(3))


def fan(face):
    return [(face[0], face[k], face[k + 1]) for k in range(1, len(face) - 1)]


def write_obj(path, groups, normals=None):
    """groups: [(material, vertices, faces, face corner uvs or None)]; normals: one per vertex
    of a single group, or None."""
    lines, base, tbase = [], 1, 1
    if normals is not None:
        lines += [f"vn {x:.9g} {y:.9g} {z:.9g}" for x, y, z in normals]
    for material, v, faces, corner_uv in groups:
        lines += [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in v]
        lines.append(f"usemtl {material}")
        corner = 0
        for f in faces:
            for tri in fan(list(range(len(f)))):
                if corner_uv is None and normals is None:
                    lines.append("f " + " ".join(str(base + f[k]) for k in tri))
                elif corner_uv is None:
                    lines.append("f " + " ".join(f"{base + f[k]}//{base + f[k]}" for k in tri))
                else:
                    lines.append("f " + " ".join(f"{base + f[k]}/{tbase + corner + k}" for k in tri))
            corner += len(f)
        if corner_uv is not None:
            lines += [f"vt {u} {t}" for u, t in corner_uv]
            tbase += len(corner_uv)
        base += len(v)
    with open(path, "w") as out:
        out.write("\n".join(lines) + "\n")


SHOT = """[shot]
name = "usd_set"
fps = 24.0
frames = [1, 2]
shutter = [0.0, 0.5]

[camera]
resolution = [96, 64]
fov_degrees = 55.0
[camera.transform]
position = [0.0, 1.25, 1.2]
look_at = [0.0, 1.0, -2.0]

[render]
spp = 64
seed = 1
max_bounces = 6
"""


def write_toml_scene():
    v, faces, parts = room()
    by_part = {name: [faces[i] for i in idx] for name, idx in parts.items()}
    write_obj(os.path.join(OUT, "room.obj"), [(f"/World/Looks/{n.capitalize()}", v, by_part[n], None) for n in ("white", "red", "green")])
    v, faces, uv = cube()
    write_obj(os.path.join(OUT, "box.obj"), [("/World/Looks/Checker", [box_world(p) for p in v], faces, uv)])
    v, faces = sphere()
    write_obj(os.path.join(OUT, "ball.obj"), [("/World/Looks/Gold", v, faces, None)], [sphere_normal(p) for p in v])
    for frame in (1, 2):
        v, faces = blob(frame)
        v = [tuple(p[i] + BLOB_AT[i] for i in range(3)) for p in v]
        write_obj(os.path.join(OUT, f"blob.{frame:04d}.obj"), [("/World/Looks/Clay", v, faces, None)])
    v, faces, _ = cube()
    for i, at in enumerate(CRATES):
        placed = [tuple(CRATE_SIZE * c + (CRATE_SIZE / 2 if k == 1 else 0) + at[k] for k, c in enumerate(p)) for p in v]
        write_obj(os.path.join(OUT, f"crate{i}.obj"), [("/World/Looks/Clay", placed, faces, None)])
    pebble_objects = write_pebbles()
    c, w, h = PANEL["center"], PANEL["width"] / 2, PANEL["height"] / 2
    write_obj(os.path.join(OUT, "panel.obj"), [("/World/Looks/Panel", [(c[0] - w, c[1] - h, c[2]), (c[0] + w, c[1] - h, c[2]), (c[0] + w, c[1] + h, c[2]), (c[0] - w, c[1] + h, c[2])], [(0, 1, 2, 3)], None)])
    ball_keys = ", ".join(f"{{ frame = {f}, position = [{p[0]}, {p[1]}, {p[2]}] }}" for f, p in BALL_KEYS.items())
    text = SHOT + f"""
[[material]]
name = "/World/Looks/White"
type = "standard"
base_color = [0.75, 0.75, 0.75]
[[material]]
name = "/World/Looks/Red"
type = "standard"
base_color = [0.65, 0.08, 0.06]
[[material]]
name = "/World/Looks/Green"
type = "standard"
base_color = [0.12, 0.5, 0.1]
[[material]]
name = "/World/Looks/Checker"
type = "standard"
base_color = {{ texture = "checker.png", colorspace = "srgb" }}
[[material]]
name = "/World/Looks/Gold"
type = "standard"
base_color = [1.0, 0.78, 0.34]
metallic = 1.0
roughness = 0.3
[[material]]
name = "/World/Looks/Panel"
type = "standard"
base_color = [0.0, 0.0, 0.0]
emission = [3.0, 2.5, 2.0]
[[material]]
name = "/World/Looks/Clay"
type = "standard"
base_color = [0.5, 0.45, 0.4]
roughness = 0.8

[[object]]
name = "/World/Room"
mesh = "room.obj"
[[object]]
name = "/World/Props/Box"
mesh = "box.obj"
[[object]]
name = "/World/Ball"
mesh = "ball.obj"
transform = {{ interpolation = "linear", keys = [{ball_keys}] }}
[[object]]
name = "/World/Blob"
mesh = "blob.####.obj"
[[object]]
name = "/World/Panel"
mesh = "panel.obj"
[[object]]
name = "/World/Crate0/Body"
mesh = "crate0.obj"
[[object]]
name = "/World/Crate1/Body"
mesh = "crate1.obj"
{pebble_objects}
[[light]]
name = "/World/Lights/Key"
type = "rect"
width = {KEY_LIGHT["width"]}
height = {KEY_LIGHT["height"]}
intensity = {KEY_LIGHT["intensity"]}
transform = {{ position = {list(KEY_LIGHT["position"])}, rotation_degrees = [-90.0, 0.0, 0.0] }}
[[light]]
name = "/World/Lights/Fill"
type = "point"
radius = {FILL["radius"]}
intensity = {FILL["intensity"]}
color = {list(FILL["color"])}
transform = {{ position = {list(FILL["position"])} }}
[[light]]
name = "/World/Lights/Spot"
type = "spot"
radius = {SPOT["radius"]}
intensity = {SPOT["intensity"]}
cone_angle = {SPOT["cone"]}
cone_softness = {SPOT["softness"]}
transform = {{ position = {list(SPOT["position"])}, rotation_degrees = [-90.0, 0.0, 0.0] }}
"""
    with open(os.path.join(OUT, "set_toml.toml"), "w") as f:
        f.write(text)


write_png(os.path.join(OUT, "checker.png"))
usda = os.path.join(OUT, "set.usda")
write_stage(usda, "checker.png")
stage = Usd.Stage.Open(usda)
stage.Export(os.path.join(OUT, "set.usdc"))
# The package holds its layer and the texture it names.
UsdUtils.CreateNewUsdzPackage(Sdf.AssetPath(usda), os.path.join(OUT, "set.usdz"))
for kind in ("usda", "usdc", "usdz"):
    with open(os.path.join(OUT, f"set_{kind}.toml"), "w") as f:
        f.write(SHOT + f'\n[[usd]]\nfile = "set.{kind}"\n')
write_toml_scene()
camera_shots()
print("ok")
