#!/usr/bin/env bash
# Every role's /metrics endpoint under attack while a real Prometheus scrapes it every second:
#  - `ragdoll train` on loopback (broker, learner, one actor) serves metrics on 127.0.0.1 only;
#  - for ATTACK_SECONDS (default 105), against each of the three endpoints: 100 clients that trickle
#    a request a byte a second, 100 that connect and send nothing (reconnecting whenever dropped),
#    and a malformed request a second (random bytes, 1 MB header, half-closed, bad method with a
#    huge body, 2000 headers, NUL bytes; tests/integration/metrics_attacker.py);
#  - at least 99 % of Prometheus's scrapes succeed during the attack (per role, over 100 scrapes or
#    more: 99 % of fewer would allow none lost), curl answers in under 2 s throughout, training goes
#    on; the actor's samples/s attacked and not is printed;
#  - afterwards each role holds no more descriptors than before (within 10).
#   metrics_attack_test.sh RAGDOLL CONFIG ATTACKER
set -u
ragdoll=$1 config=$2 attacker=$3
attack_seconds=${ATTACK_SECONDS:-105}
work=$(mktemp -d /tmp/ragdoll-metrics-attack.XXXXXX)
# Ports below 32768: above it Linux takes the local ports of outgoing connections.
run=attack port=$((13500 + 50 * (RANDOM % 20)))
prom_port=$((port + 45))
api="http://127.0.0.1:$prom_port/api/v1"
declare -A metrics=([learner]=$((port + 10)) [broker]=$((port + 11)) [actor]=$((port + 20)))
pids=()
cleanup() { kill -INT "${pids[@]}" 2> /dev/null; wait 2> /dev/null; rm -rf "$work"; }
trap cleanup EXIT
fail() {
  echo "FAIL: $*"
  echo "--- training log"; tail -n 20 "$work/train.log"
  exit 1
}
wait_for() {  # seconds, description, command...
  local limit=$1 what=$2; shift 2
  for ((i = 0; i < limit * 2; i++)); do "$@" && return 0; sleep 0.5; done
  fail "timed out after ${limit}s waiting for $what"
}
value() {  # instant query [at time]: the first result's value, or empty
  curl -sf --get "$api/query" --data-urlencode "query=$1" ${2:+--data-urlencode "time=$2"} |
    jq -r '.data.result[0].value[1] // empty'
}
updates() { cat "$work/train.log" 2> /dev/null | grep -c '^\['; }
listener_pid() { ss -Hltnp "sport = :$1" | grep -o 'pid=[0-9]*' | head -n 1 | cut -d= -f2; }
descriptors() { ls "/proc/$1/fd" | wc -l; }

config_dir=$(cd "$(dirname "$config")" && pwd)
sed -E "s#^(\\s*(motion|character):\\s*)([^/[:space:]][^[:space:]]*)#\\1$config_dir/\\3#" \
  "$config" > "$work/config.yaml"
cat > "$work/prometheus.yml" << EOF
global:
  scrape_interval: 1s
scrape_configs:
EOF
for role in learner broker actor; do
  printf '  - job_name: %s\n    static_configs: [{targets: ["127.0.0.1:%s"]}]\n' \
    "$role" "${metrics[$role]}" >> "$work/prometheus.yml"
done
prometheus --config.file="$work/prometheus.yml" --storage.tsdb.path="$work/tsdb" \
  --web.listen-address="127.0.0.1:$prom_port" > "$work/prometheus.log" 2>&1 & pids+=($!)
"$ragdoll" train "$work/config.yaml" --run-id "$run" --runs-dir "$work" --port-base "$port" \
  --actors 1 > "$work/train.log" 2>&1 & train=$!
pids+=($train)
wait_for 60 "Prometheus to answer" curl -sf "$api/status/buildinfo" -o /dev/null
wait_for 90 "2 PPO updates" bash -c "[ \$(cat '$work/train.log' | grep -c '^\[') -ge 2 ]"
wait_for 30 "every role up in Prometheus" bash -c "[ \"\$(curl -sf --get '$api/query' \
  --data-urlencode 'query=sum(up)' | jq -r '.data.result[0].value[1]')\" = 3 ]"

# Loopback only: each endpoint listens on 127.0.0.1 and nowhere else.
declare -A role_pid fds_before
for role in learner broker actor; do
  listening=$(ss -Hltn "sport = :${metrics[$role]}" | awk '{print $4}' | sort -u | tr '\n' ' ')
  [ "$listening" = "127.0.0.1:${metrics[$role]} " ] ||
    fail "$role metrics listen on '$listening', expected 127.0.0.1 only"
  role_pid[$role]=$(listener_pid "${metrics[$role]}")
  [ -n "${role_pid[$role]}" ] || fail "no process found on the $role's metrics port"
  fds_before[$role]=$(descriptors "${role_pid[$role]}")
