#!/usr/bin/env bash
# In-place locomotion as Mixamo ships it, written by another program: the shipped walk, backward
# walk and strafe and DeepMimic's captured walk and run, each exported to BVH with Mixamo's bone
# names, its hips' horizontal travel removed ("In Place"), converted to FBX by Blender, then
# imported with the defaults. The import must say it rebuilt the root's travel, and the rebuilt
# travel per cycle must be within 3 % of the original's distance and 3 degrees of its heading,
# with the planted feet sliding in no more frames than the original's.
#   in_place_test.sh RAGDOLL ASSETS_DIR DEEPMIMIC_MOTIONS_DIR
set -u
ragdoll=$1 assets=$2 deepmimic=$3
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d /tmp/ragdoll-in-place.XXXXXX)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
command -v blender > /dev/null || fail "blender is not installed (deploy/setup.sh installs it)"

# name=clip; every clip holds whole cycles (its root's travel over the clip is the cycle's).
clips=(walk="$assets/motions/walk.json" backward="$assets/motions/walk_backward.json"
       strafe="$assets/motions/strafe_left.json" dm_walk="$deepmimic/humanoid3d_walk.txt"
       dm_run="$deepmimic/humanoid3d_run.txt")
for entry in "${clips[@]}"; do
  name=${entry%%=*} clip=${entry#*=}
  "$ragdoll" motion export "$clip" --naming mixamo --out "$work/$name.bvh" 2> /dev/null ||
    fail "$name: export"
  python3 "$here/in_place_copy.py" "$work/$name.bvh" "$work/${name}_In_Place.bvh" ||
    fail "$name: in-place copy"
  blender -b --factory-startup --python "$here/../../motion/blender/convert.py" -- \
    "$work/${name}_In_Place.bvh" "$work/${name}_In_Place.fbx" > "$work/blender.log" 2>&1 ||
    { tail -n 20 "$work/blender.log"; fail "$name: blender"; }
  "$ragdoll" motion import "$work/${name}_In_Place.fbx" --loop --out "$work/$name.json" \
    > "$work/$name.import" 2>&1 || fail "$name: import: $(tail -n 3 "$work/$name.import")"
  grep -q "root motion: in place" "$work/$name.import" ||
    fail "$name: not rebuilt: $(grep 'root motion' "$work/$name.import")"
  "$ragdoll" motion inspect "$clip" > "$work/$name.original" 2>&1 || fail "$name: inspect"
  "$ragdoll" motion inspect "$work/$name.json" > "$work/$name.rebuilt" 2>&1 || fail "$name: inspect"
  python3 - "$name" "$work/$name.original" "$work/$name.rebuilt" << 'PY' || fail "$name"
import math, re, sys
name, original, rebuilt = sys.argv[1], open(sys.argv[2]).read(), open(sys.argv[3]).read()
def travel(t):  # the root's travel over the clip, forward and left
    x, y = re.search(r"^root travel +([-+0-9.]+) +([-+0-9.]+)", t, re.M).groups()
    return float(x), float(y)
def sliding(t):
    return int(re.search(r"^foot_sliding +(\d+) frames", t, re.M).group(1))
(x0, y0), (x1, y1) = travel(original), travel(rebuilt)
d0, d1 = math.hypot(x0, y0), math.hypot(x1, y1)
heading = math.degrees(math.atan2(x0 * y1 - y0 * x1, x0 * x1 + y0 * y1))
print(f"{name}: travel {d1:.3f} m against {d0:.3f} ({100 * (d1 / d0 - 1):+.1f} %), heading "
      f"{heading:+.1f} deg, feet sliding in {sliding(rebuilt)} frames (original {sliding(original)})")
ok = abs(d1 / d0 - 1) <= 0.03 and abs(heading) <= 3 and sliding(rebuilt) <= sliding(original)
sys.exit(0 if ok else 1)
PY
done
echo "in place: every clip's travel rebuilt from its feet"
