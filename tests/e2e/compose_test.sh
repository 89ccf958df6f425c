#!/usr/bin/env bash
# End to end in containers: builds the images from deploy/Dockerfile (on a Debian base image made
# here with debootstrap, since no registry is reachable; its runtime stage with the binary of the
# README's build, or compiled in the image with RAGDOLL_E2E_FROM_SOURCE=1), brings deploy/docker-compose.yml up with
# Podman and two actors, waits until the learner has published several policy versions and
# Prometheus holds the reward series, restarts the learner container and checks that it resumed
# from the checkpoint volume, checks that the broker speaks only CURVE (a plaintext actor and one
# with a stranger's key, started on the stack's network, are refused), scales the learner to two replicas (a group at the broker), kills
# one and sees the group re-form and train on, then tears everything down. Prints the figures it
# measured.
#   tests/e2e/compose_test.sh            (from anywhere; needs root or rootless Podman)
# Grafana is not started: its image cannot be built from Debian packages here.
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
export CONTAINERS_CONF="$repo/tests/e2e/containers.conf"
project=ragdoll-e2e
work=$(mktemp -d /tmp/ragdoll-e2e.XXXXXX)
mirror=${DEBIAN_MIRROR:-$(cat /etc/apt/sources.list /etc/apt/sources.list.d/*.sources 2>/dev/null |
  grep -oE '^(URIs:|deb) +https?://[^ ]+/debian/?( |$)' | head -n 1 | awk '{print $2}' || true)}
mirror=${mirror:-http://deb.debian.org/debian}

export RAGDOLL_IMAGE=localhost/ragdoll:e2e
export PROMETHEUS_IMAGE=localhost/ragdoll-e2e-prometheus:latest
export RAGDOLL_EXPERIMENT=e2e RAGDOLL_CONFIG_DIR="$repo/tests/e2e/configs" RAGDOLL_RUN_ID=e2e
export RAGDOLL_ACTORS=2 PROMETHEUS_PORT=$((29090 + RANDOM % 500))
api="http://127.0.0.1:$PROMETHEUS_PORT/api/v1"
compose=(podman-compose -p "$project" -f "$repo/deploy/docker-compose.yml")

log() { echo "[$(date +%T)] $*"; }
cleanup() {
  podman rm -f "${project}_plaintext" "${project}_stranger" > /dev/null 2>&1 || true
  "${compose[@]}" down -v > "$work/down.log" 2>&1 || true
  podman volume rm -f "${project}_runs" "${project}_prometheus" > /dev/null 2>&1 || true
  rm -rf "$work"
}
trap cleanup EXIT
fail() {
  echo "FAIL: $*"
  for c in $(podman ps -a --filter "label=io.podman.compose.project=$project" --format '{{.Names}}'); do
    echo "--- $c"; podman logs --tail 15 "$c" 2>&1
  done
  exit 1
}
container() {  # the container of a service (the first replica)
  podman ps -a --filter "label=io.podman.compose.project=$project" \
    --filter "label=com.docker.compose.service=$1" --format '{{.Names}}' | sort | head -n 1
}
containers() {
  podman ps -a --filter "label=io.podman.compose.project=$project" \
    --filter "label=com.docker.compose.service=$1" --format '{{.Names}}' | sort
}
query() { curl -sf --get "$api/query" --data-urlencode "query=$1" | jq -r '.data.result[0].value[1] // empty'; }
# Runs the service's health check now (Podman schedules them with systemd timers, which a
# container or CI machine may lack): 0 when healthy.
healthy() { podman healthcheck run "$1" > /dev/null 2>&1; }
wait_for() {  # seconds, description, command...
  local limit=$1 what=$2; shift 2
  local t0=$SECONDS
  while ! "$@"; do
    [ $((SECONDS - t0)) -lt "$limit" ] || fail "timed out after ${limit}s waiting for $what"
    sleep 1
  done
}

# 1. Images. The base: Debian bookworm by debootstrap, imported once and reused.
t0=$SECONDS
if ! podman image exists localhost/bookworm-base; then
  log "building localhost/bookworm-base with debootstrap from $mirror"
  debootstrap --variant=minbase bookworm "$work/root" "$mirror" > "$work/debootstrap.log" 2>&1 ||
    { tail -n 20 "$work/debootstrap.log"; fail "debootstrap"; }
  # As Debian's official slim image: no package caches or lists in the base.
  rm -rf "$work/root"/var/cache/apt/* "$work/root"/var/lib/apt/lists/*
  tar -C "$work/root" -c . | podman import - localhost/bookworm-base > /dev/null
  rm -rf "$work/root"
fi
# The binary the README's build made (build/ragdoll), unless RAGDOLL_E2E_FROM_SOURCE=1 asks for
# the Dockerfile's own compile (a second build of the project, ~15 min on 2 cores).
if [ "${RAGDOLL_E2E_FROM_SOURCE:-0}" = 1 ] || [ ! -x "$repo/build/ragdoll" ]; then
  log "building $RAGDOLL_IMAGE from deploy/Dockerfile, compiled in the image"
  podman build --network host --build-arg BASE_IMAGE=localhost/bookworm-base \
    -f "$repo/deploy/Dockerfile" -t "$RAGDOLL_IMAGE" "$repo" > "$work/build.log" 2>&1 ||
    { tail -n 40 "$work/build.log"; fail "image build"; }
else
  log "building $RAGDOLL_IMAGE: deploy/Dockerfile's runtime base with build/ragdoll"
  mkdir -p "$work/context"
  strip -o "$work/context/ragdoll" "$repo/build/ragdoll"
  cp -r "$repo/assets" "$repo/configs" "$work/context/"
  { podman build --network host --build-arg BASE_IMAGE=localhost/bookworm-base \
      --target runtime-base -f "$repo/deploy/Dockerfile" -t localhost/ragdoll-runtime-base:e2e \
      "$work/context" &&
    podman build --network host --build-arg RUNTIME_BASE=localhost/ragdoll-runtime-base:e2e \
      --build-arg SOURCE_DIR="$repo" -f "$repo/tests/e2e/prebuilt.Dockerfile" \
      -t "$RAGDOLL_IMAGE" "$work/context"; } > "$work/build.log" 2>&1 ||
    { tail -n 40 "$work/build.log"; fail "image build"; }
fi
podman build --network host --build-arg BASE_IMAGE=localhost/bookworm-base \
  -f "$repo/tests/e2e/prometheus.Dockerfile" -t "$PROMETHEUS_IMAGE" "$repo/tests/e2e" \
  > "$work/build-prometheus.log" 2>&1 || { tail -n 20 "$work/build-prometheus.log"; fail "prometheus image"; }
build_s=$((SECONDS - t0))
image_size=$(podman image inspect "$RAGDOLL_IMAGE" --format '{{.Size}}')
base_size=$(podman image inspect localhost/bookworm-base --format '{{.Size}}')
log "images built in ${build_s}s; ragdoll image $((image_size / 1000000)) MB (base $((base_size / 1000000)) MB)"

# 2. The stack: broker, learner, two actors, Prometheus; CURVE keys and the Grafana password from
#    deploy/make-secrets.sh, delivered as compose secrets.
"$repo/deploy/make-secrets.sh" "$work/secrets" > "$work/secrets.log" 2>&1 ||
  { cat "$work/secrets.log"; fail "make-secrets"; }
export RAGDOLL_SECRETS="$work/secrets"
t0=$SECONDS
"${compose[@]}" up -d broker learner actor prometheus > "$work/up.log" 2>&1 ||
  { cat "$work/up.log"; fail "compose up"; }
broker=$(container broker) learner=$(container learner)
mapfile -t actors < <(containers actor)
[ "${#actors[@]}" = 2 ] || fail "expected 2 actor replicas, found: ${actors[*]}"
for c in "$broker" "$learner" "${actors[@]}"; do wait_for 180 "$c to be healthy" healthy "$c"; done
healthy_s=$((SECONDS - t0))
log "stack healthy after ${healthy_s}s: $broker $learner ${actors[*]}"
podman logs "$broker" 2>&1 | grep "CURVE on; 1 actor and 1 learner keys" >/dev/null || fail "the broker is not on CURVE"
podman logs "$broker" 2>&1 | grep "listening on tcp://\*:5555 .*CURVE" >/dev/null || fail "the broker does not listen with CURVE"

# 3. Training goes on: several policy versions, and Prometheus has the reward series from
#    every role (each actor replica found through the service's DNS name).
version_at_least() { local v; v=$(query "ragdoll_policy_version") || return 1; [ "${v%.*}" -ge "$1" ] 2> /dev/null; }
wait_for 300 "policy version 5 in Prometheus" version_at_least 5
wait_for 60 "4 targets up" bash -c "[ \"\$(curl -sf --get '$api/query' --data-urlencode 'query=sum(up)' | jq -r '.data.result[0].value[1] // 0')\" = 4 ]"
reward_range() {
  curl -sf --get "$api/query_range" --data-urlencode "query=ragdoll_episode_normalized_return" \
    --data-urlencode "start=$(($(date +%s) - 300))" --data-urlencode "end=$(date +%s)" \
    --data-urlencode "step=5"
}
reward_points_at_least() { [ "$(reward_range | jq '.data.result[0].values | length')" -ge "$1" ] 2> /dev/null; }
wait_for 120 "6 scrapes of the reward series" reward_points_at_least 6
reward=$(reward_range)
log "Prometheus: ragdoll_episode_normalized_return $(echo "$reward" | jq -c '[.data.result[0].values[][1] | tonumber | . * 1000 | round / 1000]')"
log "Prometheus: policy version $(query ragdoll_policy_version), trained samples $(query ragdoll_learner_run_samples)," \
  "$(query 'sum(rate(ragdoll_actor_samples_total[30s]))' | cut -c1-6) samples/s from $(query 'count(ragdoll_actor_samples_total)') actors," \
  "$(query ragdoll_broker_actors_connected) connected, broker forwarded $(query ragdoll_broker_segments_forwarded_total) segments"

# 3b. Intruders on the stack's network: a plaintext actor and one with its own key pair. Neither
#     gets a policy; the broker counts both refusals; its own actors keep training.
network=$(podman network ls --format '{{.Name}}' | grep "^${project}_ragdoll" | head -n 1)
mkdir -p "$work/rogue"
cp "$work/secrets/keys/broker.key" "$work/rogue/"
podman run --rm --user 0 -v "$work/rogue:/keys" "$RAGDOLL_IMAGE" keygen rogue --role actor --keys /keys > /dev/null ||
  fail "keygen in the image"
chmod 0644 "$work/rogue/rogue.key_secret"
intruder() {  # name, extra options
  podman run -d --name "${project}_$1" --network "$network" -v "$RAGDOLL_CONFIG_DIR:/opt/ragdoll/configs:ro" \
    -v "$work/rogue:/rogue:ro" "$RAGDOLL_IMAGE" actor /opt/ragdoll/configs/e2e.yaml --run-id e2e \
    --broker-host broker "${@:2}" > /dev/null || fail "intruder $1"
}
intruder plaintext
intruder stranger --keys /rogue --key /rogue/rogue.key_secret
refused() {
  podman exec "$broker" curl -sf http://127.0.0.1:9301/metrics |
    awk '/^ragdoll_broker_connections_refused_total/ { s += $2 } END { print s + 0 }'
}
wait_for 60 "the broker to refuse both intruders" bash -c "[ \$(podman exec '$broker' curl -sf http://127.0.0.1:9301/metrics | awk '/^ragdoll_broker_connections_refused_total.*reason=\"unknown_key\"/ { s += \$2 } END { print s + 0 }') -gt 0 ]"
sleep 5
for c in plaintext stranger; do
  v=$(podman exec "${project}_$c" curl -sf http://127.0.0.1:9310/metrics | awk '/^ragdoll_actor_snapshot_version/ { print $2 }')
  [ "$v" = "-1" ] || fail "intruder $c got policy $v"
  podman rm -f "${project}_$c" > /dev/null
done
log "intruders refused: $(refused) connections ($(podman exec "$broker" curl -sf http://127.0.0.1:9301/metrics |
  awk '/^ragdoll_broker_connections_refused_total/ && $2 > 0 { sub(/.*reason="/, "", $1); sub(/".*/, "", $1); printf "%s %d ", $1, $2 }'))"

