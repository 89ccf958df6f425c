#!/usr/bin/env bash
# The real broker, learner and two actors on loopback learn a small task, survive losing an
# actor, drop malformed messages, and resume exactly after the learner is killed.
#   distributed_training_test.sh RAGDOLL INJECTOR CONFIG
set -u
ragdoll=$1 inject=$2 config=$3
work=$(mktemp -d /tmp/ragdoll-itest.XXXXXX)
run=itest port=$((17000 + RANDOM % 2000))
common=("$config" --run-id "$run" --port-base "$port")
pids=()
cleanup() { kill "${pids[@]}" 2>/dev/null; wait 2>/dev/null; rm -rf "$work"; }
trap cleanup EXIT
fail() { echo "FAIL: $*"; echo "--- learner log"; tail -n 30 "$work"/learner*.log; echo "--- broker log"; tail -n 10 "$work/broker.log"; exit 1; }
iterations() { cat "$work/learner.log" 2>/dev/null | grep -c "^\["; }
wait_for() {  # seconds, description, command...
  local limit=$1 what=$2; shift 2
  for ((i = 0; i < limit * 10; i++)); do "$@" && return 0; sleep 0.1; done
  fail "timed out after ${limit}s waiting for $what"
}

"$ragdoll" broker "${common[@]}" > "$work/broker.log" 2>&1 & pids+=($!)
# Actors start before the learner: they must wait for the first snapshot, not crash.
"$ragdoll" actor "${common[@]}" --index 0 > "$work/actor0.log" 2>&1 & pids+=($!)
"$ragdoll" actor "${common[@]}" --index 1 > "$work/actor1.log" 2>&1 & actor1=$!; pids+=($actor1)
sleep 3
"$ragdoll" learner "${common[@]}" --run-dir "$work/$run" > "$work/learner.log" 2>&1 & learner=$!; pids+=($learner)

wait_for 60 "3 PPO iterations" bash -c "[ \$(grep -c '^\[' '$work/learner.log') -ge 3 ]"
grep -q "waiting for the first policy snapshot" "$work/actor0.log" || fail "actor did not report waiting for a snapshot"

# Lose an actor: training continues on the other.
kill -9 "$actor1"
before=$(iterations)
"$inject" 127.0.0.1 "$port" "$run" || fail "injector failed"
wait_for 60 "2 more iterations after killing an actor" bash -c "[ \$(grep -c '^\[' '$work/learner.log') -ge $((before + 2)) ]"
grep -q "dropped a message on trajectories (malformed)" "$work/broker.log" || fail "broker did not count the malformed message"
grep -q "dropped a segment (non_finite)" "$work/learner.log" || fail "learner did not drop the NaN segment"

# Let it learn (about 140 k samples), then kill the learner without warning and resume from its last checkpoint.
wait_for 150 "35 iterations" bash -c "[ \$(grep -c '^\[' '$work/learner.log') -ge 35 ]"
kill -9 "$learner"; wait "$learner" 2>/dev/null
last_version=$(grep "^\[" "$work/learner.log" | tail -n 1 | sed 's/.* v\([0-9]*\) .*/\1/')
# A checkpoint being written when the learner died is left as *.tmp: not a checkpoint.
newest=$(ls "$work/$run/checkpoints" | grep "^checkpoint-[0-9]*\.pt$" | sort | tail -n 1)
[ -n "$newest" ] || fail "no checkpoint written"
samples=$(echo "$newest" | sed 's/checkpoint-0*\([0-9]*\)\.pt/\1/')
"$ragdoll" learner "${common[@]}" --run-dir "$work/$run" --resume > "$work/learner2.log" 2>&1 & learner=$!; pids+=($learner)
wait_for 30 "the resumed learner's first iteration" grep -q "^\[" "$work/learner2.log"
resumed=$(grep -o "resumed from .* at policy v[0-9]*, [0-9]* samples" "$work/learner2.log")
[ -n "$resumed" ] || fail "learner did not report resuming"
version=$(echo "$resumed" | sed 's/.*policy v\([0-9]*\),.*/\1/')
[ "$(echo "$resumed" | sed 's/.*, \([0-9]*\) samples/\1/')" = "$samples" ] || fail "resumed at other samples than the checkpoint ($resumed vs $samples)"
first=$(grep -m1 "^\[" "$work/learner2.log")
next_version=$(echo "$first" | sed 's/.* v\([0-9]*\) .*/\1/')
next_samples=$(echo "$first" | sed 's/.*samples \([0-9]*\) .*/\1/')
# Numbering continues after the checkpoint's version, or above the newest version the actors
# still run (the killed learner's last, when they got it before the kill): never backward.
[ "$next_version" -gt "$version" ] && [ "$next_version" -le $((last_version + 1)) ] ||
  fail "version did not continue: checkpoint v$version, last before the kill v$last_version, then v$next_version"
[ "$next_samples" -gt "$samples" ] || fail "samples did not continue: $samples then $next_samples"
echo "resumed at v$version / $samples samples; next iteration v$next_version / $next_samples samples"

# Learning: the normalised return of the last 3 iterations clears the first 3 by 0.04.
awk -F, 'NR > 1 { r[n++] = $8 } END {
  first = (r[0] + r[1] + r[2]) / 3; last = (r[n-1] + r[n-2] + r[n-3]) / 3;
  printf "normalised return: first 3 iterations %.3f, last 3 %.3f (%d iterations)\n", first, last, n;
  exit !(last >= first + 0.04) }' "$work/$run/metrics.csv" || fail "did not learn enough"
echo "1 passed, 0 failed"
