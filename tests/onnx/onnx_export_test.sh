#!/usr/bin/env bash
# `ragdoll export` as a user runs it, checked by a real ONNX Runtime:
#  - a tiny training (CONFIG) stopped with Ctrl-C after 2 PPO updates, so the observation
#    statistics are far from (0, 1), is exported with its value head (ONNX_TEST_RUN=runs/<id>
#    reuses a run instead);
#  - the sidecar describes the environment: 226 observation names, 28 action axes with their
#    ranges and gains, the control rate, the reference angles, the model's and the character's
#    SHA-256;
#  - Debian's Python onnx checker accepts the file (full check);
#  - 2000 observations recorded from real rollouts of the policy (RECORD_ROLLOUTS) run through
#    ONNX Runtime (onnxruntime-node) match libtorch's actions and values within 1e-5; the figures
#    (model size, differences, time per step) are printed;
#  - a missing run, damaged checkpoints and an unwritable output are refused with a message naming
#    them, and nothing is written or changed.
#   onnx_export_test.sh RAGDOLL RECORD_ROLLOUTS CONFIG
set -u
ragdoll=$1 recorder=$2 config=$3
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d /tmp/ragdoll-onnx-test.XXXXXX)
# Ports P..P+4, metrics P+10, P+11, P+20: clear of the other integration tests' ranges.
port=$((29100 + 50 * (RANDOM % 20)))
pids=()
cleanup() { kill "${pids[@]}" 2>/dev/null; wait 2>/dev/null; rm -rf "$work"; }
trap cleanup EXIT
fail() { echo "FAIL: $*"; exit 1; }
sha() { sha256sum < "$1" | cut -d' ' -f1; }
begin=$SECONDS

# Without ONNX Runtime this test could check nothing: it fails and says how to install it.
node -e "require('$here/node_modules/onnxruntime-node')" 2> /dev/null ||
  fail "onnxruntime-node is not installed in $here/node_modules: run deploy/setup.sh" \
    "(npm ci --ignore-scripts in tests/onnx)"
# Debian's python3-onnx lives with Debian's Python, which a pyenv or venv python3 would hide.
python=/usr/bin/python3
"$python" -c "import onnx" 2> /dev/null || fail "python3-onnx is missing: run deploy/setup.sh"

if [ -n "${ONNX_TEST_RUN:-}" ]; then
  run=$ONNX_TEST_RUN
else
  run=$work/runs/tiny
  "$ragdoll" train "$config" --run-id tiny --runs-dir "$work/runs" --port-base "$port" \
    --actors 1 > "$work/train.log" 2>&1 &
  pid=$! started=$SECONDS
  pids+=($pid)
  # The log may not exist yet; a Ctrl-C sent before the training's handler is installed would be
  # lost (a background job of a script starts with SIGINT ignored) and the training never stop.
  updates() { cat "$work/train.log" 2> /dev/null | grep -c '^\['; }
  while [ "$(updates)" -lt 2 ]; do
    [ $((SECONDS - started)) -lt 400 ] || fail "no 2 PPO updates in 400 s: $(tail -n 5 "$work/train.log")"
    kill -0 "$pid" 2> /dev/null || fail "training stopped by itself: $(tail -n 5 "$work/train.log")"
    sleep 1
  done
  kill -INT "$pid"
  wait "$pid" || fail "training did not stop cleanly: $(tail -n 5 "$work/train.log")"
  echo "trained $(updates) PPO updates in $((SECONDS - started)) s"
fi

# The export, with the value head.
out=$work/export
mkdir -p "$out"
"$ragdoll" export "$run" --onnx "$out/policy.onnx" --value 2> "$work/export.log" ||
  fail "export: $(cat "$work/export.log")"
cat "$work/export.log"
[ -s "$out/policy.onnx" ] && [ -s "$out/policy.json" ] || fail "no policy.onnx and policy.json"
[ "$(ls "$out")" = "$(printf 'policy.json\npolicy.onnx')" ] || fail "stray files: $(ls "$out")"
side=$out/policy.json
character=$(jq -r .character.file "$side")
jq -e --arg model "$(sha "$out/policy.onnx")" --arg character "$(sha "$character")" '
  .model.opset == 13 and .model.ir_version == 7 and .model.sha256 == $model
  and .model.file == "policy.onnx" and .character.sha256 == $character
  and .model.inputs[0].name == "observation" and .model.inputs[0].shape == ["batch", 226]
  and [.model.outputs[].name] == ["action", "value"] and .model.outputs[1].gamma == 0.95
  and .observation.size == 226 and (.observation.names | length) == 226
  and .observation.names[0] == "root.height" and .observation.names[-1] == "phase.cos"
  and .action.size == 28 and (.action.axes | length) == 28 and .action.mode == "offset"
  and .action.offset_scale == 0.5 and .action.axes[0].name == "chest_y"
  and all(.action.axes[]; .upper > .lower and .kp > 0 and .kd > 0 and (.axis | length) == 3)
  and .control.frequency == 30 and .control.substeps == 20 and .clip.name == "stand"
  and (.reference.hinge_angles | length) == 61 and all(.reference.hinge_angles[]; length == 28)
  and .policy.version > 0 and .policy.samples > 0' "$side" > /dev/null ||
  fail "sidecar: $(jq -c '{model, control, clip, policy}' "$side")"
