#!/usr/bin/env bash
# Runs every libFuzzer target (tests/fuzz/, built with `cmake --preset sanitize && cmake --build
# --preset sanitize`) for SECONDS each on a fresh corpus seeded with real inputs: the messages the
# system sends, BVH files written by `ragdoll motion export` (three namings, two unit systems),
# the shipped clips and DeepMimic's motion files, every shipped and test config. Prints
# executions, executions/s and coverage per target; fails on any crash, leak or sanitizer report,
# keeping the reproducer under OUT/artifacts.
#   tests/fuzz/run.sh [SECONDS=60] [OUT=build-sanitize/fuzz-run] [TARGET...]
# FUZZ_MAX_LEN (default 131072 bytes) bounds the inputs: smaller runs many times faster.
# FUZZ_RUNS stops each target after that many executions if it comes before SECONDS.
set -u
repo=$(cd "$(dirname "$0")/../.." && pwd)
seconds=${1:-60} out=${2:-$repo/build-sanitize/fuzz-run}
shift 2 2>/dev/null || shift $#
targets=("$@"); [ ${#targets[@]} -gt 0 ] || targets=(wire bvh motion config)
bin=$repo/build-sanitize/tests/fuzz
ragdoll=${RAGDOLL:-$repo/build/ragdoll}
rm -rf "$out"; mkdir -p "$out/artifacts"

# Short variants of the real clips (their first 4 frames, everything else as written): libFuzzer
# mutates small inputs many times faster, and their structure survives a small FUZZ_MAX_LEN.
short_clips() {  # folder: writes NAME-short.json / NAME-short.txt for each clip
  python3 - "$1" "$repo"/assets/motions/*.json "$repo"/../shared/data/deepmimic/motions/*.txt <<'PY'
import json, os, sys
for path in sys.argv[2:]:
    if not os.path.exists(path):
        continue
    clip = json.load(open(path))
    key = "frames" if "frames" in clip else "Frames"
    clip[key] = clip[key][:4]
    stem, ext = os.path.splitext(os.path.basename(path))
    json.dump(clip, open(os.path.join(sys.argv[1], stem + "-short" + ext), "w"), indent=1)
PY
}

seeds() {  # target -> its seed folder
  local d=$out/seeds/$1; mkdir -p "$d"
  case $1 in
    wire) "$bin/fuzz_wire_seeds" "$d" ;;
    bvh)
      if [ -x "$ragdoll" ]; then
        for clip in walk squat; do
          "$ragdoll" motion export "$repo/assets/motions/$clip.json" --out "$d/$clip-cmu.bvh" --naming cmu --units cm > /dev/null 2>&1
          "$ragdoll" motion export "$repo/assets/motions/$clip.json" --out "$d/$clip-mixamo.bvh" --naming mixamo --up y > /dev/null 2>&1
          "$ragdoll" motion export "$repo/assets/motions/$clip.json" --out "$d/$clip-ragdoll.bvh" > /dev/null 2>&1
        done
        mkdir -p "$out/short"; short_clips "$out/short"
        for clip in walk squat; do
          "$ragdoll" motion export "$out/short/$clip-short.json" --out "$d/$clip-short-cmu.bvh" --naming cmu --units cm > /dev/null 2>&1
          "$ragdoll" motion export "$out/short/$clip-short.json" --out "$d/$clip-short-mixamo.bvh" --naming mixamo --up y > /dev/null 2>&1
        done
      fi
      ;;
    motion)
      cp "$repo"/assets/motions/*.json "$d/"
      cp "$repo"/../shared/data/deepmimic/motions/*.txt "$d/" 2>/dev/null || true
      short_clips "$d"
      ;;
    config) cp "$repo"/configs/*.yaml "$repo"/tests/data/*.yaml "$repo"/tests/e2e/configs/*.yaml "$d/" ;;
  esac
  echo "$d"
}

# One target per core at a time; each gets SECONDS of wall time.
jobs=${FUZZ_JOBS:-$(nproc)}
fuzz() {  # target: runs it, then writes its row to OUT/TARGET.row
  local t=$1 seed_dir corpus log code runs line cov ft rate result
  seed_dir=$(seeds "$t")
  corpus=$out/corpus/$t; mkdir -p "$corpus"
  log=$out/$t.log
  "$bin/fuzz_$t" "$corpus" "$seed_dir" -max_total_time="$seconds" -max_len="${FUZZ_MAX_LEN:-131072}" -timeout=10 \
    -runs="${FUZZ_RUNS:--1}" -rss_limit_mb=4096 -print_final_stats=1 -artifact_prefix="$out/artifacts/$t-" > "$log" 2>&1
  code=$?
  runs=$(awk '/stat::number_of_executed_units/ { print $NF }' "$log")
  line=$(grep -E '^#[0-9]+' "$log" | tail -n 1)
  cov=$(echo "$line" | grep -o 'cov: [0-9]*' | awk '{print $2}')
  ft=$(echo "$line" | grep -o 'ft: [0-9]*' | awk '{print $2}')
  rate=$(awk '/stat::average_exec_per_sec/ { print $NF }' "$log")
  result=ok
  if [ $code -ne 0 ] || grep -q "ERROR: AddressSanitizer\|runtime error:\|ERROR: libFuzzer" "$log"; then
    result="CRASH (exit $code): $(ls "$out/artifacts" | grep "^$t-" | head -n 1)"
  fi
  printf '%-8s %12s %10s %8s %8s %s\n' "$t" "${runs:-?}" "${rate:-?}" "${cov:-?}" "${ft:-?}" "$result" > "$out/$t.row"
}
running=0
for t in "${targets[@]}"; do
  fuzz "$t" &
  running=$((running + 1))
  if [ "$running" -ge "$jobs" ]; then wait -n; running=$((running - 1)); fi
done
wait
failed=0
printf '%-8s %12s %10s %8s %8s %s\n' target executions "exec/s" cov ft result
for t in "${targets[@]}"; do
  cat "$out/$t.row"
  if ! grep -q " ok$" "$out/$t.row"; then
    failed=1
    grep -m 5 -A 12 "ERROR\|runtime error" "$out/$t.log"
  fi
done
exit $failed
