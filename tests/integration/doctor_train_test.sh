#!/usr/bin/env bash
# `ragdoll doctor CONFIG --train S` (cli/doctor_command.cc) runs a real training of CONFIG beside
# its measurements and sets the training's samples/s against the bound of its parts:
#  - the figures it prints and writes agree with each other (each share is the training's rate over
#    the bound it names, the bound after the training is built from the actor measured again);
#  - every figure is a rate a training of this config can have (positive, the shares within
#    0.05-20: wide, since the config's two actors beat a one-actor bound and tests run beside
#    others, but a wrong unit or a rate over the wrong span lands far outside);
#  - it leaves no temporary run folder behind;
#  - a training too short to update gives a clear error naming its log, and a non-zero exit.
#   doctor_train_test.sh RAGDOLL CONFIG
set -u
ragdoll=$1 config=$2
work=$(mktemp -d /tmp/ragdoll-doctor-test.XXXXXX)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
check() {  # python expression over `d` (the JSON) that must hold, and what it means
  python3 -c "import json, sys; d = json.load(open(sys.argv[1])); sys.exit(0 if ($1) else 1)" \
    "$work/doctor.json" || fail "$2: $(python3 -m json.tool "$work/doctor.json")"
}

"$ragdoll" doctor "$config" --quick --train 40 --json "$work/doctor.json" > "$work/doctor.txt" 2>&1 ||
  fail "ragdoll doctor --train: $(cat "$work/doctor.txt")"
cat "$work/doctor.txt"

check "d['train_samples_per_second'] > 0 and d['actor_samples_per_second_after_training'] > 0" \
  "the training's or the second actor measurement's rate is not positive"
check "abs(d['train_share_of_bound'] - d['train_samples_per_second'] / d['bound_separate_cores']) < 1e-9" \
  "the share is not the training's rate over the bound of its parts on their own cores"
check "abs(d['train_share_of_shared_bound'] - d['train_samples_per_second'] / d['bound_samples_per_second']) < 1e-9" \
  "the share of the shared bound is not the training's rate over that bound"
# The bound after the training: the learner's new samples/s or the actors' measured again.
check "abs(d['train_share_of_bound_after'] - d['train_samples_per_second'] / min(d['learner']['update_samples_per_second_per_epoch'] / d['learner']['epochs'], (d['cpu']['cores'] - 1) * d['actor_samples_per_second_after_training'])) < 1e-9" \
  "the share after the training is not set against the actor measured again"
check "all(0.05 < d[k] < 20 for k in ('train_share_of_bound', 'train_share_of_bound_after', 'train_share_of_shared_bound'))" \
  "a share of the bound is outside 0.05-20: the training's rate or a bound is wrong"
grep -q "^ragdoll train $config, 40 s: [0-9]* samples/s after its first update" "$work/doctor.txt" ||
  fail "the training's line is missing"
grep -q "^actor after the training: [0-9]* samples/s" "$work/doctor.txt" ||
  fail "the actor measured after the training is not printed"
run_dir=$(sed -n 's#^training .* (log: \(.*\)/train.log) \.\.\.$#\1#p' "$work/doctor.txt")
[ -n "$run_dir" ] || fail "the doctor does not say where the training's log is"
[ ! -e "$run_dir" ] || fail "the training's temporary folder $run_dir was left behind"

# Too short a training to measure: an error that names the log, which is kept for reading.
if "$ragdoll" doctor "$config" --quick --train 1 > "$work/short.txt" 2>&1; then
  fail "a 1 s training was taken as a measurement: $(cat "$work/short.txt")"
fi
cat "$work/short.txt"
grep -q "fewer than 3 updates in 1 s; its log: /tmp/ragdoll-doctor\..*/train.log" "$work/short.txt" ||
  fail "the short training's error does not say what and where"
short_log=$(sed -n 's#.*its log: \(/tmp/ragdoll-doctor\.[^ ]*/train.log\).*#\1#p' "$work/short.txt" | head -n 1)
[ -f "$short_log" ] || fail "the log the error names ($short_log) is not there"
rm -rf "$(dirname "$short_log")"
echo "PASS"
