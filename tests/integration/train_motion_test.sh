#!/usr/bin/env bash
# `ragdoll train --motion FILE`, as a new user runs it on a download:
#  - the shipped walk written as BVH by `motion export`, its root's horizontal travel removed as
#    Mixamo's "In Place" does: the import rebuilds the travel and finds the loop, the walk's
#    template is chosen, the clip and the config land in the run folder, the training makes PPO
#    updates; Ctrl-C, then `--resume` from the run's own config carries it on, and `eval` works;
#  - the shipped walk_stop (plays once): the one-shot template is chosen, and `eval` adds the
#    whole clip from its first frame;
#  - a missing file and a run given neither a config nor a clip are refused with a message.
#   train_motion_test.sh RAGDOLL ASSETS_DIR
set -u
ragdoll=$1 assets=$2
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d /tmp/ragdoll-train-motion.XXXXXX)
# Below 32768, where Linux takes the local ports of outgoing connections.
port=$((29700 + 50 * (RANDOM % 20)))
pids=()
cleanup() { kill -INT "${pids[@]}" 2> /dev/null; wait 2> /dev/null; rm -rf "$work"; }
trap cleanup EXIT
fail() { echo "FAIL: $*"; exit 1; }
updates() { cat "$1" 2> /dev/null | grep -c '^\['; }
# train LOG ARGS...: in the background until the log shows a PPO update, then Ctrl-C.
train_one_update() {
  local log=$1; shift
  "$ragdoll" train --runs-dir "$work" --port-base "$port" --actors 1 "$@" > "$log" 2>&1 &
  local pid=$! started=$SECONDS
  pids+=($pid)
  until [ "$(updates "$log")" -ge 1 ]; do
    kill -0 "$pid" 2> /dev/null || fail "training ended: $(tail -n 5 "$log")"
    [ $((SECONDS - started)) -lt 180 ] || fail "no PPO update in 180 s: $(tail -n 5 "$log")"
    sleep 0.5
  done
  kill -INT "$pid"
  wait "$pid" || fail "train exited $? after Ctrl-C: $(tail -n 5 "$log")"
}

# The walk, in place.
"$ragdoll" motion export "$assets/motions/walk.json" --out "$work/walk.bvh" 2> /dev/null ||
  fail "export"
python3 "$here/in_place_copy.py" "$work/walk.bvh" "$work/Walking_In_Place.bvh" || fail "in-place copy"
train_one_update "$work/walk.log" --motion "$work/Walking_In_Place.bvh" --run-id walk
grep -q "root motion: in place" "$work/walk.log" || fail "no root motion rebuilt: $(grep 'root motion' "$work/walk.log")"
grep -q "loop: yes" "$work/walk.log" || fail "the loop was not found: $(grep 'loop:' "$work/walk.log")"
grep -q "looping locomotion (.*): config template .*/configs/walk.yaml" "$work/walk.log" ||
  fail "template: $(grep 'template' "$work/walk.log")"
run="$work/walk"
[ -s "$run/motion.json" ] && [ -s "$run/Walking_In_Place.yaml" ] || fail "run folder: $(ls "$run")"
grep -q "motion: motion.json" "$run/Walking_In_Place.yaml" || fail "config does not name its clip"
"$ragdoll" motion inspect "$run/motion.json" > "$work/inspect.txt" || fail "inspect"
python3 - "$work/inspect.txt" << 'PY' || fail "the clip does not travel: $(grep -E 'per cycle|clip' "$work/inspect.txt")"
import re, sys
t = open(sys.argv[1]).read()
x = float(re.search(r"^per cycle +([-+0-9.]+)", t, re.M).group(1))
sys.exit(0 if "(looping)" in t and abs(x - 0.9) < 0.027 else 1)  # the walk's 0.9 m, within 3 %
PY
echo "in-place walk: $(grep 'root motion' "$work/walk.log" | sed 's/^ *//')"
before=$(sed -n 's/.* samples \([0-9]*\) .*/\1/p' "$work/walk.log" | tail -n 1)
train_one_update "$work/resume.log" "$run/Walking_In_Place.yaml" --run-id walk --resume
after=$(sed -n 's/.* samples \([0-9]*\) .*/\1/p' "$work/resume.log" | tail -n 1)
[ "${after:-0}" -gt "${before:-0}" ] || fail "resume did not carry the run on ($before -> $after)"
"$ragdoll" eval "$run" --episodes 2 > "$work/eval.txt" 2>&1 || fail "eval: $(tail -n 3 "$work/eval.txt")"
grep -q "normalised return" "$work/eval.txt" || fail "eval: $(tail -n 3 "$work/eval.txt")"

# A clip that plays once: its template, and `eval` judges the whole clip from its first frame.
train_one_update "$work/stop.log" --motion "$assets/motions/walk_stop.json" --run-id stop
grep -q "one-shot action (it plays once (1.50 s)): config template .*/configs/action.yaml" \
  "$work/stop.log" || fail "walk_stop: $(grep template "$work/stop.log")"
"$ragdoll" eval "$work/stop" --episodes 2 --json "$work/stop.json" > /dev/null 2> "$work/stop_eval.txt" ||
  fail "eval of the one-shot run: $(tail -n 3 "$work/stop_eval.txt")"
grep -q "the clip plays once: from its first frame" "$work/stop_eval.txt" ||
  fail "no whole-clip figure: $(tail -n 3 "$work/stop_eval.txt")"
python3 - "$work/stop.json" << 'PY' || fail "whole_clip: $(cat "$work/stop.json")"
import json, sys
w = json.load(open(sys.argv[1]))["whole_clip"]
# 1.5 s at 30 decisions per second, unless it fell; a return in [0, 1]; the same for the PD
# targets alone.
ok = lambda e: 0 < e["episode_length"] <= 45 and 0 <= e["normalized_return"] <= 1 and (
    e["fell"] or e["episode_length"] == 45)
sys.exit(0 if ok(w) and ok(w["reference_tracking"]) else 1)
PY
grep -q "plays once" "$work/eval.txt" && fail "a looping walk was judged as a one-shot clip"

# Refusals.
"$ragdoll" train --motion "$work/nothing.bvh" > "$work/bad.log" 2>&1
[ $? != 0 ] && grep -q "nothing.bvh" "$work/bad.log" || fail "missing file: $(cat "$work/bad.log")"
"$ragdoll" train --runs-dir "$work" > "$work/bad.log" 2>&1
[ $? != 0 ] && grep -q "give a config" "$work/bad.log" || fail "no config: $(cat "$work/bad.log")"
echo "train --motion: in-place walk rebuilt and trained, resumed and evaluated; one-shot template chosen"
