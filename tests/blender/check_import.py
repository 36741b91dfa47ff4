"""Blender headless check of a run's exports (the GLB written back into a rigged glTF, and the OBJ).

Run by gltf_test's Blender case:
  blender -b --factory-startup --python-exit-code 1 -P check_import.py -- MODEL.glb MODEL.obj RENDER.png
Imports the GLB and checks what an artist relies on: the armature and its two bones, the mesh skinned to it (an
Armature modifier) that deforms when a bone turns, the morph target as a shape key, three UV layers with the
material's image texture on the third (the montage's), custom split normals, vertex colours, the material's name;
renders a frame with Cycles on the CPU and checks that the texture shows. Then imports the OBJ: faces, a textured
material, a UV layer and the file's normals. Prints one line per check; any failure raises (exit code 1).
"""
import os
import sys

import numpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from blender_check import check, import_rig  # noqa: E402  (also restores numpy.bool for the glTF importer)

import bpy  # noqa: E402
from mathutils import Euler  # noqa: E402


glb, obj, render = sys.argv[sys.argv.index("--") + 1:][:3]

arm, ob = import_rig(glb, ["root_bone", "upper_bone"])
me = ob.data
check(len(ob.vertex_groups) >= 2, f"GLB: joint weights as vertex groups ({len(ob.vertex_groups)})")
keys = [k.name for k in me.shape_keys.key_blocks] if me.shape_keys else []
check(len(keys) == 2, f"GLB: the morph target as a shape key ({keys})")
check(len(me.uv_layers) == 3, f"GLB: three UV layers ({[u.name for u in me.uv_layers]})")
check(me.has_custom_normals, "GLB: the file's normals as custom split normals")
check(len(me.color_attributes) >= 1, "GLB: vertex colours")
check(len(me.polygons) == 288, f"GLB: 288 faces ({len(me.polygons)})")
mat = me.materials[0]
check(mat.name == "skin_material", f"GLB: material name ({mat.name})")
images = [n for n in mat.node_tree.nodes if n.type == "TEX_IMAGE"]
uvmaps = [n for n in mat.node_tree.nodes if n.type == "UVMAP"]
check(len(images) == 1 and images[0].image is not None and images[0].image.size[0] >= 64,
      "GLB: the base colour's image texture is linked, with its image")
check(len(uvmaps) == 1 and uvmaps[0].uv_map == me.uv_layers[2].name,
      f"GLB: the texture reads the third UV layer ({uvmaps[0].uv_map if uvmaps else None})")

# The armature deforms the textured mesh: turn the upper bone and compare the evaluated vertices.
depsgraph = bpy.context.evaluated_depsgraph_get()
rest = [v.co.copy() for v in ob.evaluated_get(depsgraph).data.vertices]
arm.pose.bones["upper_bone"].rotation_mode = "XYZ"
arm.pose.bones["upper_bone"].rotation_euler = Euler((0.8, 0, 0))
bpy.context.view_layer.update()
depsgraph = bpy.context.evaluated_depsgraph_get()
posed = [v.co.copy() for v in ob.evaluated_get(depsgraph).data.vertices]
moved = max((a - b).length for a, b in zip(rest, posed))
check(moved > 0.3, f"GLB: turning the upper bone moves the mesh (up to {moved:.2f})")
arm.pose.bones["upper_bone"].rotation_euler = Euler((0, 0, 0))

# A rendered frame shows the texture.
scene = bpy.context.scene
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = 8
scene.cycles.use_denoising = False  # Debian builds Cycles without OpenImageDenoise
scene.render.resolution_x = scene.render.resolution_y = 160
scene.render.film_transparent = True
cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
cam.location = (0, -6.0, 1.0)  # the importer turns glTF's y up into Blender's z up: the cylinder stands on z
cam.rotation_euler = Euler((1.5708, 0, 0))
scene.collection.objects.link(cam)
scene.camera = cam
sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
sun.data.energy = 3
sun.rotation_euler = Euler((1.1, 0, 0.4))
scene.collection.objects.link(sun)
scene.render.filepath = render
bpy.ops.render.render(write_still=True)
img = bpy.data.images.load(render)
px = numpy.array(img.pixels[:]).reshape(-1, 4)
covered = px[px[:, 3] > 0.5][:, :3]
check(len(covered) > 0.1 * len(px), f"render: the mesh covers {len(covered) / len(px):.0%} of the frame")
spread = float(covered.std(axis=0).mean()) if len(covered) else 0
check(spread > 0.03, f"render: the texture shows (colour spread {spread:.3f})")

# The OBJ.
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.wm.obj_import(filepath=obj)
meshes = [o for o in bpy.data.objects if o.type == "MESH"]
check(len(meshes) >= 1, "OBJ: imported")
faces = sum(len(o.data.polygons) for o in meshes)
check(faces == 288, f"OBJ: 288 faces ({faces})")
me = meshes[0].data
check(len(me.uv_layers) == 1, "OBJ: a UV layer")
check(me.has_custom_normals, "OBJ: the file's normals")
mat = me.materials[0]
tex = [n for n in mat.node_tree.nodes if n.type == "TEX_IMAGE" and n.image is not None]
check(len(tex) == 1 and tex[0].image.size[0] >= 64, f"OBJ: material {mat.name} shows its texture")
print("all checks passed")
