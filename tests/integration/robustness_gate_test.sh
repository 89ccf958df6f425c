#!/usr/bin/env bash
# The robustness regression gate: a trained policy shipped in tests/data is evaluated with a short
# push eval (DeepMimic's protocol, 10 trials a direction) and must keep the figures recorded with
# it in its robustness.json: unpushed normalised return within 0.03, and in every direction at
# least 3/4 of the recorded impulse (the margin covers other CPUs' float rounding, which changes
# single trials; a broken push, reward or controller costs far more). A policy that gets up has
# its recovery recorded too ("recovery": {"trials", "within_10"}): as many settled falls, and the
# share standing within 10 s at most 0.15 below the recorded one; and its knock-downs under
# command ("knockdowns": {"runs", "share_back_within"}): as many runs of docs/knockdowns.yaml, and
# the share back on command within 6 s at most 0.15 below the recorded one. A steered policy may
# have its pushes told to stand recorded too ("protocol_standing", the same floors).
#   robustness_gate_test.sh RAGDOLL CHECKPOINT RECORDED_JSON
set -euo pipefail
ragdoll=$1 checkpoint=$2 recorded=$3
out=$(mktemp /tmp/ragdoll-gate.XXXXXX.json)
standing=$(mktemp /tmp/ragdoll-gate-standing.XXXXXX.json)
trap 'rm -f "$out" "$standing"' EXIT
recovery=$(python3 -c 'import json, sys; r = json.load(open(sys.argv[1])).get("recovery")
print("--recovery %d" % r["trials"] if r else "")' "$recorded")
knockdowns=$(python3 -c 'import json, sys; k = json.load(open(sys.argv[1])).get("knockdowns")
print("--commands %s --command-runs %d" % (sys.argv[2], k["runs"]) if k else "")' \
  "$recorded" "$(dirname "$0")/../../docs/knockdowns.yaml")
# shellcheck disable=SC2086  # $recovery and $knockdowns are empty or several words
"$ragdoll" eval "$checkpoint" --pushes --push-trials 10 --push-resolution 4 --episodes 4 \
  --push-impulses 0 $recovery $knockdowns --json "$out" > /dev/null
echo '{}' > "$standing"
if python3 -c 'import json, sys; sys.exit("protocol_standing" not in json.load(open(sys.argv[1])))' \
  "$recorded"; then
  "$ragdoll" eval "$checkpoint" --pushes --push-command stand --push-trials 10 \
    --push-resolution 4 --episodes 1 --push-impulses 0 --json "$standing" > /dev/null
fi
python3 - "$out" "$recorded" "$standing" <<'PY'
import json, sys
got, want = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
failures = []


def check_protocol(result, recorded, told):
    for d in result["perturbation"]["protocol"]["directions"]:
        floor = 0.75 * recorded[d["direction"]]
        print(f"{d['direction']:9s} {d['survived_90']:6.1f} N s ({d['velocity_change']:.2f} m/s)"
              f"{told}, recorded {recorded[d['direction']]:.1f}, floor {floor:.1f}")
        if d["survived_90"] < floor:
            failures.append(f"{d['direction']}{told} {d['survived_90']} N s < {floor} N s")


nr = got["normalized_return"]
print(f"unpushed normalised return {nr:.3f} (recorded {want['normalized_return']:.3f})")
if nr < want["normalized_return"] - 0.03:
    failures.append(f"normalised return {nr:.3f} < {want['normalized_return'] - 0.03:.3f}")
check_protocol(got, want["protocol"], "")
if "protocol_standing" in want:
    check_protocol(json.load(open(sys.argv[3])), want["protocol_standing"], " told to stand")
if "recovery" in want:
    r, floor = got["recovery"], want["recovery"]["within_10"] - 0.15
    print(f"recovery  {r['within_10']:.2f} standing within 10 s of {r['trials']} falls, "
          f"recorded {want['recovery']['within_10']:.2f}, floor {floor:.2f}")
    if r["within_10"] < floor:
        failures.append(f"recovery within 10 s {r['within_10']:.2f} < {floor:.2f}")
if "knockdowns" in want:
    # No knock-down at all (no knock felled it) is every knock-down back.
    k = got["commands"].get("knockdowns", {"share_back_within": 1.0, "count": 0, "back_window": 6})
    floor = want["knockdowns"]["share_back_within"] - 0.15
    print(f"knocked   {k['share_back_within']:.2f} of {k['count']} knock-downs back on command "
          f"within {k['back_window']:g} s, recorded {want['knockdowns']['share_back_within']:.2f}, "
          f"floor {floor:.2f}")
    if k["share_back_within"] < floor:
        failures.append(f"back on command {k['share_back_within']:.2f} < {floor:.2f}")
for f in failures:
    print("FAIL:", f)
sys.exit(1 if failures else 0)
PY
