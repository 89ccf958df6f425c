# Blender reads an animation file (BVH, FBX, COLLADA, glTF) with its own importer and writes the
# animation back as BVH, to check what Blender reads of a file the project wrote:
#   blender -b --factory-startup --python blender_to_bvh.py -- IN.{bvh,fbx,dae,glb} OUT.bvh [FPS]
# FPS: the scene's frame rate before the import (glTF keys are times, placed on its frames).
import os
import sys

here = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(here, "..", "..", "motion", "blender"))
import blender_shims  # noqa: E402,F401  (before bpy)
import bpy  # noqa: E402

arguments = sys.argv[sys.argv.index("--") + 1:]
source, target = arguments[:2]
bpy.ops.wm.read_factory_settings(use_empty=True)
if len(arguments) > 2:
    bpy.context.scene.render.fps = int(arguments[2])
if source.endswith(".bvh"):
    bpy.ops.import_anim.bvh(filepath=source, axis_forward="-Z", axis_up="Y", update_scene_fps=True,
                            update_scene_duration=True)
elif source.endswith(".fbx"):
    bpy.ops.import_scene.fbx(filepath=source)
elif source.endswith(".dae"):
    bpy.ops.wm.collada_import(filepath=source)
elif source.endswith(".glb"):
    bpy.ops.import_scene.gltf(filepath=source)
else:
    sys.exit("blender_to_bvh.py: read .bvh, .fbx, .dae or .glb, not " + source)
armatures = [o for o in bpy.data.objects if o.type == "ARMATURE"]
action = bpy.data.actions[0]
print("blender read %d armature(s), %d bones, frames %d..%d" % (
    len(armatures), len(armatures[0].data.bones), round(action.frame_range[0]), round(action.frame_range[1])))
bpy.context.view_layer.objects.active = armatures[0]
bpy.ops.export_anim.bvh(filepath=target, frame_start=round(action.frame_range[0]),
                        frame_end=round(action.frame_range[1]), root_transform_only=False)
