"""Blender headless check of the GLB a run writes from the rigged FBX of tests/data (tests/blender/make_rig_fbx.py).

Run by gltf_test's Blender case:
  blender -b --factory-startup --python-exit-code 1 -P check_fbx_rig.py -- MODEL.glb MODEL.obj
Imports the GLB and checks that the FBX's rig came through: the armature with the bones root and tip, the mesh
skinned to it and deformed when the tip turns, the shape key, the FBX's two UV layers and the montage's third with
the material's image on it; the bind pose in the same place as the OBJ's mesh. Any failure raises (exit code 1).
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from blender_check import check, import_rig  # noqa: E402  (also restores numpy.bool for the glTF importer)

import bpy  # noqa: E402
from mathutils import Euler, Vector  # noqa: E402


def world_box(ob):
    depsgraph = bpy.context.evaluated_depsgraph_get()
    ev = ob.evaluated_get(depsgraph)
    points = [ev.matrix_world @ v.co for v in ev.data.vertices]
    return Vector([min(p[i] for p in points) for i in range(3)]), Vector([max(p[i] for p in points) for i in range(3)])


glb, obj = sys.argv[sys.argv.index("--") + 1:][:2]

arm, ob = import_rig(glb, ["root", "tip"])
keys = [k.name for k in ob.data.shape_keys.key_blocks] if ob.data.shape_keys else []
check("bulge" in keys, f"GLB: the shape key ({keys})")
check(len(ob.data.uv_layers) == 3, f"GLB: three UV layers ({[u.name for u in ob.data.uv_layers]})")
mat = ob.data.materials[0]
check(mat.name == "skin_material", f"GLB: material name ({mat.name})")
images = [n for n in mat.node_tree.nodes if n.type == "TEX_IMAGE" and n.image is not None]
uvmaps = [n for n in mat.node_tree.nodes if n.type == "UVMAP"]
check(len(images) == 1 and len(uvmaps) == 1 and uvmaps[0].uv_map == ob.data.uv_layers[2].name,
      "GLB: the montage's image on the third UV layer")

# The bind pose (the animation taken off) is where the OBJ has the mesh, and the tip bone deforms it.
arm.animation_data_clear()
for pose in arm.pose.bones:
    pose.rotation_mode = "XYZ"
    pose.rotation_euler = Euler((0, 0, 0))
    pose.location = (0, 0, 0)
    pose.scale = (1, 1, 1)
bpy.context.view_layer.update()
glb_box = world_box(ob)
arm.pose.bones["tip"].rotation_euler = Euler((0.8, 0, 0))
bpy.context.view_layer.update()
posed_box = world_box(ob)
moved = max((glb_box[0] - posed_box[0]).length, (glb_box[1] - posed_box[1]).length)
check(moved > 10, f"GLB: turning the tip bone moves the mesh (its box by {moved:.1f} of 200)")

bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.wm.obj_import(filepath=obj)
obj_box = world_box([o for o in bpy.data.objects if o.type == "MESH"][0])
apart = max((glb_box[0] - obj_box[0]).length, (glb_box[1] - obj_box[1]).length)
check(apart < 0.01, f"GLB: the bind pose is where the OBJ has the mesh (boxes {apart:.4f} apart)")
print("all checks passed")
