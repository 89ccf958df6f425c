#!/usr/bin/env bash
# Falling and getting up as a user runs it: the shipped configs/walk_recovery.yaml (pushes and
# DeepMimic's get-up clips) trains with real processes, shrunk to two small PPO updates; the log
# has the falls, getting_up and push_level columns; `ragdoll eval --recovery` drops the trained
# character into settled falls and reports them; the export's sidecar carries the get-up clips,
# the fall and stand rules and the observation entries that name the get-up; `verify` accepts the
# checkpoint. The same with steering (configs/steer.yaml with the recovery section added), started
# from a steering run without recovery (--init-from), and a source whose observation the new run's
# does not begin with refused.
#   recovery_test.sh RAGDOLL CONFIGS_DIR PORT_BASE
set -u
ragdoll=$1 configs=$2 port=$3
work=$(mktemp -d /tmp/ragdoll-recovery.XXXXXX)
trap '[ -n "${KEEP:-}" ] || rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
assets=$(cd "$configs/../assets" && pwd)

# The configs keep their relative asset paths (../assets beside them, a link), so that the run
# folder's effective config must have made them absolute.
mkdir -p "$work/configs" && ln -s "$assets" "$work/assets"
shrink() {  # config out
  sed -e 's/^  max_episode_steps: .*/  max_episode_steps: 90/' \
      -e 's/^    batch_size: .*/    batch_size: 256/' -e 's/^    buffer_size: .*/    buffer_size: 1024/' \
      -e 's/^    hidden_units: .*/    hidden_units: 32/' -e 's/^  max_steps: .*/  max_steps: 2048/' \
      -e 's/^  time_horizon: .*/  time_horizon: 16/' -e 's/^  checkpoint_interval: .*/  checkpoint_interval: 1024/' \
      -e 's/^  count: 0 .*/  count: 1/' -e 's/^  environments: .*/  environments: 4/' "$1" > "$2"
  grep -q "hidden_units: 32" "$2" || fail "could not shrink $1"
}

check_run() {  # name config port [train options]
  local name=$1 config=$2 p=$3 run=$work/runs/$1
  shift 3
  timeout 180 "$ragdoll" train "$config" --run-id "$name" --runs-dir "$work/runs" --port-base "$p" \
    "$@" > "$work/$name-train.txt" 2>&1 || { tail -20 "$work/$name-train.txt"; fail "$name: train"; }
  [ "$(wc -l < "$run/metrics.csv")" -eq 3 ] || fail "$name: expected two updates: $(cat "$run/metrics.csv")"
  # Episodes go on through falls: falls per episode >= 0, a share of steps getting up in [0, 1]
  # (a quarter of the episodes start fallen), the push curriculum's level.
  awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) c[$i] = i; next }
    !(c["falls"] && $c["falls"] >= 0 && $c["getting_up"] > 0 && $c["getting_up"] <= 1 &&
      (!c["push_level"] || $c["push_level"] >= 20)) { bad = 1 }
    END { exit bad }' "$run/metrics.csv" || fail "$name: recovery columns: $(cat "$run/metrics.csv")"
  [ "$(grep -cE 'face_(down|up): /' "$run/config.yaml")" -eq 2 ] ||
    fail "$name: effective config: $(cat "$run/config.yaml")"

  "$ragdoll" eval "$run" --episodes 2 --recovery 4 --recovery-seconds 3 --json "$work/$name-eval.json" \
    > /dev/null 2> "$work/$name-eval.txt" || { cat "$work/$name-eval.txt"; fail "$name: eval --recovery"; }
  jq -e '.recovery.trials == 4 and (.recovery.times | length) == 4 and .recovery.within_10 >= 0' \
    "$work/$name-eval.json" > /dev/null || fail "$name: eval JSON: $(cat "$work/$name-eval.json")"
  grep -q "recovery from 4 settled falls" "$work/$name-eval.txt" || fail "$name: eval table: $(cat "$work/$name-eval.txt")"

  "$ragdoll" export "$run" --onnx "$work/$name.onnx" > /dev/null 2>&1 || fail "$name: export"
  jq -e '(.recovery.clips | map(.name)) == ["get_up_face_down", "get_up_face_up"]
         and (.recovery.clips[0].hinge_angles | length) > 60
         and (.recovery.may_touch_floor | index("left_ankle")) != null
         and (.recovery.may_touch_floor | index("chest")) == null
         and .recovery.stand_height > 0.5
         and .observation.names[-2:] == ["recovery.face_down", "recovery.face_up"]' \
    "$work/$name.json" > /dev/null ||
    fail "$name: sidecar: $(jq -c '.recovery | del(.clips[].hinge_angles)' "$work/$name.json")"
  "$ragdoll" verify "$run" > /dev/null 2>&1 || fail "$name: verify"
}

shrink "$configs/walk_recovery.yaml" "$work/configs/walk_recovery.yaml"
check_run walk "$work/configs/walk_recovery.yaml" "$port"

# Steering with recovery: steer.yaml and the walk's recovery section, started from a steering run
# without it (--init-from: the two recovery inputs are new).
shrink "$configs/steer.yaml" "$work/configs/steer.yaml"
timeout 180 "$ragdoll" train "$work/configs/steer.yaml" --run-id steer_plain --runs-dir "$work/runs" \
  --port-base "$((port + 20))" > "$work/steer_plain.txt" 2>&1 || { tail -20 "$work/steer_plain.txt"; fail "steer_plain: train"; }
cp "$work/configs/steer.yaml" "$work/configs/steer_recovery.yaml"
sed -n '/^  recovery:/,/give_up_after/p' "$work/configs/walk_recovery.yaml" > "$work/recovery.part"
sed -i "/^environment:/r $work/recovery.part" "$work/configs/steer_recovery.yaml"
check_run steer "$work/configs/steer_recovery.yaml" "$((port + 10))" --init-from "$work/runs/steer_plain"
grep -q "2 new observation entries (recovery.face_down, ...) start at zero weight" "$work/steer-train.txt" ||
  fail "--init-from a steering run: $(grep init "$work/steer-train.txt")"
# Refused: the walk's observation does not begin with the steering run's.
if "$ragdoll" train "$work/configs/walk_recovery.yaml" --run-id refused --runs-dir "$work/runs" \
     --port-base "$((port + 30))" --init-from "$work/runs/steer" > "$work/refused.txt" 2>&1; then
  fail "--init-from a run whose observation is not a prefix was accepted"
fi
grep -q "a run can start from one whose observation entries its own begin with" "$work/refused.txt" ||
  fail "refusal: $(cat "$work/refused.txt")"
jq -e '(.steering.clips | map(.name) | index("get_up_face_up")) == null
       and .observation.names[-2:] == ["recovery.face_down", "recovery.face_up"]' \
  "$work/steer.json" > /dev/null || fail "steer: sidecar: $(jq -c '.steering.clips | map(.name)' "$work/steer.json")"

echo "PASS: walk and steering with recovery train, evaluate falls, export and verify"
