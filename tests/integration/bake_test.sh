#!/usr/bin/env bash
# `ragdoll bake` on the shipped steering policy, read back by real clients: the simulated motion
# (.json) against the BVH and glTF binary it writes, each imported by `motion import` (feet and
# root as they are), and the BVH as Blender reads it (re-exported by Blender, then imported): joint
# rotations within 0.5 degrees, the root within 0.5 cm across the floor and at a constant height
# offset (the import puts the lowest foot on the floor). .fbx and .dae are refused with the reason.
#   bake_test.sh RAGDOLL RUN
set -u
ragdoll=$1 run=$2
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d /tmp/ragdoll-bake.XXXXXX)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
command -v blender > /dev/null || fail "blender is not installed (deploy/setup.sh installs it)"
for ext in json bvh glb; do
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
blender -b --factory-startup --python "$here/blender_bvh_roundtrip.py" -- "$work/baked.bvh" \
  "$work/blender.bvh" > "$work/blender.log" 2>&1 || { tail -n 20 "$work/blender.log"; fail "blender"; }
grep "^blender read" "$work/blender.log"
import_back "$work/blender.bvh" "$work/blender.json"
compare "$work/baked.json" "$work/blender.json" "BVH as Blender reads it" || fail "Blender round trip"
for ext in fbx dae; do
  "$ragdoll" bake "$run" --out "$work/baked.$ext" > /dev/null 2> "$work/bad.err" && fail ".$ext written"
  grep -q "neither Blender nor Assimp read back" "$work/bad.err" || fail ".$ext: $(cat "$work/bad.err")"
done
echo "bake: every written file read back within 0.5 degrees"
