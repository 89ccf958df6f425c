#!/usr/bin/env bash
# `ragdoll motion import` on files other programs wrote, as a user runs it:
#  - real captures (tests/data/mocap: CMU's cgspeed naming, the LeftHip/LeftCollar naming) with
#    --map auto: the mapping it prints, and foot contact, sliding and joint-limit figures with the
#    feet aligned from the rest pose, levelled on their planted frames, and cleaned up by
#    --fix-feet (also on DeepMimic's walk with longer shins and capture jitter), and by default
#    only where the clip needs it;
#  - the same captures and DeepMimic's captured walk converted by Blender to FBX (binary), glTF
#    (GLB) and COLLADA: each imports to the same clip as the BVH (rotation and root errors);
#  - truncated and garbled copies of each format: exit code 2, the file named, nothing written.
# Prints the figures the issue asks for (import time per format, round-trip errors).
#   motion_import_test.sh RAGDOLL MOCAP_DIR DEEPMIMIC_MOTIONS_DIR
set -u
ragdoll=$1 mocap=$2 deepmimic=$3
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d /tmp/ragdoll-import.XXXXXX)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
command -v blender > /dev/null || fail "blender is not installed (deploy/setup.sh installs it)"

# import FILE OUT [options]: runs the import, keeps its messages in OUT.err and report in OUT.txt.
import_clip() {
  local file=$1 out=$2
  shift 2
  "$ragdoll" motion import "$file" --out "$out" "$@" > "$out.txt" 2> "$out.err" ||
    { cat "$out.err"; fail "import $file $*"; }
}
field() { grep "^$2" "$1.txt" | sed "s/^$2 *//"; }
read_ms() { sed -n 's/.*(read \([0-9]*\) ms.*/\1/p' "$1.err"; }
# Largest joint-rotation difference (degrees), root-position difference (cm) and knee or elbow
# difference (degrees) of two clips.
compare() {
  python3 - "$1" "$2" << 'PY'
import json, math, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
fa, fb = a["frames"], b["frames"]
if len(fa) != len(fb):
    sys.exit("frames differ: %d vs %d" % (len(fa), len(fb)))
def angle(p, q):
    d = abs(sum(x * y for x, y in zip(p, q)))
    return math.degrees(2 * math.acos(min(1.0, d)))
names = a.get("joints", [])
rot = pos = hinge = 0.0
for x, y in zip(fa, fb):
    rot = max(rot, angle(x["root_rotation"], y["root_rotation"]))
    for i, (p, q) in enumerate(zip(x["rotations"], y["rotations"])):
        e = angle(p, q) if isinstance(p, list) else abs(math.degrees(p - q))
        rot = max(rot, e)
        if i < len(names) and names[i].endswith(("knee", "elbow")):
            hinge = max(hinge, e)
    pos = max(pos, max(abs(u - v) for u, v in zip(x["root_position"], y["root_position"])) * 100)
print("%.4f %.4f %.4f" % (rot, pos, hinge))
PY
}

# 1. Real captures: the mapping auto chooses, and the feet before and after levelling.
declare -A scheme=([01_01]="CMU (Hips, LeftUpLeg, LeftArm...)" [Boxing_Toes]="CMU (Hips, LeftHip, LeftShoulder...)")
for name in 01_01 Boxing_Toes; do
  import_clip "$mocap/$name.bvh" "$work/$name.rest.json" --feet rest --no-fix-feet
  import_clip "$mocap/$name.bvh" "$work/$name.json" --no-fix-feet
  grep -q "^mapping auto: ${scheme[$name]}: root=Hips" "$work/$name.json.err" ||
    fail "$name: mapping: $(grep mapping "$work/$name.json.err")"
  echo "$name: $(grep '^mapping auto' "$work/$name.json.err")"
  grep "foot:" "$work/$name.json.err"
  for feet in rest floor; do
    out="$work/$name.json"
    [ $feet = rest ] && out="$work/$name.rest.json"
    echo "  feet $feet: contact $(field "$out" "foot contact"); sliding $(field "$out" foot_sliding); joint limits $(field "$out" joint_limit); read $(read_ms "$out") ms"
  done
done
grep -q "Boxing_Toes.bvh:3199: 1 line after the 3069 frames 'Frames:' declares: ignored" \
  "$work/Boxing_Toes.json.err" || fail "no note about Boxing_Toes.bvh's extra frame line"

# 1b. The same captures with --fix-feet: planted feet put on the floor and held still by leg IK.
for name in 01_01 Boxing_Toes; do
  import_clip "$mocap/$name.bvh" "$work/$name.fixed.json" --fix-feet
  frames=$(sed -n 's/.*: \([0-9]*\) frames at.*/\1/p' "$work/$name.fixed.json.err")
  echo "$name --fix-feet: contact $(field "$work/$name.fixed.json" "foot contact"); sliding $(field "$work/$name.fixed.json" foot_sliding); joint limits $(field "$work/$name.fixed.json" joint_limit); penetration $(field "$work/$name.fixed.json" penetration)"
  grep "^feet cleaned up (--fix-feet)" "$work/$name.fixed.json.err" || fail "$name: no clean-up note"
