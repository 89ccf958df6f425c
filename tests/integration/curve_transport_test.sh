#!/usr/bin/env bash
# CURVE with real processes: `ragdoll keygen` makes the keys, `ragdoll train --keys` trains with
# every socket encrypted and authenticated, and three intruders run the real actor against the
# same broker: one with a key the broker does not know, one in plaintext, one holding the
# learner's key. None of them gets a segment in, the first two not even the policy; the broker counts each refusal by
# reason; training goes on. A broker told to listen on every interface without keys refuses to
# start and says how to make them; --insecure lets it.
#   curve_transport_test.sh RAGDOLL CONFIG
set -u
ragdoll=$1 config=$2
work=$(mktemp -d /tmp/ragdoll-curve.XXXXXX)
run=curve port=$((23000 + RANDOM % 2000))
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null; done; wait 2>/dev/null; rm -rf "$work"; }
trap cleanup EXIT
fail() { echo "FAIL: $*"; for f in "$work"/*.log; do echo "--- $f"; tail -n 15 "$f"; done; exit 1; }
wait_for() {  # seconds, description, command...
  local limit=$1 what=$2; shift 2
  for ((i = 0; i < limit * 10; i++)); do "$@" && return 0; sleep 0.1; done
  fail "timed out after ${limit}s waiting for $what"
}
metric() {  # port name [label filter]: the series' value
  curl -sf "http://127.0.0.1:$1/metrics" | awk -v n="$2" -v l="${3:-}" \
    '$1 ~ "^"n"({|$)" && index($1, l) { print $2; exit }'
}

"$ragdoll" keygen --keys "$work/keys" > "$work/keygen.log" 2>&1 || fail "keygen"
for f in broker.key broker.key_secret actor.key_secret learner.key_secret actors/actor.key \
         learners/learner.key; do
  [ -f "$work/keys/$f" ] || fail "keygen did not write $f"
done
[ "$(stat -c %a "$work/keys/actor.key_secret")" = 600 ] || fail "secret key readable by others"
"$ragdoll" keygen --keys "$work/keys" > "$work/again.log" 2>&1 && fail "keygen overwrote keys"
grep -q "already exists" "$work/again.log" || fail "keygen did not say why it stopped"
# The intruder's own pair (it knows the broker's public key: that is public).
"$ragdoll" keygen rogue --role actor --keys "$work/rogue" > /dev/null || fail "keygen rogue"
cp "$work/keys/broker.key" "$work/rogue/"

"$ragdoll" train "$config" --keys "$work/keys" --actors 1 --port-base "$port" \
  --runs-dir "$work" --run-id "$run" > "$work/train.log" 2>&1 &
pids+=($!)
wait_for 60 "3 PPO iterations under CURVE" bash -c "[ \$(grep -c '^\[' '$work/train.log') -ge 3 ]"
grep -q "CURVE keys from $work/keys" "$work/train.log" || fail "train did not say it uses CURVE"
grep -q "broker: CURVE on; 1 actor and 1 learner keys" "$work/train.log" || fail "broker not CURVE"

intruder() {  # name, then the actor's options
  local name=$1; shift
  "$ragdoll" actor "$config" --run-id "$run" --port-base "$port" --index "$1" \
    --metrics-port "$2" "${@:3}" > "$work/$name.log" 2>&1 &
  pids+=($!)
}
intruder unknown 7 $((port + 40)) --keys "$work/rogue" --key "$work/rogue/rogue.key_secret"
intruder plaintext 8 $((port + 41))
intruder learner-key 9 $((port + 42)) --keys "$work/keys" --key "$work/keys/learner.key_secret"
# And a learner with a key of its own: it must not receive the actors' segments.
"$ragdoll" keygen rogue-learner --role learner --keys "$work/rogue" > /dev/null || fail "keygen rogue learner"
"$ragdoll" learner "$config" --run-id "$run" --port-base "$port" --run-dir "$work/rogue-run" \
  --metrics-port $((port + 43)) --keys "$work/rogue" --key "$work/rogue/rogue-learner.key_secret" \
  > "$work/rogue-learner.log" 2>&1 &
pids+=($!)
broker=$((port + 11))
refusals() {  # reason regex: the sum of those refusal counters
  curl -sf "http://127.0.0.1:$broker/metrics" |
    awk -v r="$1" '$1 ~ "connections_refused_total.*reason=\"("r")\"" { s += $2 } END { print s + 0 }'
}
refused() { [ "$(refusals "$1")" -gt 0 ]; }
# A plaintext client is refused as not_curve, or as protocol when it hangs up first (which side
# notices the mismatch first is a race).
for reason in unknown_key 'not_curve|protocol' wrong_role; do
  wait_for 30 "a refusal ($reason)" refused "$reason"
done
before=$(grep -c '^\[' "$work/train.log")
sleep 8
# The unknown key and the plaintext actor get nothing; the learner's key may read the policy (the
# learner holds it anyway) but not push segments as an actor.
for m in $((port + 40)) $((port + 41)); do
  [ "$(metric $m ragdoll_actor_snapshot_version)" = "-1" ] || fail "an intruder got a policy"
done
# (An actor counts a segment as sent once ZeroMQ queues it; the broker is what must not take it.)
[ "$(metric $broker ragdoll_broker_actors_connected)" = "1" ] || fail "the broker hears an intruder as an actor"
rejected=$(curl -sf "http://127.0.0.1:$broker/metrics" |
  awk '/^ragdoll_broker_messages_rejected_total.*socket="trajectories"/ { s += $2 } END { print s + 0 }')
[ "$rejected" = 0 ] || fail "$rejected intruder messages reached the trajectory socket"
grep -q "the broker refused this actor's key" "$work/unknown.log" || fail "no reason in the log"
grep -q "disagree on security" "$work/plaintext.log" || fail "no reason in the plaintext log"
grep -q "the broker refused this learner's key" "$work/rogue-learner.log" || fail "no reason in the rogue learner's log"
[ "$(metric $((port + 43)) ragdoll_ppo_updates_total)" = "0" ] ||
  fail "the rogue learner trained on the actors' segments"
grep -q "disagree on security\|refused this actor's key" "$work/learner-key.log" ||
  fail "no reason in the log of the actor holding the learner's key"
[ "$(grep -c '^\[' "$work/train.log")" -gt "$before" ] || fail "training stopped"
accepted=$(metric $broker ragdoll_broker_connections_accepted_total 'role="actor"')
refused=$(curl -sf "http://127.0.0.1:$broker/metrics" | grep connections_refused_total | grep -v '^#')
echo "accepted actor connections: $accepted"; echo "$refused"
# Refusals are logged at a bounded rate: at most one line per reason per 10 s.
lines=$(grep -c "refused a connection" "$work/train.log")
[ "$lines" -le 12 ] || fail "$lines refusal lines in the log: not rate-limited"
kill -INT "${pids[0]}"; wait "${pids[0]}"

# Plaintext beyond loopback: refused, with the way out named; --insecure allows it.
"$ragdoll" broker "$config" --run-id x --port-base $((port + 100)) --bind '*' \
  > "$work/open.log" 2>&1 && fail "a plaintext broker listened on every interface"
grep -q "refusing to listen on tcp://\*:$((port + 100)) in plaintext" "$work/open.log" || fail "no reason"
grep -q "ragdoll keygen" "$work/open.log" || fail "the refusal does not say how to make keys"
"$ragdoll" broker "$config" --run-id x --port-base $((port + 100)) --bind '*' --insecure \
  --metrics-port 0 > "$work/insecure.log" 2>&1 &
pids+=($!)
wait_for 10 "the --insecure broker" grep -q "PLAINTEXT on a network" "$work/insecure.log"
echo "PASS"
