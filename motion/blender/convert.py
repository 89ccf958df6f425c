# Converts a BVH file into FBX (binary, as Blender and Autodesk's tools write it), glTF binary
# or COLLADA with Blender's own importer and exporters: `ragdoll bake --out FILE.fbx` runs it on
# the BVH it bakes (bake refuses .dae, cli/bake_command.cc says why), and the tests make files
# another program wrote with it, COLLADA among them:
#   blender -b --factory-startup --python convert.py -- IN.bvh OUT.{fbx,glb,dae}
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import blender_shims  # noqa: E402,F401  (before bpy)
import bpy  # noqa: E402

source, target = sys.argv[sys.argv.index("--") + 1:][:2]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_anim.bvh(filepath=source, axis_forward="-Z", axis_up="Y", update_scene_fps=True,
                        update_scene_duration=True)
if target.endswith(".fbx"):
    bpy.ops.export_scene.fbx(filepath=target, bake_anim=True, bake_anim_simplify_factor=0.0,
                             add_leaf_bones=False)
elif target.endswith(".glb"):
    bpy.ops.export_scene.gltf(filepath=target, export_format="GLB")
elif target.endswith(".dae"):
    bpy.ops.wm.collada_export(filepath=target)
else:
    sys.exit("convert.py: write .fbx, .glb or .dae, not " + target)
