"""Builds a small set in Blender (pip bpy) and writes it with Blender's own USD exporter, as a
client's files arrive, for tests/usd_scenes.rs:

    python3 tests/support/blender_set.py OUT_DIR

OUT_DIR gets blender.usda (Blender's Z-up stage) and its texture: a floor with an image
texture made here, a gold metal sphere, a diffuse cube, point, spot, area and sun lights, and a
camera.
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
bpy.ops.mesh.primitive_cube_add(size=0.8, location=(0.8, 0.3, 0.4))
bpy.context.object.data.materials.append(material("Clay", (0.5, 0.45, 0.4), 0.0, 0.8))
bpy.ops.object.light_add(type="POINT", location=(0, -1.5, 2.0)); bpy.context.object.data.energy = 200
bpy.ops.object.light_add(type="SPOT", location=(1.5, -1.5, 2.5), rotation=(math.radians(40), 0, math.radians(45))); bpy.context.object.data.energy = 300
bpy.ops.object.light_add(type="AREA", location=(0, 0, 3)); bpy.context.object.data.energy = 100; bpy.context.object.data.size = 1.0
bpy.ops.object.light_add(type="SUN", rotation=(math.radians(30), 0, 0)); bpy.context.object.data.energy = 2
bpy.ops.object.camera_add(location=(0, -5, 2.5), rotation=(math.radians(65), 0, 0))
scene.camera = bpy.context.object
bpy.ops.wm.usd_export(filepath=os.path.join(out, "blender.usda"), export_materials=True)
print("exported")