# 4. Restart the learner container: it resumes from the checkpoint in the `runs` volume.
podman stop -t 60 "$learner" > /dev/null
stopped=$(podman logs "$learner" 2>&1 | grep -o "final (stopped) checkpoint .*" | tail -n 1)
[ -n "$stopped" ] || fail "the learner wrote no final checkpoint when stopped"
saved=$(echo "$stopped" | sed 's/.*checkpoint-0*\([0-9]*\)\.pt/\1/')
log "learner stopped: $stopped"
t0=$(date +%s%N)
podman start "$learner" > /dev/null
wait_for 120 "the learner to resume" bash -c "podman logs '$learner' 2>&1 | grep -q 'resumed from .*, $saved samples'"
resumed=$(podman logs "$learner" 2>&1 | grep -o "resumed from .* at policy v[0-9]*, $saved samples" | tail -n 1)
version=$(echo "$resumed" | sed 's/.*policy v\([0-9]*\),.*/\1/')
broker_version_at_least() {
  local v
  v=$(podman exec "$broker" curl -sf http://127.0.0.1:9301/metrics | awk '/^ragdoll_broker_snapshot_version/ { print $2 }')
  [ -n "$v" ] && [ "${v%.*}" -ge "$1" ]
}
wait_for 120 "the broker to receive the resumed snapshot" broker_version_at_least "$version"
first_ms=$(( ($(date +%s%N) - t0) / 1000000 ))
next=$((version + 1))
wait_for 120 "policy v$next after the restart" broker_version_at_least "$next"
next_ms=$(( ($(date +%s%N) - t0) / 1000000 ))
log "learner $resumed; broker had its snapshot v$version ${first_ms} ms after the restart, the newly trained v$next after ${next_ms} ms"
first_line=$(podman logs "$learner" 2>&1 | grep "^\[" | awk -v v="v$next" '$0 ~ " " v " " { print; exit }')
echo "$first_line" | grep -q "samples" || fail "no progress line for v$next"
log "first iteration after the restart: $first_line"

# 5. Two learner replicas: the service scaled with RAGDOLL_LEARNERS=2 forms a group at the
#    broker, resumes from the volume's checkpoint and trains; a replica killed from outside breaks
#    the group, `restart: on-failure` brings both back and the new group resumes again.
learners_up_s=$SECONDS
# The single learner's container goes first: compose would keep it, with its old group size.
podman stop -t 60 "$learner" > /dev/null && podman rm "$learner" > /dev/null
RAGDOLL_LEARNERS=2 "${compose[@]}" up -d learner > "$work/up2.log" 2>&1 || { cat "$work/up2.log"; fail "compose up with 2 learners"; }
mapfile -t learners < <(containers learner)
[ "${#learners[@]}" = 2 ] || fail "expected 2 learner replicas, found: ${learners[*]}"
groups() { podman logs "$broker" 2>&1 | grep -c "learner group [0-9]* of 2 replicas"; }
wait_for 120 "a group of 2 learner replicas at the broker" bash -c "[ \$(podman logs '$broker' 2>&1 | grep -c 'learner group [0-9]* of 2 replicas') -ge 1 ]"
group_version=$(podman exec "$broker" curl -sf http://127.0.0.1:9301/metrics | awk '/^ragdoll_broker_snapshot_version/ { print int($2) }')
wait_for 180 "the group to train 3 versions" broker_version_at_least $((group_version + 3))
log "2 learner replicas: group formed and trained v$group_version -> v$((group_version + 3)) ($((SECONDS - learners_up_s)) s after up)"
before_groups=$(groups)
kill -9 "$(podman inspect --format '{{.State.Pid}}' "${learners[1]}")"
wait_for 180 "the group to re-form after a replica was killed" bash -c "[ \$(podman logs '$broker' 2>&1 | grep -c 'learner group [0-9]* of 2 replicas') -gt $before_groups ]"
group_version=$(podman exec "$broker" curl -sf http://127.0.0.1:9301/metrics | awk '/^ragdoll_broker_snapshot_version/ { print int($2) }')
wait_for 180 "the re-formed group to train" broker_version_at_least $((group_version + 2))
log "a killed replica: the group re-formed and trained on to v$((group_version + 2))"

# 6. Down, volumes removed by the trap.
log "figures: images ${build_s}s, ragdoll image $((image_size / 1000000)) MB; healthy ${healthy_s}s;" \
  "learner restart -> snapshot at broker ${first_ms} ms, -> next version ${next_ms} ms"
echo "1 passed, 0 failed"
