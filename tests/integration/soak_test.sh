#!/usr/bin/env bash
# A long run that proves nothing grows: a real training (broker, learner, two actors as separate
# processes), a killer that SIGKILLs and restarts one role every SOAK_KILL_EVERY seconds (in turn:
# learner, broker, actor-0, actor-1), a scraper reading every role's /metrics every 2 s, and a
# sampler that records every role's resident memory, open descriptors and threads and the run
# folder's disk use every SOAK_SAMPLE seconds (samples.csv). Part-way, the learner is stopped
# (SIGSTOP) for 60 s and continued. Asserts (soak_check.py):
#  - after a warm-up, no process's memory grows by more than 5 % per hour (plus 8 MB of noise),
#    descriptors by more than 5, threads by more than 2, within its life;
#  - each restart's memory, at the same age, is within 15 % of the role's first life;
#  - the run folder stays within (keep_checkpoints + 1) x the checkpoint size + its logs;
#  - while the learner is stopped the broker's and actors' memory stays within 64 MB of where it
#    was (the actors keep collecting; the broker drops what the learner cannot take at once and
#    counts it), the dropped segments are counted (the broker's unforwarded, the learner's stale),
#    and the learner publishes new policies within 60 s of being continued.
# SOAK_SECONDS 1200 (the test), 7200 for the two-hour soak (docs/testing.md); SOAK_OUT keeps the
# samples and the PNG of the curves (soak_plot.py).
#   soak_test.sh RAGDOLL CONFIG
set -u
ragdoll=$1 here=$(cd "$(dirname "$0")" && pwd)
seconds=${SOAK_SECONDS:-1200} sample_every=${SOAK_SAMPLE:-60}
kill_every=${SOAK_KILL_EVERY:-$((seconds / 5))}
stall_at=${SOAK_STALL_AT:-$((seconds * 2 / 5))}
work=$(mktemp -d /tmp/ragdoll-soak.XXXXXX)
out=${SOAK_OUT:-$work/out}
mkdir -p "$out"
config=$work/soak.yaml
config_dir=$(cd "$(dirname "$2")" && pwd)
sed -E -e 's/^(\s*max_steps:).*/\1 1.0e9/' \
  -e "s#^(\\s*(- )?(motion|character|keys):\\s*)([^/\"'[:space:]][^[:space:]]*)#\\1$config_dir/\\4#" \
  "$2" > "$config"
keep=$(sed -n 's/^\s*keep_checkpoints:\s*\([0-9]*\).*/\1/p' "$config")
# Ports below 32768: above it Linux takes the local ports of outgoing connections.
run=soak port=$((15000 + 50 * (RANDOM % 20)))
roles=(broker learner actor-0 actor-1)
declare -A pid life metrics_port=([learner]=$((port + 10)) [broker]=$((port + 11))
  [actor-0]=$((port + 20)) [actor-1]=$((port + 21)))
scraper=
cleanup() {
  [ -n "$scraper" ] && kill "$scraper" 2> /dev/null
  for r in "${roles[@]}"; do [ -n "${pid[$r]:-}" ] && kill -CONT "${pid[$r]}" 2> /dev/null &&
    kill -9 "${pid[$r]}" 2> /dev/null; done
  wait 2> /dev/null
  [ -n "${SOAK_OUT:-}" ] || rm -rf "$work"
}
trap cleanup EXIT
fail() {
  echo "FAIL: $*"
  for r in "${roles[@]}"; do echo "--- $r"; tail -n 8 "$work/$r.log"; done
  exit 1
}
metric() {  # port, name: the first sample's value
  curl -sf --max-time 2 "http://127.0.0.1:$1/metrics" |
    awk -v n="$2" '$1 ~ "^"n"({|$)" { print $2; exit }'
}
start() {  # role
  local r=$1 args=("$config" --run-id "$run" --port-base "$port")
  case $r in
    broker) args=(broker "${args[@]}") ;;
    learner) args=(learner "${args[@]}" --run-dir "$work/$run" --resume) ;;
    actor-*) args=(actor "${args[@]}" --index "${r#actor-}") ;;
  esac
  "$ragdoll" "${args[@]}" >> "$work/$r.log" 2>&1 &
  pid[$r]=$!
  life[$r]=$((${life[$r]:-0} + 1))
  born[$r]=$SECONDS
}
declare -A born
sample() {  # phase: one row per role
  local now=$((SECONDS - t0)) disk logs
  disk=$(du -sb "$work/$run" 2> /dev/null | cut -f1)
  logs=$(find "$work/$run" -maxdepth 1 -type f \( -name '*.csv' -o -name '*.log' -o -name '*.yaml' \) \
    -printf '%s\n' 2> /dev/null | awk '{ s += $1 } END { print s + 0 }')
  for r in "${roles[@]}"; do
    local p=${pid[$r]} rss fds threads
    rss=$(awk '/^VmRSS:/ { print $2 }' "/proc/$p/status" 2> /dev/null)
    threads=$(awk '/^Threads:/ { print $2 }' "/proc/$p/status" 2> /dev/null)
    fds=$(ls "/proc/$p/fd" 2> /dev/null | wc -l)
    [ -n "$rss" ] || continue
    echo "$now,$1,$r,${life[$r]},$((SECONDS - born[$r])),$rss,$fds,$threads,${disk:-0},$logs" \
      >> "$out/samples.csv"
  done
}
echo "t,phase,role,life,age,rss_kb,fds,threads,run_bytes,log_bytes" > "$out/samples.csv"
for r in "${roles[@]}"; do start "$r"; done
( while true; do
    for r in "${roles[@]}"; do curl -sf --max-time 2 "http://127.0.0.1:${metrics_port[$r]}/metrics" \
      -o /dev/null; done
    sleep 2
  done ) > /dev/null 2>&1 &
