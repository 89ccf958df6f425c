# Converts a BVH file into FBX (binary, as Blender and Autodesk's tools write it), glTF binary
# or COLLADA with Blender's own importer and exporters, to test the readers on files another
# program wrote:
#   blender -b --factory-startup --python blender_convert.py -- IN.bvh OUT.{fbx,glb,dae}
import builtins
import sys

import numpy

# Debian 12's Blender 3.4 add-ons predate its numpy 1.24 (np.bool) and Python 3.11 (open mode
# "U"); both shims only restore what those add-ons expect.
numpy.bool = bool
_open = builtins.open


def _open_without_u(file, mode="r", *args, **kwargs):
    return _open(file, mode.replace("U", ""), *args, **kwargs)


builtins.open = _open_without_u

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
    sys.exit("blender_convert.py: write .fbx, .glb or .dae, not " + target)
