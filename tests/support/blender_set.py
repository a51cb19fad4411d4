"""Builds a small set in Blender (pip bpy) and writes it with Blender's own USD exporter, as a
client's files arrive, for tests/usd_scenes.rs:

    python3 tests/support/blender_set.py OUT_DIR

OUT_DIR gets blender.usda (Blender's Z-up stage) and its texture: a floor with an image
texture made here, a gold metal sphere, a diffuse cube, 300 pebbles (instances of one
collection, written as instanceable prims), point, spot, area and sun lights, and a camera;
also blender.blend (the scene itself, for Cycles: tools/blender_vs_cycles.py) and camera.toml
(the camera as a rift shot's [camera] section).
"""
import math
import os
import sys

import bpy

out = sys.argv[-1]
os.makedirs(out, exist_ok=True)
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
# Texture image made here.
img = bpy.data.images.new("checker", 64, 64)
px = []
for y in range(64):
    for x in range(64):
        on = ((x // 8) + (y // 8)) % 2
        px += [0.9, 0.5, 0.1, 1.0] if on else [0.2, 0.2, 0.2, 1.0]
img.pixels = px
img.filepath_raw = os.path.join(out, "checker.png")
img.file_format = "PNG"
img.save()

def material(name, color=(0.8, 0.8, 0.8), metallic=0.0, roughness=0.5, texture=None):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    bsdf = m.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    bsdf.inputs["Metallic"].default_value = metallic
    bsdf.inputs["Roughness"].default_value = roughness
    if texture:
        tex = m.node_tree.nodes.new("ShaderNodeTexImage")
        tex.image = texture
        m.node_tree.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    return m

bpy.ops.mesh.primitive_plane_add(size=6)
floor = bpy.context.object
floor.data.materials.append(material("Floor", texture=img))
bpy.ops.mesh.primitive_uv_sphere_add(radius=0.5, location=(-0.8, 0, 0.5))
bpy.context.object.data.materials.append(material("Gold", (1.0, 0.78, 0.34), 1.0, 0.3))
# Shaded smooth, as a modeller leaves a sphere: the exporter writes its normals per corner.
bpy.ops.object.shade_smooth()
bpy.ops.mesh.primitive_cube_add(size=0.8, location=(0.8, 0.3, 0.4))
bpy.context.object.data.materials.append(material("Clay", (0.5, 0.45, 0.4), 0.0, 0.8))
# Pebbles: one collection (a flattened sphere), instanced 300 times over the floor's front half.
pebbles = bpy.data.collections.new("Pebble")
bpy.ops.mesh.primitive_uv_sphere_add(radius=0.06, segments=10, ring_count=6, location=(0, 0, 0))
pebble = bpy.context.object
pebble.scale = (1.0, 1.0, 0.6)
pebble.data.materials.append(material("Stone", (0.35, 0.33, 0.3), 0.0, 0.9))
for c in pebble.users_collection:
    c.objects.unlink(pebble)
pebbles.objects.link(pebble)
for i in range(300):
    inst = bpy.data.objects.new(f"Pebble{i:03d}", None)
    inst.instance_type = "COLLECTION"
    inst.instance_collection = pebbles
    # A low-discrepancy spread over x in [-2.5, 2.5], y in [-2.5, -0.6], turned about z.
    u, v = (i * 0.618034) % 1.0, (i * 0.754878 + 0.5) % 1.0
    inst.location = (-2.5 + 5.0 * u, -2.5 + 1.9 * v, 0.03)
    inst.rotation_euler = (0.0, 0.0, i * 2.399963)
    inst.scale = (1.0 + 0.5 * ((i * 0.381966) % 1.0),) * 3
    scene.collection.objects.link(inst)
bpy.ops.object.light_add(type="POINT", location=(0, -1.5, 2.0)); bpy.context.object.data.energy = 200
bpy.ops.object.light_add(type="SPOT", location=(1.5, -1.5, 2.5), rotation=(math.radians(40), 0, math.radians(45))); bpy.context.object.data.energy = 300
bpy.ops.object.light_add(type="AREA", location=(0, 0, 3)); bpy.context.object.data.energy = 100; bpy.context.object.data.size = 1.0
bpy.ops.object.light_add(type="SUN", rotation=(math.radians(30), 0, 0)); bpy.context.object.data.energy = 2
bpy.ops.object.camera_add(location=(0, -5, 2.5), rotation=(math.radians(65), 0, 0))
scene.camera = bpy.context.object
# The camera dollies in and pans over the shot's 24 frames (keyed at the first and last).
cam = scene.camera
cam.keyframe_insert("location", frame=1)
cam.keyframe_insert("rotation_euler", frame=1)
cam.location = (1.0, -3.5, 2.0)
cam.rotation_euler = (math.radians(70), 0, math.radians(15))
cam.keyframe_insert("location", frame=24)
cam.keyframe_insert("rotation_euler", frame=24)
scene.frame_start, scene.frame_end = 1, 24
scene.frame_set(1)
scene.render.resolution_x, scene.render.resolution_y = 160, 90
bpy.ops.wm.usd_export(filepath=os.path.join(out, "blender.usda"), export_materials=True,
                      use_instancing=True, export_animation=True)
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(out, "blender.blend"))
# The camera at frame 1 as rift's shot file has it (the stage's own Z-up axes): where it is, a
# point it looks at, its up, and its lens (Blender's sensor fits the image's width here).
cam = scene.camera
m = cam.matrix_world
at = m.translation - m.col[2].xyz
with open(os.path.join(out, "camera.toml"), "w") as f:
    f.write(f"""[camera]
resolution = [{scene.render.resolution_x}, {scene.render.resolution_y}]
focal_length_mm = {cam.data.lens}
sensor_width_mm = {cam.data.sensor_width}
[camera.transform]
position = [{m.translation.x}, {m.translation.y}, {m.translation.z}]
look_at = [{at.x}, {at.y}, {at.z}]
up = [{m.col[1].x}, {m.col[1].y}, {m.col[1].z}]
""")
print("exported")
