#!/usr/bin/env bash
# The steering task as a user runs it: the shipped motion set (configs/steer.yaml's, mirrored
# clips and transitions included) trains with real processes, the run folder's effective config
# keeps every clip, `ragdoll eval --commands` scores a script and random scripts, and the export's
# sidecar names the command inputs and carries every clip's reference; `ragdoll report` names the
# motion set and animates a random command script; `export --run` ships the run as a relocatable
# folder. Bad scripts are refused.
#   steering_test.sh RAGDOLL CONFIGS_DIR PORT_BASE
set -u
ragdoll=$1 configs=$2 port=$3
work=$(mktemp -d /tmp/ragdoll-steering.XXXXXX)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

# The shipped config, shrunk to two small PPO updates.
sed -e 's#\.\./assets#'"$(cd "$configs/../assets" && pwd)"'#' \
    -e 's/^  max_episode_steps: .*/  max_episode_steps: 90/' \
    -e 's/^    batch_size: .*/    batch_size: 256/' -e 's/^    buffer_size: .*/    buffer_size: 1024/' \
    -e 's/^    hidden_units: .*/    hidden_units: 32/' -e 's/^  max_steps: .*/  max_steps: 2048/' \
    -e 's/^  time_horizon: .*/  time_horizon: 16/' -e 's/^  checkpoint_interval: .*/  checkpoint_interval: 1024/' \
    -e 's/^  count: 0 .*/  count: 1/' -e 's/^  environments: .*/  environments: 4/' \
    "$configs/steer.yaml" > "$work/steer.yaml"
grep -q "hidden_units: 32" "$work/steer.yaml" || fail "could not shrink the config"
timeout 180 "$ragdoll" train "$work/steer.yaml" --run-id steer --runs-dir "$work/runs" \
  --port-base "$port" > "$work/train.txt" 2>&1 || { tail -20 "$work/train.txt"; fail "train"; }
run=$work/runs/steer
[ "$(wc -l < "$run/metrics.csv")" -eq 3 ] || fail "expected two updates: $(cat "$run/metrics.csv")"
# The steering columns: a task term in (0, 0.5] and finite errors.
awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) c[$i] = i; next }
  !($c["task"] > 0 && $c["task"] <= 0.5 && $c["speed_error"] >= 0 && $c["heading_error"] >= 0) { bad = 1 }
  END { exit bad }' "$run/metrics.csv" || fail "steering columns: $(cat "$run/metrics.csv")"
# The effective config names every clip by an absolute path.
[ "$(grep -c 'motion: /' "$run/config.yaml")" -eq 9 ] || fail "effective config: $(cat "$run/config.yaml")"

cat > "$work/script.yaml" <<EOF
duration: 6
commands:
  - {at: 0, command: stand}
  - {at: 2, command: walk}
  - {at: 4, command: turn_right}
EOF
"$ragdoll" eval "$run" --episodes 2 --commands "$work/script.yaml" --command-runs 2 \
  --json "$work/eval.json" > /dev/null 2> "$work/eval.txt" || { cat "$work/eval.txt"; fail "eval --commands"; }
cat "$work/eval.txt"
jq -e '.commands.runs == 2 and .commands.script != null and (.commands.fall_rate >= 0)
       and (.reward_terms.task >= 0) and (.steering.speed_error >= 0)' "$work/eval.json" > /dev/null ||
  fail "eval JSON: $(cat "$work/eval.json")"
grep -q "commands: 2 runs" "$work/eval.txt" || fail "no command table"
"$ragdoll" eval "$run" --episodes 1 --commands random --command-runs 2 --command-seconds 8 \
  --json "$work/random.json" > /dev/null 2>&1 || fail "eval --commands random"
jq -e '.commands.runs == 2 and .commands.script == "random"' "$work/random.json" > /dev/null ||
  fail "random: $(cat "$work/random.json")"

# Bad scripts: an unknown command names the set; a run without steering is refused.
printf 'commands:\n  - {at: 0, command: moonwalk}\n' > "$work/bad.yaml"
"$ragdoll" eval "$run" --episodes 1 --commands "$work/bad.yaml" > /dev/null 2> "$work/bad.txt" &&
  fail "accepted an unknown command"
grep -q "bad.yaml:2: commands\[0\].command: 'moonwalk' is not a command of the run's motion set (stand, walk, walk_backward, strafe_left, strafe_right, turn_left, turn_right)" \
  "$work/bad.txt" || fail "message: $(cat "$work/bad.txt")"

# The export: the sidecar names the command inputs and carries each clip's reference.
"$ragdoll" export "$run" --onnx "$work/steer.onnx" > /dev/null 2>&1 || fail "export"
jq -e '(.observation.names | index("command.forward")) != null
       and (.observation.names | index("reference.walk_stop")) != null
       and (.steering.clips | length) == 9
       and ([.steering.clips[] | select(.name == "strafe_right")][0].command.left < -0.3)
       and ([.steering.clips[] | select(.name == "walk_start")][0].transition.to == "walk")
       and (.steering.clips[0].hinge_angles | length) > 10' "$work/steer.json" > /dev/null ||
  fail "sidecar: $(jq -c '.steering | del(.clips[].hinge_angles)' "$work/steer.json")"
# A run folder to ship: file paths relative to it, a checkpoint without optimizer state (under
# half the size), and eval takes it like the run.
"$ragdoll" export "$run" --run "$work/shipped" > /dev/null 2> "$work/ship.txt" || { cat "$work/ship.txt"; fail "export --run"; }
grep -q 'motion: \.\./' "$work/shipped/config.yaml" && ! grep -q ': /' "$work/shipped/config.yaml" ||
  fail "shipped config: $(grep -n ': /\|motion' "$work/shipped/config.yaml")"
slim=$(stat -c %s "$work"/shipped/checkpoints/*.pt) whole=$(ls -S "$run"/checkpoints/*.pt | head -1 | xargs stat -c %s)
[ $((slim * 2)) -lt "$whole" ] || fail "shipped checkpoint $slim bytes, the run's $whole"
"$ragdoll" eval "$work/shipped" --episodes 1 --json "$work/shipped.json" > /dev/null 2>&1 || fail "eval of the shipped run"
jq -e '.episodes == 1' "$work/shipped.json" > /dev/null || fail "shipped eval: $(cat "$work/shipped.json")"

# The report names the motion set and animates a random command script.
"$ragdoll" report "$run" --out "$work/report.html" --gif-seconds 3 > /dev/null 2> "$work/report.txt" ||
  { cat "$work/report.txt"; fail "report"; }
grep -q "steering: stand, walk, walk_backward" "$work/report.html" || fail "report: no motion set"
grep -q "following a random command script" "$work/report.html" || fail "report: GIF caption"
grep -q "data:image/gif;base64," "$work/report.html" || fail "report: no GIF"
echo "PASS: steering trains, evaluates on scripts, exports and reports"