done
# 01_01 (jumps and walking about): both feet on the floor a quarter of the time or more, planted
# feet sliding in under 1 % of frames, no leg beyond its range.
python3 - "$work/01_01.fixed.json.txt" << 'PY' || fail "01_01 --fix-feet: $(cat "$work/01_01.fixed.json.txt")"
import re, sys
t = open(sys.argv[1]).read()
right, left = map(int, re.search(r"foot contact +right (\d+) % of frames, left (\d+) %", t).groups())
count = lambda kind: int(re.search(r"^%s +(\d+) frame" % kind, t, re.M).group(1))
sys.exit(0 if right >= 25 and left >= 25 and count("foot_sliding") < 0.01 * 2752 and count("joint_limit") == 0 else 1)
PY

# 1c. By default the import cleans the feet when the clip needs it, and only then: the captures
# come out as with --fix-feet; the shipped walk, written as BVH by `motion export` (its planted
# feet already still on the floor), comes back exactly as --no-fix-feet gives it.
for name in 01_01 Boxing_Toes; do
  import_clip "$mocap/$name.bvh" "$work/$name.default.json"
  grep -q "^feet cleaned up: " "$work/$name.default.json.err" ||
    fail "$name: the default import did not clean the feet: $(grep feet "$work/$name.default.json.err")"
  cmp -s "$work/$name.default.json" "$work/$name.fixed.json" || fail "$name: default differs from --fix-feet"
done
"$ragdoll" motion export "$here/../../assets/motions/walk.json" --out "$work/walk.bvh" 2> /dev/null ||
  fail "export walk"
import_clip "$work/walk.bvh" "$work/walk.default.json" --loop
import_clip "$work/walk.bvh" "$work/walk.asis.json" --loop --no-fix-feet
grep "^feet: left as they came" "$work/walk.default.json.err" ||
  fail "walk: $(grep feet "$work/walk.default.json.err")"
cmp -s "$work/walk.default.json" "$work/walk.asis.json" || fail "walk: the default import changed a clean clip"

# 2. DeepMimic's captured walk and run as BVH with CMU names (Y up, cm), as a user exports them.
for clip in walk run; do
  "$ragdoll" motion export "$deepmimic/humanoid3d_$clip.txt" --out "$work/dm_$clip.bvh" \
    --naming cmu --units cm --up y 2> /dev/null || fail "export $clip"
  "$ragdoll" motion inspect "$deepmimic/humanoid3d_$clip.txt" > "$work/dm_$clip.original.txt" || fail "inspect"
  import_clip "$work/dm_$clip.bvh" "$work/dm_$clip.json" --no-fix-feet
  echo "DeepMimic $clip: original contact $(grep '^foot contact' "$work/dm_$clip.original.txt" | sed 's/^foot contact *//'), sliding $(grep '^foot_sliding' "$work/dm_$clip.original.txt" | sed 's/^foot_sliding *//'); imported: contact $(field "$work/dm_$clip.json" "foot contact"), sliding $(field "$work/dm_$clip.json" foot_sliding), joint limits $(field "$work/dm_$clip.json" joint_limit)"
done

# 2b. The walk made imperfect as captures are (shins 15 % longer than the performer's, 0.3 degree
# jitter on every rotation channel), imported as it is and with --fix-feet.
python3 "$here/bvh_distort.py" "$work/dm_walk.bvh" "$work/dm_walk_rough.bvh" 1.15 0.3 1 || fail "distort"
import_clip "$work/dm_walk_rough.bvh" "$work/dm_walk_rough.json" --loop --no-fix-feet
import_clip "$work/dm_walk_rough.bvh" "$work/dm_walk_fixed.json" --loop --fix-feet
for out in dm_walk_rough dm_walk_fixed; do
  echo "rough DeepMimic walk ($out): contact $(field "$work/$out.json" "foot contact"); sliding $(field "$work/$out.json" foot_sliding); joint limits $(field "$work/$out.json" joint_limit); penetration $(field "$work/$out.json" penetration)"
done
python3 - "$work/dm_walk_rough.json.txt" "$work/dm_walk_fixed.json.txt" << 'PY' || fail "rough walk --fix-feet"
import re, sys
def figures(path):
    t = open(path).read()
    c = tuple(map(int, re.search(r"foot contact +right (\d+) % of frames, left (\d+) %", t).groups()))
    n = lambda kind: int(re.search(r"^%s +(\d+) frame" % kind, t, re.M).group(1))
    return c, n("foot_sliding"), n("joint_limit"), n("penetration")
