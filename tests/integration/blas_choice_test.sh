#!/usr/bin/env bash
# The BLAS kernels each process runs are chosen for its CPU (common/blas.h):
#  - left to itself, every ragdoll process runs the kernel set of the CPU's widest vectors
#    (SkylakeX with AVX-512, Haswell with AVX2; OpenBLAS falls back to Prescott on CPUs it does
#    not know);
#  - started on a generic set as if the library had fallen back (OPENBLAS_CORETYPE=Prescott,
#    marked as ragdoll's own), it detects that and runs the CPU's set instead, and so do the
#    learner and actors of a training started that way (their start-up lines);
#  - an OPENBLAS_CORETYPE the user set is kept, said so, and `ragdoll doctor` says what it costs.
# Each kernel set's sgemm figure is printed (not asserted: a figure, docs/benchmarks.md).
#   blas_choice_test.sh RAGDOLL CONFIG
set -u
ragdoll=$1 config=$2
work=$(mktemp -d /tmp/ragdoll-blas.XXXXXX)
train_pid=
cleanup() { [ -n "$train_pid" ] && kill -INT "$train_pid" 2> /dev/null; wait 2> /dev/null; rm -rf "$work"; }
trap cleanup EXIT
fail() { echo "FAIL: $*"; exit 1; }
clean_env=(env -u OPENBLAS_CORETYPE -u RAGDOLL_BLAS_CHOSEN -u RAGDOLL_BLAS_REPLACED
  -u RAGDOLL_BLAS_REJECTED -u RAGDOLL_BLAS_KERNELS)
field() {  # json, python expression over `d`
  python3 -c "import json, sys; d = json.load(open(sys.argv[1])); print($2)" "$1"
}

"${clean_env[@]}" "$ragdoll" doctor --blas-only --json "$work/own.json" > "$work/own.txt" 2>&1 ||
  fail "ragdoll doctor: $(cat "$work/own.txt")"
cat "$work/own.txt"
features=$(field "$work/own.json" "d['cpu']['features']")
case $features in
  AVX-512) want=SkylakeX ;;
  AVX2+FMA) want=Haswell ;;
  *) echo "SKIP: no AVX2 on this CPU: there is no better kernel set to choose"; exit 0 ;;
esac
kernel=$(field "$work/own.json" "d['blas']['kernel']")
[ -n "$kernel" ] || { echo "SKIP: the BLAS is not OpenBLAS ($(field "$work/own.json" "d['blas']['library']"))"; exit 0; }
# Left to itself: the CPU's set, or one of the same width the library chose itself (Zen).
rank=$(field "$work/own.json" "{'SkylakeX': 3, 'Cooperlake': 3, 'SapphireRapids': 3, 'Haswell': 2, 'Zen': 2}.get(d['blas']['kernel'], 0)")
want_rank=$([ "$want" = SkylakeX ] && echo 3 || echo 2)
[ "$rank" -ge "$want_rank" ] || fail "left to itself the process runs $kernel kernels on a $features CPU"

# Started on generic kernels as if the library had chosen them: corrected.
"${clean_env[@]}" OPENBLAS_CORETYPE=Prescott RAGDOLL_BLAS_CHOSEN=Prescott \
  "$ragdoll" doctor --blas-only --json "$work/forced.json" > "$work/forced.txt" 2>&1 ||
  fail "ragdoll doctor: $(cat "$work/forced.txt")"
cat "$work/forced.txt"
[ "$(field "$work/forced.json" "d['blas']['kernel']")" = "$want" ] ||
  fail "started on Prescott kernels, the process did not move to $want"
grep -q "BLAS: .*, $want kernels (chosen by ragdoll; the library chose Prescott on this" \
  "$work/forced.txt" || fail "the BLAS line does not say what ragdoll chose instead of what"

# The user's own setting: kept, and doctor says what the CPU's set would gain.
"${clean_env[@]}" OPENBLAS_CORETYPE=Prescott \
  "$ragdoll" doctor --blas-only --json "$work/user.json" > "$work/user.txt" 2>&1 ||
  fail "ragdoll doctor: $(cat "$work/user.txt")"
cat "$work/user.txt"
[ "$(field "$work/user.json" "d['blas']['kernel']")" = Prescott ] ||
  fail "the user's OPENBLAS_CORETYPE=Prescott was not kept"
grep -q "OPENBLAS_CORETYPE=Prescott set in the environment: kept" "$work/user.txt" ||
  fail "the kept setting is not said"
grep -q "unset OPENBLAS_CORETYPE" "$work/user.txt" || fail "doctor does not say what to change"

# A training started on generic kernels: its learner and actor run the CPU's set and say so.
config_dir=$(cd "$(dirname "$config")" && pwd)
sed -E -e "s#^(\\s*(motion|character):\\s*)([^/[:space:]][^[:space:]]*)#\\1$config_dir/\\3#" \
  "$config" > "$work/config.yaml"
"${clean_env[@]}" OPENBLAS_CORETYPE=Prescott RAGDOLL_BLAS_CHOSEN=Prescott \
  "$ragdoll" train "$work/config.yaml" --run-id run --runs-dir "$work" --actors 1 \
  --port-base $((36000 + 50 * (RANDOM % 20))) > "$work/train.log" 2>&1 &
train_pid=$!
started=$SECONDS
until grep -q '^\[' "$work/train.log" 2> /dev/null; do
  kill -0 "$train_pid" 2> /dev/null || fail "the training ended: $(tail -n 5 "$work/train.log")"
  [ $((SECONDS - started)) -lt 120 ] || fail "no PPO update in 120 s"
  sleep 0.5
done
kill -INT "$train_pid"
wait "$train_pid"
train_pid=
grep "BLAS:" "$work/train.log"
grep -q "^learner: BLAS: .*, $want kernels (chosen by ragdoll; the library chose Prescott" \
  "$work/train.log" || fail "the learner does not run $want kernels"
grep -q "actor-0: BLAS: .*, $want kernels (chosen by ragdoll" "$work/train.log" ||
  fail "the actor does not run $want kernels"
grep -q "GFLOP/s on one thread" "$work/train.log" || fail "no measured sgemm figure at start-up"
echo "1 passed, 0 failed"
