# Blender reads a BVH and writes its animation back as BVH, to check what Blender reads of a file
# the project wrote:
#   blender -b --factory-startup --python blender_bvh_roundtrip.py -- IN.bvh OUT.bvh
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import blender_shims  # noqa: E402,F401  (before bpy)
import bpy  # noqa: E402

source, target = sys.argv[sys.argv.index("--") + 1:][:2]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_anim.bvh(filepath=source, axis_forward="-Z", axis_up="Y", update_scene_fps=True,
                        update_scene_duration=True)
armatures = [o for o in bpy.data.objects if o.type == "ARMATURE"]
action = bpy.data.actions[0]
print("blender read %d armature(s), %d bones, frames %d..%d" % (
    len(armatures), len(armatures[0].data.bones), action.frame_range[0], action.frame_range[1]))
bpy.context.view_layer.objects.active = armatures[0]
bpy.ops.export_anim.bvh(filepath=target, frame_start=int(action.frame_range[0]),
                        frame_end=int(action.frame_range[1]), root_transform_only=False)