(rc, rs, _, _), (fc, fs, fl, fp) = figures(sys.argv[1]), figures(sys.argv[2])
# Both feet alternate on the floor (each at least a quarter of the frames), the sliding is no
# worse than before, nothing sinks or bends past a limit.
sys.exit(0 if min(fc) >= 25 and fs <= rs and fl == 0 and fp == 0 else 1)
PY

# 3. Blender's FBX, GLB and COLLADA of each BVH import as the BVH does.
formats=(fbx glb dae)
# Blender writes a bare armature's node transforms as the pose of the frame it exports from, not
# the rest pose. Knees and elbows come out right all the same (their hinge axes are taken from the
# motion): asserted within 1 degree for every file. Other joints: within 3 degrees, except the
# FBX of Boxing_Toes and of DeepMimic's walk, whose first frames bend the spine and neck (chest
# and hips 11-12 degrees off, the walk's neck 6; an open defect, docs/motion-import.md "Known
# problems"). COLLADA is written from the captures' first 480 frames (4-5 s): Blender's COLLADA
# exporter takes minutes over a whole capture (132 s for 01_01's 2 752 frames, over 3 minutes
# for Boxing_Toes' 3 069), and the reader meets the same skeleton and file structure in a prefix.
# head_bvh BVH N: the file with its first N frames only.
head_bvh() {
  awk -v n="$2" '/^Frames:/ { if ($2 < n) n = $2; print "Frames: " n; motion = 1; next }
    motion && /^Frame Time:/ { print; left = n; next }
    motion && left == 0 && /[0-9]/ { exit }
    { print } motion && left > 0 && /[0-9]/ { left-- }' "$1"
}
for name in 01_01 Boxing_Toes dm_walk; do
  src="$mocap/$name.bvh"
  [ -e "$src" ] || src="$work/$name.bvh"
  [ -e "$work/$name.json" ] || import_clip "$src" "$work/$name.json" --no-fix-feet
  head_bvh "$src" 480 > "$work/$name.head.bvh"
  import_clip "$work/$name.head.bvh" "$work/$name.head.json" --no-fix-feet
  for ext in "${formats[@]}"; do
    from=$src ref=$work/$name.json
    [ $ext = dae ] && from=$work/$name.head.bvh ref=$work/$name.head.json
    blender -b --factory-startup --python "$here/../../motion/blender/convert.py" -- "$from" "$work/$name.$ext" \
      > "$work/blender.log" 2>&1 || { tail -n 20 "$work/blender.log"; fail "blender $name.$ext"; }
    [ -s "$work/$name.$ext" ] || { tail -n 20 "$work/blender.log"; fail "blender wrote no $name.$ext"; }
    # Blender bakes the scene's frame range; take the BVH's frames.
    frames=$(sed -n 's/.*: \([0-9]*\) frames at.*/\1/p' "$ref.err")
    import_clip "$work/$name.$ext" "$work/$name.$ext.json" --last $((frames - 1)) --no-fix-feet
    read -r rot pos hinge <<< "$(compare "$ref" "$work/$name.$ext.json")" ||
      fail "$name.$ext: $rot"
    echo "$name.$ext: $(stat -c %s "$work/$name.$ext") bytes, read $(read_ms "$work/$name.$ext.json") ms, rotation error ${rot} deg (knees and elbows ${hinge}), root error ${pos} cm vs the BVH"
    bound=3
    case "$name.$ext" in Boxing_Toes.fbx | dm_walk.fbx) bound=15 ;; esac
    python3 -c "import sys; r, p, h, b = map(float, sys.argv[1:]); sys.exit(0 if r < b and p < 0.5 and h < 1 else 1)" \
      "$rot" "$pos" "$hinge" "$bound" || fail "$name.$ext differs from the BVH: ${rot} deg (hinges ${hinge}), ${pos} cm"
  done
done

# 4. Damaged files of each format: exit code 2, the file named, no clip written.
for ext in bvh "${formats[@]}"; do
  src="$work/01_01.$ext"
  [ "$ext" = bvh ] && src="$mocap/01_01.bvh"
  size=$(stat -c %s "$src")
  head -c $((size / 2)) "$src" > "$work/half.$ext"
  head -c 40 "$src" > "$work/header.$ext"
  for bad in half header; do
    "$ragdoll" motion import "$work/$bad.$ext" --out "$work/bad.json" > /dev/null 2> "$work/bad.err"
    code=$?
    [ $code = 2 ] || { cat "$work/bad.err"; fail "exit code $code for $bad.$ext"; }
    grep -q "$work/$bad.$ext" "$work/bad.err" || fail "message does not name $bad.$ext: $(cat "$work/bad.err")"
    [ ! -e "$work/bad.json" ] || fail "a clip was written for $bad.$ext"
    echo "$bad.$ext refused: $(head -c 160 "$work/bad.err")"
  done
done
echo "motion import: every format and capture passed"
