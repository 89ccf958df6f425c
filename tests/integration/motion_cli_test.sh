#!/usr/bin/env bash
# `ragdoll motion` as a user runs it: export a shipped clip as BVH (Y-up, centimetres, CMU names),
# import it back with the CMU preset, inspect both; a malformed BVH is refused with file and line.
#   motion_cli_test.sh RAGDOLL ASSETS
set -u
ragdoll=$1 assets=$2
work=$(mktemp -d /tmp/ragdoll-motion.XXXXXX)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

"$ragdoll" motion export "$assets/motions/walk.json" --out "$work/walk.bvh" --naming cmu \
  --units cm --up y --order YXZ || fail "export"
grep -q "ROOT Hips" "$work/walk.bvh" || fail "export did not use the CMU names"
"$ragdoll" motion import "$work/walk.bvh" --map cmu --loop --out "$work/walk.json" \
  > "$work/import.txt" 2> "$work/import.err" || { cat "$work/import.err"; fail "import"; }
cat "$work/import.err" "$work/import.txt"
"$ragdoll" motion inspect "$assets/motions/walk.json" --json "$work/report.json" > "$work/original.txt" ||
  fail "inspect"
# The imported clip reads like the original: same timing, travel, contact and no problems.
for field in duration "root travel" "per cycle" "foot contact" penetration foot_sliding joint_limit; do
  a=$(grep "^$field" "$work/original.txt") b=$(grep "^$field" "$work/import.txt")
  [ "$a" = "$b" ] || fail "'$field' differs: original '$a', imported '$b'"
done
grep -q '"foot_contact"' "$work/report.json" || fail "no JSON report"
# The walk puts only its feet on the floor, and its rotations are unit quaternions.
grep -Eq "^ground contact +right_ankle [0-9]+ % left_ankle [0-9]+ %$" "$work/original.txt" ||
  fail "ground contact line: $(grep '^ground contact' "$work/original.txt")"
grep -q '"ground_contacts": {' "$work/report.json" || fail "no ground_contacts in the JSON report"
grep -Eq "^rotations +0 renormalised" "$work/original.txt" || fail "rotations line"

# A truncated motion section is refused with the file, the line and the reason.
head -n -5 "$work/walk.bvh" > "$work/truncated.bvh"
"$ragdoll" motion import "$work/truncated.bvh" --out "$work/x.json" 2> "$work/err.txt"
code=$?
[ $code = 2 ] || fail "exit code $code for a truncated file"
grep -q "truncated.bvh:[0-9]*: truncated: 'Frames: 61' but 56 frame lines" "$work/err.txt" ||
  fail "message: $(cat "$work/err.txt")"
[ ! -e "$work/x.json" ] || fail "a clip was written for a bad file"
echo "1 passed, 0 failed"
