#!/usr/bin/env bash
# Checkpoints that cannot silently rot, with real processes:
#  - a learner whose file size limit drops below one checkpoint (prlimit: as a full disk) logs and
#    counts the failure, keeps its earlier checkpoints whole and trains on; with the limit lifted
#    the next checkpoint is written;
#  - a bit-flipped newest checkpoint is detected by `eval` and `render`, which use the previous
#    one and name both; a truncated newest one by `train --resume`, which sets it aside and
#    resumes from the previous one.
#   checkpoint_integrity_test.sh RAGDOLL CONFIG
set -u
ragdoll=$1 config=$2
work=$(mktemp -d /tmp/ragdoll-checkpoints.XXXXXX)
run=ck port=$((25000 + RANDOM % 2000))
train=
cleanup() { [ -n "$train" ] && kill "$train" 2>/dev/null; wait 2>/dev/null; rm -rf "$work"; }
trap cleanup EXIT
fail() { echo "FAIL: $*"; for f in "$work"/*.log; do echo "--- $f"; tail -n 20 "$f"; done; exit 1; }
wait_for() {  # seconds, description, command...
  local limit=$1 what=$2; shift 2
  for ((i = 0; i < limit * 10; i++)); do "$@" && return 0; sleep 0.1; done
  fail "timed out after ${limit}s waiting for $what"
}
metric() { curl -sf "http://127.0.0.1:$1/metrics" | awk -v n="$2" '$1 ~ "^"n"({|$)" { print $2; exit }'; }
saved() { grep -c "learner: saved checkpoint /" "$work/train.log"; }
iterations() { grep -c '^\[' "$work/train.log"; }
ckdir=$work/$run/checkpoints

# Logs go through a pipe: a file size limit applies to every file the learner writes, its log too.
"$ragdoll" train "$config" --actors 1 --port-base "$port" --runs-dir "$work" --run-id "$run" \
  > >(cat > "$work/train.log") 2>&1 &
train=$!
wait_for 120 "2 checkpoints" bash -c "[ \$(grep -c 'learner: saved checkpoint /' '$work/train.log' 2>/dev/null) -ge 2 ]"

# A full disk: the learner's file size limit drops to 1 KiB.
learner=$(pgrep -f -- "learner .*--run-id $run" | head -n 1)
[ -n "$learner" ] || fail "no learner process"
prlimit --pid "$learner" --fsize=1024:unlimited || fail "prlimit"
sums_before=$(cd "$ckdir" && sha256sum checkpoint-*.pt)
wait_for 120 "a failed checkpoint" grep -q "checkpoint FAILED: .*File too large" "$work/train.log"
failures=$(metric $((port + 10)) ragdoll_learner_checkpoint_failures_total)
[ "${failures%.*}" -ge 1 ] || fail "failure not counted ($failures)"
before=$(iterations)
wait_for 60 "training to go on" bash -c "[ \$(grep -c '^\[' '$work/train.log') -ge $((before + 3)) ]"
[ "$(cd "$ckdir" && sha256sum checkpoint-*.pt)" = "$sums_before" ] || fail "earlier checkpoints changed"
ls "$ckdir" | grep -q '\.tmp$' && fail "a temporary file was left behind"
grep "checkpoint FAILED" "$work/train.log" | head -n 1
prlimit --pid "$learner" --fsize=unlimited:unlimited || fail "prlimit (lift)"
n=$(saved)
wait_for 120 "a checkpoint after the limit was lifted" bash -c "[ \$(grep -c 'learner: saved checkpoint /' '$work/train.log' 2>/dev/null) -gt $n ]"
kill -INT "$train"; wait "$train"; train=
grep -q "final (stopped) checkpoint /" "$work/train.log" || fail "no final checkpoint"

mapfile -t all < <(ls "$ckdir"/checkpoint-*.pt | sort)
newest=${all[-1]} previous=${all[-2]}
# One bit flipped in the middle of the newest checkpoint.
size=$(stat -c %s "$newest")
python3 - "$newest" $((size / 2)) <<'PY'
import sys
path, at = sys.argv[1], int(sys.argv[2])
with open(path, "r+b") as f:
    f.seek(at); b = f.read(1); f.seek(at); f.write(bytes([b[0] ^ 0x04]))
PY
"$ragdoll" eval "$work/$run" --episodes 2 > "$work/eval.json" 2> "$work/eval.log" || fail "eval failed"
grep -q "$(basename "$newest"): checksum mismatch.*using the previous one, $previous" "$work/eval.log" ||
  fail "eval did not name the damaged and the used checkpoint"
grep -q "\"checkpoint\": \"$previous\"" "$work/eval.json" || fail "eval did not use $previous"
"$ragdoll" eval "$newest" --episodes 1 > /dev/null 2> "$work/eval-file.log" && fail "eval of the damaged file itself succeeded"
grep -q "checksum mismatch" "$work/eval-file.log" || fail "no reason for the damaged file"
if command -v xvfb-run > /dev/null; then
  xvfb-run -a -s "-screen 0 640x480x24" "$ragdoll" render "$work/$run" --out "$work/frame.png" \
    --width 160 --height 90 > "$work/render.log" 2>&1 || fail "render failed"
  grep -q "checksum mismatch.*using the previous one" "$work/render.log" || fail "render did not say"
fi

# Truncated instead, then --resume: the damaged file is set aside, the previous one resumed.
truncate -s $((size - 1000)) "$newest"
"$ragdoll" train "$config" --actors 1 --port-base "$port" --runs-dir "$work" --run-id "$run" \
  --resume > "$work/resume.log" 2>&1 &
train=$!
wait_for 60 "the resumed learner" grep -q "resumed from" "$work/resume.log"
grep -q "$(basename "$newest"): truncated.*set aside as $(basename "$newest").damaged; using $previous instead" \
  "$work/resume.log" || fail "resume did not name the damaged and the used checkpoint"
grep -q "resumed from $previous" "$work/resume.log" || fail "did not resume from $previous"
[ -f "$newest.damaged" ] || fail "the damaged checkpoint was not kept aside"
wait_for 60 "training after the resume" bash -c "[ \$(grep -c '^\[' '$work/resume.log') -ge 2 ]"
kill -INT "$train"; wait "$train"; train=
echo "PASS"