done
echo "metrics on 127.0.0.1 only: learner ${metrics[learner]}, broker ${metrics[broker]}," \
  "actor ${metrics[actor]}"

# A quiet window for the throughput baseline, then the attack.
sleep 20
quiet_end=$(date +%s)
quiet_rate=$(value "rate(ragdoll_actor_samples_total[20s])" "$quiet_end")
before_updates=$(updates)
python3 "$attacker" "$attack_seconds" 100 100 "127.0.0.1:${metrics[learner]}" \
  "127.0.0.1:${metrics[broker]}" "127.0.0.1:${metrics[actor]}" > "$work/attacker.json" &
attack=$! attack_start=$(date +%s)
pids+=($attack)
sleep 5
slow=0 probes=0
while kill -0 "$attack" 2> /dev/null; do
  for role in learner broker actor; do
    probes=$((probes + 1))
    curl -sf --max-time 2 "http://127.0.0.1:${metrics[$role]}/metrics" -o /dev/null ||
      slow=$((slow + 1))
  done
  sleep 2
done
wait "$attack" || fail "the attacker failed"
attack_end=$(date +%s)
window=$((attack_end - attack_start))
sleep 2  # the last scrapes of the window are in
attacked_rate=$(value "rate(ragdoll_actor_samples_total[$((window - 5))s])" "$attack_end")
echo "attacker: $(cat "$work/attacker.json")"
echo "curl during the attack: $((probes - slow)) of $probes answered within 2 s"

failed=()
for role in learner broker actor; do
  ok=$(value "sum_over_time(up{job=\"$role\"}[${window}s])" "$attack_end")
  all=$(value "count_over_time(up{job=\"$role\"}[${window}s])" "$attack_end")
  slowest=$(value "max_over_time(scrape_duration_seconds{job=\"$role\"}[${window}s])" "$attack_end")
  median=$(value "quantile_over_time(0.5, scrape_duration_seconds{job=\"$role\"}[${window}s])" "$attack_end")
  echo "$role: ${ok%.*} of ${all%.*} scrapes succeeded during the attack" \
    "(median ${median} s, slowest ${slowest} s)"
  # When a scrape fails, when it failed: one role alone points at its endpoint, all at the machine.
  lost=$(curl -sf --get "$api/query" --data-urlencode "query=up{job=\"$role\"}[${window}s]" \
    --data-urlencode "time=$attack_end" | jq -r --argjson t0 "$attack_start" \
    '[.data.result[0].values[] | select(.[1] == "0") | "\(.[0] - $t0 | floor) s"] | join(", ")')
  [ -z "$lost" ] || echo "  $role's lost scrapes, seconds into the attack: $lost"
  awk -v ok="${ok:-0}" -v all="${all:-0}" -v least="$((attack_seconds - 5))" \
    'BEGIN { exit !(all >= least && ok >= 0.99 * all) }' ||
    failed+=("$role: ${ok:-0} of ${all:-0} scrapes succeeded, fewer than 99 %")
done
[ "$slow" = 0 ] || failed+=("$slow of $probes direct requests got no answer within 2 s")
[ ${#failed[@]} = 0 ] || fail "${failed[*]}"

[ "$(updates)" -gt "$before_updates" ] || fail "training stopped during the attack"
awk -v q="${quiet_rate:-0}" -v a="${attacked_rate:-0}" \
  'BEGIN { printf "actor samples/s: %.0f quiet, %.0f attacked (ratio %.2f)\n", q, a, (q > 0 ? a / q : 0) }'

sleep 6  # the server's idle timeout closes what the attacker left
for role in learner broker actor; do
  after=$(descriptors "${role_pid[$role]}")
  echo "$role descriptors: ${fds_before[$role]} before the attack, $after after"
  [ "$after" -le $((fds_before[$role] + 10)) ] ||
    fail "$role holds $after descriptors after the attack, ${fds_before[$role]} before"
  curl -sf --max-time 2 "http://127.0.0.1:${metrics[$role]}/metrics" | grep -q '^ragdoll_' ||
    fail "$role's endpoint does not answer after the attack"
done

kill -INT "$train"
wait "$train" || fail "training did not stop cleanly"
echo "1 passed, 0 failed"
