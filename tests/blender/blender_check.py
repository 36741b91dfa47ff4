"""What the Blender check scripts share: numpy's bool alias for Blender 3.4's glTF importer, and one line per check."""
import numpy

# Blender 3.4's glTF importer uses numpy.bool, which numpy 1.24 removed.
if "bool" not in numpy.__dict__:
    numpy.bool = bool


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        raise SystemExit(1)


def import_rig(glb, bones):
    """Imports GLB into an empty scene and checks one armature with `bones` (names) and one mesh skinned to it;
    returns (armature, mesh object)."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=glb)
    armatures = [o for o in bpy.data.objects if o.type == "ARMATURE"]
    meshes = [o for o in bpy.data.objects if o.type == "MESH"]
    check(len(armatures) == 1 and len(meshes) == 1, f"GLB: one armature and one mesh ({len(armatures)}, {len(meshes)})")
    arm, ob = armatures[0], meshes[0]
    names = sorted(b.name for b in arm.data.bones)
    check(names == sorted(bones), f"GLB: bones {names}")
    check(any(m.type == "ARMATURE" and m.object == arm for m in ob.modifiers), "GLB: the mesh is skinned to the armature")
    return arm, ob
