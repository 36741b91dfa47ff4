# Makes tests/data/rig.fbx: a cylinder of quads on a two-bone armature (automatic weights), a shape key, a second
# UV set, vertex colours, a material and a short animation of the upper bone; exported as binary FBX.
#   blender --background --factory-startup --python tests/blender/make_rig_fbx.py -- tests/data/rig.fbx
# (Blender 3.4, Debian bookworm).
import sys

import bpy

out = sys.argv[sys.argv.index("--") + 1]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.mesh.primitive_cylinder_add(vertices=16, radius=0.5, depth=2, location=(0, 0, 1))
body = bpy.context.active_object
body.name = "body"
body.data.name = "body_mesh"
bpy.ops.object.mode_set(mode="EDIT")
bpy.ops.mesh.select_all(action="DESELECT")
bpy.ops.object.mode_set(mode="OBJECT")
for e in body.data.edges:  # the vertical edges, cut into 4 rings
    a, b = (body.data.vertices[i].co for i in e.vertices)
    e.select = abs(a.z - b.z) > 1.5
bpy.ops.object.mode_set(mode="EDIT")
bpy.ops.mesh.subdivide(number_cuts=3)
bpy.ops.object.mode_set(mode="OBJECT")
body.data.uv_layers[0].name = "main"
detail = body.data.uv_layers.new(name="detail")
for loop in body.data.loops:
    co = body.data.vertices[loop.vertex_index].co
    detail.data[loop.index].uv = (0.5 + 0.4 * co.x, 0.5 + 0.4 * co.y)
colours = body.data.color_attributes.new("tint", "BYTE_COLOR", "CORNER")
for loop in body.data.loops:
    z = body.data.vertices[loop.vertex_index].co.z
    colours.data[loop.index].color = (0.2 + 0.4 * z, 0.5, 1.0 - 0.4 * z, 1.0)
material = bpy.data.materials.new("skin_material")
material.diffuse_color = (0.8, 0.6, 0.5, 1)
body.data.materials.append(material)

bpy.ops.object.armature_add(location=(0, 0, 0))
rig = bpy.context.active_object
rig.name = "rig"
bpy.ops.object.mode_set(mode="EDIT")
root = rig.data.edit_bones[0]
root.name = "root"
root.head, root.tail = (0, 0, 0), (0, 0, 1)
tip = rig.data.edit_bones.new("tip")
tip.head, tip.tail = (0, 0, 1), (0, 0, 2)
tip.parent = root
bpy.ops.object.mode_set(mode="OBJECT")
bpy.ops.object.select_all(action="DESELECT")
body.select_set(True)
rig.select_set(True)
bpy.context.view_layer.objects.active = rig
bpy.ops.object.parent_set(type="ARMATURE_AUTO")

body.shape_key_add(name="Basis")
bulge = body.shape_key_add(name="bulge")
for v, k in zip(body.data.vertices, bulge.data):
    s = 1 + 0.3 * max(0.0, 1 - abs(v.co.z - 1))
    k.co = (v.co.x * s, v.co.y * s, v.co.z)

bone = rig.pose.bones["tip"]
bone.rotation_mode = "XYZ"
for frame, angle in ((1, 0.0), (20, 0.6), (40, 0.0)):
    bone.rotation_euler = (angle, 0, 0)
    bone.keyframe_insert("rotation_euler", frame=frame)

bpy.ops.export_scene.fbx(filepath=out, add_leaf_bones=False, bake_anim=True, mesh_smooth_type="FACE")