echo "sidecar: $(jq '.observation.size' "$side") observations, $(jq '.action.size' "$side") axes" \
  "($(jq -r '.action.mode' "$side") mode), $(stat -c %s "$side") bytes"

# Debian's Python onnx, a checker other than the one the exporter ran.
"$python" - "$out/policy.onnx" << 'PY' || fail "Python's onnx checker refuses the model"
import sys
import onnx
model = onnx.load(sys.argv[1])
onnx.checker.check_model(model, full_check=True)
props = {p.key: p.value for p in model.metadata_props}
print(f"python3-onnx {onnx.__version__}: checker accepts the model (opset "
      f"{model.opset_import[0].version}, IR {model.ir_version}, policy v{props['policy_version']}, "
      f"ragdoll {props['ragdoll_version']})")
PY

# Real rollouts with libtorch's actions and values, then the same observations in ONNX Runtime.
"$recorder" "$run" 2000 "$work/record" || fail "recording rollouts"
node "$here/check_onnx.js" "$out/policy.onnx" "$side" "$work/record" 1e-5 ||
  fail "ONNX Runtime differs from libtorch"

# A missing run: refused, naming it; nothing written.
"$ragdoll" export "$work/no-such-run" --onnx "$work/x.onnx" 2> "$work/missing.log" &&
  fail "exported a run that does not exist"
grep -q "no-such-run: no such run folder or checkpoint file" "$work/missing.log" ||
  fail "missing run: $(cat "$work/missing.log")"
ls "$work"/x.* > /dev/null 2>&1 && fail "files written for a missing run"

# Damaged checkpoints (one bit flipped in each): refused, naming the file and the damage.
cp -r "$run" "$work/damaged"
for f in "$work"/damaged/checkpoints/checkpoint-*.pt; do
  "$python" - "$f" << 'PY'
import os, sys
with open(sys.argv[1], "r+b") as f:
    at = os.path.getsize(sys.argv[1]) // 2
    f.seek(at); b = f.read(1); f.seek(at); f.write(bytes([b[0] ^ 0x04]))
PY
done
newest=$(ls "$work"/damaged/checkpoints/checkpoint-*.pt | sort | tail -n 1)
"$ragdoll" export "$newest" --onnx "$work/x.onnx" 2> "$work/damaged-file.log" &&
  fail "exported a damaged checkpoint"
grep -q "$(basename "$newest"): checksum mismatch" "$work/damaged-file.log" ||
  fail "damaged checkpoint: $(cat "$work/damaged-file.log")"
"$ragdoll" export "$work/damaged" --onnx "$work/x.onnx" 2> "$work/damaged-run.log" &&
  fail "exported a run whose checkpoints are all damaged"
grep -q "damaged: no whole checkpoint found" "$work/damaged-run.log" ||
  fail "damaged run: $(cat "$work/damaged-run.log")"
ls "$work"/x.* > /dev/null 2>&1 && fail "files written for a damaged checkpoint"

# Unwritable outputs: a folder that does not exist for the model, then for the sidecar only; a
# model already in place stays as it was and no temporary file is left.
"$ragdoll" export "$run" --onnx "$work/nowhere/policy.onnx" 2> "$work/unwritable.log" &&
  fail "wrote into a missing folder"
grep -q "nowhere/policy.onnx: cannot write (No such file or directory)" "$work/unwritable.log" ||
  fail "unwritable model: $(cat "$work/unwritable.log")"
mkdir "$work/keep"
echo "an earlier model" > "$work/keep/policy.onnx"
"$ragdoll" export "$run" --onnx "$work/keep/policy.onnx" --sidecar "$work/nowhere/policy.json" \
  2> "$work/unwritable-sidecar.log" && fail "wrote a sidecar into a missing folder"
grep -q "nowhere/policy.json: cannot write (No such file or directory)" \
  "$work/unwritable-sidecar.log" || fail "unwritable sidecar: $(cat "$work/unwritable-sidecar.log")"
[ "$(cat "$work/keep/policy.onnx")" = "an earlier model" ] || fail "the earlier model was replaced"
[ "$(ls "$work/keep")" = "policy.onnx" ] || fail "stray files: $(ls "$work/keep")"

echo "PASS in $((SECONDS - begin)) s"