scraper=$!

t0=$SECONDS next_sample=$SECONDS next_kill=$((SECONDS + kill_every)) kill_turn=0 stalled=0
max_checkpoint=0
echo "soak: ${seconds} s, a sample every ${sample_every} s, a kill every ${kill_every} s," \
  "the learner stopped for 60 s at ${stall_at} s (ports $port...)"
while [ $((SECONDS - t0)) -lt "$seconds" ]; do
  sleep 1
  for r in "${roles[@]}"; do
    kill -0 "${pid[$r]}" 2> /dev/null ||
      fail "$r exited by itself $((SECONDS - t0)) s into the soak"
  done
  for c in "$work/$run"/checkpoints/checkpoint-*.pt; do
    [ -f "$c" ] || continue
    s=$(stat -c %s "$c" 2> /dev/null || echo 0)
    [ "$s" -gt "$max_checkpoint" ] && max_checkpoint=$s
  done
  if [ "$SECONDS" -ge "$next_sample" ]; then
    sample run
    next_sample=$((next_sample + sample_every))
  fi
  if [ "$stalled" = 0 ] && [ $((SECONDS - t0)) -ge "$stall_at" ]; then
    stalled=1
    idle_before=$(metric "${metrics_port[actor-0]}" ragdoll_actor_idle_seconds_total)
    unforwarded_before=$(metric "${metrics_port[broker]}" ragdoll_broker_segments_unforwarded_total)
    stale_before=$(metric "${metrics_port[learner]}" ragdoll_learner_stale_segments_dropped_total)
    before_version=$(metric "${metrics_port[broker]}" ragdoll_broker_snapshot_version)
    kill -STOP "${pid[learner]}"
    echo "[$((SECONDS - t0)) s] learner stopped (SIGSTOP) at policy v${before_version%.*}"
    stall_end=$((SECONDS + 60))
    while [ "$SECONDS" -lt "$stall_end" ]; do sample stall; sleep 5; done
    idle_after=$(metric "${metrics_port[actor-0]}" ragdoll_actor_idle_seconds_total)
    unforwarded_after=$(metric "${metrics_port[broker]}" ragdoll_broker_segments_unforwarded_total)
    kill -CONT "${pid[learner]}"
    continued=$SECONDS
    until v=$(metric "${metrics_port[broker]}" ragdoll_broker_snapshot_version) &&
      [ "${v%.*}" -gt "${before_version%.*}" ]; do
      [ $((SECONDS - continued)) -lt 60 ] || fail "no new policy within 60 s of SIGCONT"
      sleep 1
    done
    resumed_after=$((SECONDS - continued))
    sleep 20  # the queued segments reach the learner; those made too many versions back are stale
    stale_after=$(metric "${metrics_port[learner]}" ragdoll_learner_stale_segments_dropped_total)
    echo "[$((SECONDS - t0)) s] learner continued: a new policy after ${resumed_after} s;" \
      "actor-0 waited $(awk -v a="$idle_before" -v b="$idle_after" 'BEGIN { printf "%.0f", b - a }') s" \
      "of the 60 s; the broker dropped $(( ${unforwarded_after%.*} - ${unforwarded_before%.*} ))" \
      "segments during it, the learner $(( ${stale_after%.*} - ${stale_before%.*} )) stale ones after it"
    echo "${idle_before%.*},${idle_after%.*},${unforwarded_before%.*},${unforwarded_after%.*},${stale_before%.*},${stale_after%.*},$resumed_after" \
      > "$out/stall.csv"
    sample after-stall
  fi
  if [ "$SECONDS" -ge "$next_kill" ]; then
    order=(learner broker actor-0 actor-1)
    r=${order[$((kill_turn % 4))]}
    kill_turn=$((kill_turn + 1))
    kill -9 "${pid[$r]}"; wait "${pid[$r]}" 2> /dev/null
    start "$r"
    echo "[$((SECONDS - t0)) s] killed and restarted $r (life ${life[$r]})"
    next_kill=$((SECONDS + kill_every))
  fi
done
sample end
versions=$(grep -o "  v[0-9]*  " "$work/learner.log" | tr -d ' v')
echo "policy v$(echo "$versions" | head -n 1) -> v$(echo "$versions" | tail -n 1);" \
  "largest checkpoint $max_checkpoint bytes, keep_checkpoints $keep"
python3 "$here/soak_check.py" "$out/samples.csv" "$out/stall.csv" "$keep" "$max_checkpoint" ||
  fail "the soak's bounds (above)"
if command -v rsvg-convert > /dev/null; then
  python3 "$here/soak_plot.py" "$out/samples.csv" "$out/soak.svg" &&
    rsvg-convert -o "$out/soak.png" "$out/soak.svg" && echo "curves: $out/soak.png"
fi
"$ragdoll" verify "$work/$run" > "$work/verify.log" 2>&1 || { cat "$work/verify.log"; fail "a checkpoint is bad"; }
echo "1 passed, 0 failed"
