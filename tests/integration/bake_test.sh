#!/usr/bin/env bash
# `ragdoll bake` on the shipped steering policy, read back by real clients: the simulated motion
# (.json) against the BVH and glTF binary it writes, each imported by `motion import` (feet and
# root as they are), and each as Blender reads it (re-exported by Blender, then imported): joint
# rotations within 0.5 degrees, the root within 0.5 cm across the floor and at a constant height
# offset (the import puts the lowest foot on the floor). The FBX Blender writes from the bake, read
# by Blender and by `motion import`, the same; .dae is refused with the reason, and .fbx without
# Blender.
# --pushes bakes the reactions: the same motion until the first push, another after it.
#   bake_test.sh RAGDOLL RUN
set -u
ragdoll=$1 run=$2
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d /tmp/ragdoll-bake.XXXXXX)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
command -v blender > /dev/null || fail "blender is not installed (deploy/setup.sh installs it)"
for ext in json bvh glb fbx; do
  "$ragdoll" bake "$run" --out "$work/baked.$ext" --seconds 3 2> "$work/$ext.err" ||
    fail "bake .$ext: $(cat "$work/$ext.err")"
done
echo "$(cat "$work/bvh.err")"
import_back() {  # FILE OUT
  "$ragdoll" motion import "$1" --out "$2" --feet rest --no-fix-feet --root-motion keep \
    > /dev/null 2> "$2.err" || fail "import $1: $(tail -n 3 "$2.err")"
}
compare() {  # SIMULATED IMPORTED LABEL
  python3 - "$1" "$2" "$3" << 'PY'
import json, math, statistics, sys
a, b = (json.load(open(p))["frames"] for p in sys.argv[1:3])
if len(a) != len(b):
    sys.exit("%s: %d frames, the simulation has %d" % (sys.argv[3], len(b), len(a)))
angle = lambda p, q: math.degrees(2 * math.acos(min(1.0, abs(sum(x * y for x, y in zip(p, q))))))
rot = max(max([angle(x["root_rotation"], y["root_rotation"])] +
              [angle(p, q) for p, q in zip(x["rotations"], y["rotations"])]) for x, y in zip(a, b))
across = max(math.hypot(x["root_position"][0] - y["root_position"][0],
                        x["root_position"][1] - y["root_position"][1]) for x, y in zip(a, b)) * 100
dz = [(y["root_position"][2] - x["root_position"][2]) * 100 for x, y in zip(a, b)]
print("%s: %d frames, joint rotations within %.3f deg, root across %.3f cm, height offset %.2f cm (spread %.3f)"
      % (sys.argv[3], len(a), rot, across, statistics.mean(dz), max(dz) - min(dz)))
sys.exit(0 if rot < 0.5 and across < 0.5 and max(dz) - min(dz) < 0.5 else 1)
PY
}
import_back "$work/baked.bvh" "$work/bvh.json"
compare "$work/baked.json" "$work/bvh.json" "BVH, motion import" || fail "BVH round trip"
import_back "$work/baked.glb" "$work/glb.json"
compare "$work/baked.json" "$work/glb.json" "GLB (Assimp), motion import" || fail "GLB round trip"
# in_blender EXT [FPS]: the baked file as Blender's importer reads it (written back as BVH by
# Blender, then imported), against the simulation.
in_blender() {
  blender -b --factory-startup --python "$here/blender_to_bvh.py" -- "$work/baked.$1" \
    "$work/blender_$1.bvh" ${2:-} > "$work/blender.log" 2>&1 ||
    { tail -n 20 "$work/blender.log"; fail "blender $1"; }
  grep "^blender read" "$work/blender.log"
  import_back "$work/blender_$1.bvh" "$work/blender_$1.json"
  compare "$work/baked.json" "$work/blender_$1.json" "$1 as Blender reads it" || fail "$1 in Blender"
}
in_blender bvh
in_blender glb 30  # glTF keys are times: the scene set to 30 frames/s places them on its frames
in_blender fbx     # written by Blender from the baked BVH; read by motion import (Assimp) too:
import_back "$work/baked.fbx" "$work/fbx.json"
compare "$work/baked.json" "$work/fbx.json" "FBX, motion import" || fail "FBX round trip"
ls "$work"/*.blender.log 2> /dev/null && fail "Blender's log left behind"
"$ragdoll" bake "$run" --out "$work/baked.dae" > /dev/null 2> "$work/bad.err" && fail ".dae written"
grep -q "COLLADA is not written" "$work/bad.err" || fail ".dae: $(cat "$work/bad.err")"
RAGDOLL_BLENDER=/nonexistent/blender "$ragdoll" bake "$run" --out "$work/none.fbx" --seconds 1 \
  > /dev/null 2> "$work/bad.err" && fail ".fbx written without Blender"
grep -q "could not be run (apt install blender" "$work/bad.err" || fail "no Blender: $(cat "$work/bad.err")"

# --pushes: the same episode until the first push (at 1 s), the pushed one carried away after it.
"$ragdoll" bake "$run" --out "$work/pushed.json" --seconds 3 --pushes 30 --push-every 1 \
  2> "$work/pushed.err" || fail "bake --pushes: $(cat "$work/pushed.err")"
grep -q "push at 1.00 s: 30 N s on the pelvis" "$work/pushed.err" || fail "no push: $(cat "$work/pushed.err")"
python3 - "$work/baked.json" "$work/pushed.json" << 'PY' || fail "bake --pushes"
import json, math, sys
a, b = (json.load(open(p))["frames"] for p in sys.argv[1:3])
gap = [math.dist(x["root_position"], y["root_position"]) for x, y in zip(a, b)]
before, after = max(gap[:31]), max(gap[31:])  # frame 30 is at 1 s, 30 frames/s
print(f"bake --pushes: root {before * 100:.3f} cm from the unpushed bake before the push, up to {after * 100:.1f} cm after")
sys.exit(0 if before == 0 and after > 0.02 else 1)
PY
echo "bake: every written file read back within 0.5 degrees"
