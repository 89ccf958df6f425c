#!/usr/bin/env bash
# Chaos with real processes: broker, learner and two actors run as separate processes under a
# supervisor loop (restart at once, as `restart: always` would; the learner with --resume), while
# a killer SIGKILLs a role every 12-30 s for CHAOS_SECONDS (default 150): the roles in a shuffled
# order, reshuffled after each round, so that every role dies at least once in the default run
# (4 kills at the least, about 7 usually; a random role each time, as before, spared some role
# in about one run of eight at 240 s).
# Asserts: training progresses over the run; the policy version never goes backward (progress
# lines across learner restarts, and the broker's snapshot version between its own restarts);
# every checkpoint on disk is whole, loads and is finite (`ragdoll verify`); actors reconnect
# within 10 s of a broker restart; no process exits unless killed (no crash loop). Prints kills
# per role, samples rolled back per learner kill and reconnect times.
#   chaos_test.sh RAGDOLL CONFIG            CHAOS_SECONDS=3600 for the long version
set -u
ragdoll=$1
seconds=${CHAOS_SECONDS:-150}
seed=${CHAOS_SEED:-$RANDOM}
RANDOM=$seed
work=$(mktemp -d /tmp/ragdoll-chaos.XXXXXX)
# The config with max_steps out of reach, so that only the killer ends a process (a fast machine
# finished learn_stand's 1 M samples inside 240 s). The copy lives elsewhere, so the keys the
# reader resolves against the config's folder (motion, also in a motion list, character, keys)
# are made absolute.
config=$work/chaos.yaml
config_dir=$(cd "$(dirname "$2")" && pwd)
sed -E -e 's/^(\s*max_steps:).*/\1 1.0e9/' \
  -e "s#^(\\s*(- )?(motion|character|keys):\\s*)([^/\"'[:space:]][^[:space:]]*)#\\1$config_dir/\\4#" \
  "$2" > "$config"
# Ports below 32768: above it Linux takes the local ports of outgoing connections.
run=chaos port=$((11000 + RANDOM % 2000))
declare -A pid kills restarts
roles=(broker learner actor-0 actor-1)
cleanup() {
  for r in "${roles[@]}"; do [ -n "${pid[$r]:-}" ] && kill -9 "${pid[$r]}" 2>/dev/null; done
  wait 2>/dev/null; rm -rf "$work"
}
trap cleanup EXIT
fail() {
  echo "FAIL: $* (seed $seed)"
  for r in "${roles[@]}"; do echo "--- $r"; tail -n 12 "$work/$r.log"; done
  exit 1
}
metric() { curl -sf --max-time 1 "http://127.0.0.1:$1/metrics" | awk -v n="$2" '$1 ~ "^"n"({|$)" { print $2; exit }'; }
start() {  # role
  local r=$1 args=("$config" --run-id "$run" --port-base "$port")
  case $r in
    broker) args=(broker "${args[@]}") ;;
    learner) args=(learner "${args[@]}" --run-dir "$work/$run" --resume) ;;
    actor-*) args=(actor "${args[@]}" --index "${r#actor-}") ;;
  esac
  "$ragdoll" "${args[@]}" >> "$work/$r.log" 2>&1 &
  pid[$r]=$!
}
for r in "${roles[@]}"; do kills[$r]=0; restarts[$r]=0; start "$r"; done

