#!/usr/bin/env bash
# Ctrl-C and `--resume` at once, as the README invites: a training is stopped with SIGINT after
# its first PPO update and resumed within a second, ROUNDS times (default 10); each resume starts
# (its ports bind although the last run's connections wait in TIME-WAIT) and carries the run on.
# While a run is live, a second `ragdoll train` on its ports is refused with the --port-base hint.
#   stop_resume_test.sh RAGDOLL CONFIG
set -u
ragdoll=$1 config=$2
rounds=${ROUNDS:-10}
work=$(mktemp -d /tmp/ragdoll-stop-resume.XXXXXX)
# Below 32768, where Linux takes the local ports of outgoing connections (one held 35800 once).
port=$((28700 + 50 * (RANDOM % 20)))
pids=()
cleanup() { kill -INT "${pids[@]}" 2> /dev/null; wait 2> /dev/null; rm -rf "$work"; }
trap cleanup EXIT
fail() { echo "FAIL: $*"; exit 1; }
updates() { cat "$1" 2> /dev/null | grep -c '^\['; }
config_dir=$(cd "$(dirname "$config")" && pwd)
sed -E "s#^(\\s*(motion|character):\\s*)([^/[:space:]][^[:space:]]*)#\\1$config_dir/\\3#" \
  "$config" > "$work/config.yaml"
train() {  # log, extra options...: starts a training in the background (pid in $train_pid)
  local log=$1; shift
  "$ragdoll" train "$work/config.yaml" --run-id run --runs-dir "$work" --port-base "$port" \
    --actors 1 "$@" > "$log" 2>&1 &
  train_pid=$!
  pids+=($train_pid)
}
wait_updates() {  # log, pid: until the log shows a PPO update
  local started=$SECONDS
  until [ "$(updates "$1")" -ge 1 ]; do
    kill -0 "$2" 2> /dev/null || fail "training ended: $(tail -n 5 "$1")"
    [ $((SECONDS - started)) -lt 120 ] || fail "no PPO update in 120 s: $(tail -n 5 "$1")"
    sleep 0.2
  done
}
sample_count() { sed -n 's/.* samples \([0-9]*\) .*/\1/p' "$1" | tail -n 1; }

train "$work/0.log"
wait_updates "$work/0.log" "$train_pid"
# A live run's ports are refused to a second training, with the hint.
"$ragdoll" train "$work/config.yaml" --run-id other --runs-dir "$work" --port-base "$port" \
  --actors 1 > "$work/second.log" 2>&1 && fail "a second training started on a live run's ports"
grep -q "port $port is in use.*--port-base" "$work/second.log" ||
  fail "the second training's refusal: $(cat "$work/second.log")"
echo "a second training on live ports: $(grep -o 'port [0-9]* is in use[^;]*' "$work/second.log")"

previous=0
for ((round = 1; round <= rounds; round++)); do
  kill -INT "$train_pid"
  wait "$train_pid" || fail "round $round: the training did not stop cleanly"
  stopped_at=$(date +%s.%N)
  samples=$(sample_count "$work/$((round - 1)).log")
  train "$work/$round.log" --resume
  gap=$(awk -v a="$stopped_at" -v b="$(date +%s.%N)" 'BEGIN { printf "%.2f", b - a }')
  wait_updates "$work/$round.log" "$train_pid"
  resumed=$(sample_count "$work/$round.log")
  grep -q "in use" "$work/$round.log" && fail "round $round refused: $(cat "$work/$round.log")"
  [ "$resumed" -gt "$samples" ] ||
    fail "round $round: resumed at $resumed samples, the stopped run had $samples"
  [ "$samples" -gt "$previous" ] || fail "round $round: no progress ($samples samples)"
  previous=$samples
  waiting=$(ss -Htan state time-wait "( sport >= :$port and sport <= :$((port + 49)) ) or ( dport >= :$port and dport <= :$((port + 49)) )" | wc -l)
  echo "round $round: resumed ${gap} s after the stop ($waiting connections in TIME-WAIT)," \
    "at $resumed samples"
done
kill -INT "$train_pid"
wait "$train_pid" || fail "the last training did not stop cleanly"
echo "1 passed, 0 failed"
