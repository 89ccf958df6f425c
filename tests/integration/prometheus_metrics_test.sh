#!/usr/bin/env bash
# A short training (broker, learner, two actors on loopback) scraped by a real Prometheus server
# (Debian's binary, started here with a generated config). Then Prometheus's HTTP API must hold
# the reward series from several scrapes, every role's target must be up, and every metric the
# Grafana dashboard queries must be among the series Prometheus collected.
#   prometheus_metrics_test.sh RAGDOLL CONFIG DASHBOARD_JSON
set -u
ragdoll=$1 config=$2 dashboard=$3
work=$(mktemp -d /tmp/ragdoll-promtest.XXXXXX)
run=promtest port=$((19000 + RANDOM % 2000))
prom_port=$((port + 50))
api="http://127.0.0.1:$prom_port/api/v1"
pids=()
cleanup() { kill -INT "${pids[@]}" 2>/dev/null; wait 2>/dev/null; rm -rf "$work"; }
trap cleanup EXIT
fail() {
  echo "FAIL: $*"
  echo "--- training log"; tail -n 20 "$work/train.log"
  echo "--- prometheus log"; tail -n 10 "$work/prometheus.log"
  exit 1
}
wait_for() {  # seconds, description, command...
  local limit=$1 what=$2; shift 2
  for ((i = 0; i < limit * 2; i++)); do "$@" && return 0; sleep 0.5; done
  fail "timed out after ${limit}s waiting for $what"
}
query() { curl -sf --get "$api/query" --data-urlencode "query=$1"; }
# The first value of an instant query's result, or empty.
value() { query "$1" | jq -r '.data.result[0].value[1] // empty'; }

# Metrics ports follow --port-base: learner +10, broker +11, actor i +20+i.
cat > "$work/prometheus.yml" <<EOF
global:
  scrape_interval: 1s
  evaluation_interval: 1s
scrape_configs:
  - job_name: learner
    static_configs: [{targets: ['127.0.0.1:$((port + 10))']}]
  - job_name: broker
    static_configs: [{targets: ['127.0.0.1:$((port + 11))']}]
  - job_name: actor
    static_configs: [{targets: ['127.0.0.1:$((port + 20))', '127.0.0.1:$((port + 21))']}]
EOF
prometheus --config.file="$work/prometheus.yml" --storage.tsdb.path="$work/tsdb" \
  --web.listen-address="127.0.0.1:$prom_port" > "$work/prometheus.log" 2>&1 & pids+=($!)
"$ragdoll" train "$config" --run-id "$run" --runs-dir "$work" --port-base "$port" --actors 2 \
  > "$work/train.log" 2>&1 & pids+=($!)
start=$(date +%s)

wait_for 60 "Prometheus to answer" curl -sf "$api/status/buildinfo" -o /dev/null
wait_for 90 "6 policy versions in Prometheus" \
  bash -c "v=\$(curl -sf --get '$api/query' --data-urlencode 'query=ragdoll_policy_version{run=\"$run\"}' | jq -r '.data.result[0].value[1] // 0'); [ \"\${v%.*}\" -ge 6 ]"
# At least 10 scrapes (1 s apart) of the reward series, however fast training runs.
reward_points() {
  curl -sf --get "$api/query_range" \
    --data-urlencode "query=ragdoll_episode_normalized_return{run=\"$run\"}" \
    --data-urlencode "start=$start" --data-urlencode "end=$(date +%s)" --data-urlencode "step=1" |
    jq '.data.result[0].values | length'
}
reward_points_at_least() { [ "$(reward_points)" -ge "$1" ] 2> /dev/null; }
wait_for 60 "10 scrapes of the reward series" reward_points_at_least 10

# Every target is up: the learner, the broker and both actors.
up=$(value "sum(up)")
[ "${up%.*}" = 4 ] || fail "expected 4 targets up, Prometheus says $up: $(query up)"

# The reward series comes from several scrapes, and it moves as the policy learns.
now=$(date +%s)
range=$(curl -sf --get "$api/query_range" \
  --data-urlencode "query=ragdoll_episode_normalized_return{run=\"$run\"}" \
  --data-urlencode "start=$start" --data-urlencode "end=$now" --data-urlencode "step=1")
samples=$(echo "$range" | jq '.data.result[0].values | length')
distinct=$(echo "$range" | jq '[.data.result[0].values[][1]] | unique | length')
echo "ragdoll_episode_normalized_return: $samples samples at 1 s steps, $distinct distinct values"
echo "$range" | jq -r '.data.result[0].values | "  first \(.[0][1]), last \(.[-1][1])"'
[ "${samples:-0}" -ge 10 ] || fail "too few samples of the reward series: $range"
[ "${distinct:-0}" -ge 3 ] || fail "the reward series did not change between iterations: $range"

# Throughput per actor and in total, from the actors' own counters.
for actor in 0 1; do
  rate=$(value "rate(ragdoll_actor_samples_total{instance=\"127.0.0.1:$((port + 20 + actor))\"}[10s])")
  echo "actor $actor: $rate samples/s"
  awk -v r="${rate:-0}" 'BEGIN { exit !(r > 0) }' || fail "actor $actor reports no samples/s"
done
trained=$(value "ragdoll_learner_run_samples{run=\"$run\"}")
forwarded=$(value "ragdoll_broker_segments_forwarded_total{run=\"$run\"}")
actors=$(value "ragdoll_broker_actors_connected{run=\"$run\"}")
echo "learner trained on $trained samples; broker forwarded $forwarded segments; $actors actors connected"
[ "${actors%.*}" = 2 ] || fail "broker reports $actors actors connected, expected 2"
awk -v t="${trained:-0}" 'BEGIN { exit !(t >= 6 * 4096) }' || fail "learner reports $trained samples"

# Every metric the dashboard queries is one the project exports (and Prometheus scraped).
names=$(curl -sf "$api/label/__name__/values" | jq -r '.data[]')
wanted=$(jq -r '.. | .expr? // empty' "$dashboard" | grep -o 'ragdoll_[a-z_]*' | sort -u)
[ -n "$wanted" ] || fail "no ragdoll_ metric found in $dashboard"
missing=0
for name in $wanted; do
  if ! grep -qx "$name" <<< "$names"; then echo "dashboard queries $name, which is not exported"; missing=1; fi
done
[ $missing = 0 ] || fail "the dashboard queries metrics nobody exports"
echo "dashboard: all $(wc -w <<< "$wanted") metrics it queries are exported"
# The learner's update against its own limit, by the dashboard's own query: both gauges are there
# and their labels match.
limit_query=$(jq -r '.panels[] | select(.title == "Learner update against its limit") |
  .targets[0].expr' "$dashboard")
[ -n "$limit_query" ] || fail "no 'Learner update against its limit' panel in $dashboard"
share=$(value "${limit_query//\$run/$run}")
echo "learner update against its limit: $share"
awk -v s="${share:-0}" 'BEGIN { exit !(s > 0 && s < 10) }' ||
  fail "the update's share of its limit is '$share' ($limit_query)"

# Stop cleanly: the training writes its final checkpoint.
kill -INT "${pids[1]}"; wait "${pids[1]}"
grep -q "final (stopped) checkpoint" "$work/train.log" || fail "no final checkpoint on stop"
echo "1 passed, 0 failed"