t0=$SECONDS
next_kill=$((SECONDS + 12 + RANDOM % 19))
order=()  # the roles still to kill in this round
broker_restarted_at=-1 last_broker_version=-1 reconnects=() rolled_back=()
while [ $((SECONDS - t0)) -lt "$seconds" ]; do
  sleep 0.2
  # Supervisor: a process that exits without being killed is a failure (crash or crash loop).
  for r in "${roles[@]}"; do
    if ! kill -0 "${pid[$r]}" 2>/dev/null; then
      wait "${pid[$r]}" 2>/dev/null; code=$?
      fail "$r exited by itself (exit $code) $((SECONDS - t0)) s into the run"
    fi
  done
  # Killer.
  if [ "$SECONDS" -ge "$next_kill" ]; then
    if [ ${#order[@]} -eq 0 ]; then  # a new round: the three roles, shuffled
      order=(broker learner actor)
      for ((i = 2; i > 0; i--)); do
        j=$((RANDOM % (i + 1))); t=${order[$i]}; order[$i]=${order[$j]}; order[$j]=$t
      done
    fi
    r=${order[0]}; order=("${order[@]:1}")
    [ "$r" = actor ] && r=actor-$((RANDOM % 2))
    if [ "$r" = learner ]; then  # what the learner had trained when it died
      before=$(metric $((port + 10)) ragdoll_learner_run_samples)
    fi
    kill -9 "${pid[$r]}"; wait "${pid[$r]}" 2>/dev/null
    kills[$r]=$((kills[$r] + 1))
    echo "[$((SECONDS - t0)) s] killed $r"
    start "$r"; restarts[$r]=$((restarts[$r] + 1))
    if [ "$r" = broker ]; then
      broker_restarted_at=$SECONDS last_broker_version=-1
      declare -A connects_before=()
      for i in 0 1; do connects_before[$i]=$(metric $((port + 20 + i)) ragdoll_actor_reconnects_total); done
      pending_reconnect=1
    fi
    if [ "$r" = learner ]; then
      for ((w = 0; w < 100; w++)); do grep -q "resumed from\|starting fresh" <(tail -n 5 "$work/learner.log") && break; sleep 0.2; done
      resumed=$(grep -o "resumed from .* at policy v[0-9]*, [0-9]* samples" "$work/learner.log" | tail -n 1 | sed 's/.*, \([0-9]*\) samples/\1/')
      [ -n "$before" ] && [ -n "$resumed" ] && rolled_back+=($(( ${before%.*} - resumed )))
    fi
    next_kill=$((SECONDS + 12 + RANDOM % 19))
  fi
  # Actors reconnect within 10 s of a broker restart (unless they were restarted themselves).
  if [ "${pending_reconnect:-0}" = 1 ]; then
    done_all=1
    for i in 0 1; do
      now=$(metric $((port + 20 + i)) ragdoll_actor_reconnects_total)
      [ -n "$now" ] && [ -n "${connects_before[$i]}" ] && [ "${now%.*}" -gt "${connects_before[$i]%.*}" ] || done_all=0
    done
    if [ "$done_all" = 1 ]; then
      reconnects+=($((SECONDS - broker_restarted_at))); pending_reconnect=0
    elif [ $((SECONDS - broker_restarted_at)) -gt 10 ]; then
      # An actor killed and restarted meanwhile connects afresh (no reconnect to count).
      for i in 0 1; do
        [ "$(metric $((port + 20 + i)) ragdoll_actor_connected)" = 1 ] || fail "actor-$i not connected 10 s after a broker restart"
      done
      reconnects+=(">10 (restarted)"); pending_reconnect=0
    fi
  fi
  # The broker's snapshot version never goes backward while it lives.
  v=$(metric $((port + 11)) ragdoll_broker_snapshot_version); v=${v%.*}
  if [ -n "$v" ] && [ "$v" != -1 ]; then
    [ "$v" -ge "$last_broker_version" ] || fail "broker snapshot version went from $last_broker_version to $v"
    last_broker_version=$v
  fi
done
for r in "${roles[@]}"; do kill -TERM "${pid[$r]}" 2>/dev/null; done
for r in "${roles[@]}"; do wait "${pid[$r]}" 2>/dev/null; done
pid=()

# Progress lines, across every learner restart: versions never go backward, samples grow.
versions=$(grep -o "  v[0-9]*  " "$work/learner.log" | tr -d ' v')
[ -n "$versions" ] || fail "no progress line"
echo "$versions" | awk 'NR > 1 && $1 < prev { print "backward: v" prev " then v" $1; bad = 1 } { prev = $1 } END { exit bad }' ||
  fail "the policy version went backward"
[ "${kills[broker]}" -ge 1 ] && [ "${kills[learner]}" -ge 1 ] && [ $((kills[actor-0] + kills[actor-1])) -ge 1 ] ||
  fail "a role was never killed: broker ${kills[broker]}, learner ${kills[learner]}, actors $((kills[actor-0] + kills[actor-1]))"
first=$(echo "$versions" | head -n 1) last=$(echo "$versions" | tail -n 1)
samples=$(grep "^\[" "$work/learner.log" | tail -n 1 | sed 's/.*samples \([0-9]*\) .*/\1/')
[ "$last" -ge $((first + 20)) ] || fail "little progress: v$first to v$last"
"$ragdoll" verify "$work/$run" > "$work/verify.log" 2>&1 || { cat "$work/verify.log"; fail "a checkpoint is bad"; }
echo "figures (seed $seed, $seconds s): kills broker ${kills[broker]}, learner ${kills[learner]}," \
  "actors $((kills[actor-0] + kills[actor-1])); policy v$first -> v$last, $samples samples trained;" \
  "samples rolled back per learner kill: ${rolled_back[*]:-none}; actor reconnect after broker restart (s): ${reconnects[*]:-none};" \
  "$(grep -c '^ok' "$work/verify.log") checkpoints verified"
echo "PASS"
