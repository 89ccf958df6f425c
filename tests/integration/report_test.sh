#!/usr/bin/env bash
# `ragdoll report` as a user runs it. A tiny training is stopped with Ctrl-C (final checkpoint),
# evaluated (eval.json), copied, resumed for a while (its clock restarts) and stopped again; the
# report on the run and its earlier copy must open in headless Chromium without console errors,
# draw both runs' curves, embed a GIF per run and write the curves as a PNG. Bad run folders are
# refused with the file, line and column.
#   report_test.sh RAGDOLL CONFIG
set -u
ragdoll=$1 config=$2
work=$(mktemp -d /tmp/ragdoll-report-test.XXXXXX)
# Ports P..P+4, metrics P+10, P+11, P+20+i: clear of the other integration tests' ranges.
port=$((27600 + 50 * (RANDOM % 20)))
pids=()
cleanup() { kill "${pids[@]}" 2>/dev/null; wait 2>/dev/null; rm -rf "$work"; }
trap cleanup EXIT
fail() { echo "FAIL: $*"; exit 1; }
runs=$work/runs run=$work/runs/tiny copy=$work/runs/tiny-before-resume
begin=$SECONDS

# Trains for about $1 seconds and at least $2 PPO updates, then stops it as Ctrl-C would.
train() {
  local seconds=$1 updates=$2 log=$3; shift 3
  "$ragdoll" train "$config" --run-id tiny --runs-dir "$runs" --port-base "$port" "$@" \
    > "$log" 2>&1 &
  local pid=$! started=$SECONDS
  pids+=($pid)
  while [ $((SECONDS - started)) -lt "$seconds" ] || [ "$(grep -c '^\[' "$log")" -lt "$updates" ]; do
    [ $((SECONDS - started)) -lt 120 ] || fail "no $updates PPO updates in 120 s: $(tail -n 5 "$log")"
    kill -0 "$pid" 2>/dev/null || fail "training stopped by itself: $(tail -n 5 "$log")"
    sleep 1
  done
  kill -INT "$pid"
  wait "$pid" || fail "training did not stop cleanly: $(tail -n 5 "$log")"
}
rows() { tail -n +2 "$1/metrics.csv" | grep -c .; }

train 25 3 "$work/train1.log"
ls "$run"/checkpoints/checkpoint-*.pt > /dev/null 2>&1 || fail "no checkpoint after Ctrl-C"
echo "first session: $(rows "$run") PPO updates, $(ls "$run/checkpoints" | tail -n 1)"

# eval on a run folder also writes <run>/eval.json, naming the checkpoint it evaluated.
"$ragdoll" eval "$run" --episodes 5 --json "$work/eval-copy.json" > "$work/eval.out" \
  2> "$work/eval.err" || fail "eval: $(cat "$work/eval.err")"
[ -s "$run/eval.json" ] || fail "eval did not write $run/eval.json"
cmp -s "$run/eval.json" "$work/eval-copy.json" || fail "eval.json differs from --json's file"
newest=$(ls "$run/checkpoints" | sort | tail -n 1)
jq -e --arg c "$newest" '(.checkpoint | endswith($c)) and .policy_version > 0 and .samples > 0
  and .episodes == 5 and (.normalized_return | type) == "number"' "$run/eval.json" > /dev/null ||
  fail "eval.json lacks the checkpoint fields: $(cat "$run/eval.json")"
jq -e '.policy_version > 0' "$work/eval.out" > /dev/null || fail "eval's stdout is not the JSON"

cp -r "$run" "$copy"
rm "$copy/eval.json"
train 15 4 "$work/train2.log" --resume
grep -q "resumed from" "$work/train2.log" ||
  fail "second session did not resume: $(head -n 5 "$work/train2.log")"
# The resumed learner's clock starts at zero again: elapsed_s goes back once.
restarts=$(awk -F, 'NR > 2 && $4 < previous { n++ } { previous = $4 } END { print n + 0 }' \
  "$run/metrics.csv")
[ "$restarts" = 1 ] || fail "expected elapsed_s to restart once, saw $restarts"
echo "after resuming: $(rows "$run") PPO updates (the copy has $(rows "$copy"))"

# The report: two runs overlaid, a GIF each, the curves as PNG too.
report_start=$SECONDS
"$ragdoll" report "$run" "$copy" --out "$work/report.html" --png "$work/curves.png" \
  --gif-seconds 4 2> "$work/report.err" || fail "report: $(cat "$work/report.err")"
cat "$work/report.err"
echo "report took $((SECONDS - report_start)) s; page $(($(stat -c %s "$work/report.html") / 1000)) kB"
html=$work/report.html
[ "$(grep -o 'data:image/gif;base64,R0lGOD' "$html" | wc -l)" = 2 ] || fail "not 2 embedded GIFs"
grep -q "tiny-before-resume: no eval.json. Make one with <code>ragdoll eval $copy</code>" "$html" ||
  fail "the run without eval.json is not explained"
grep -q "<td>policy version</td><td class=\"num\">v[0-9]*</td>" "$html" ||
  fail "no evaluation table with the policy version"
grep -q "tiny: evaluated at [0-9 ]* samples; training has reached" "$html" ||
  fail "the evaluation done before the resume is not flagged as older than the curves"
grep -q "<td>stand</td>" "$html" || fail "header does not name the clip"
# The header's wall time adds up both learner sessions.
wall=$(awk -F, 'NR > 1 { if ($4 < previous) offset += previous; previous = $4; t = $4 + offset }
  END { s = int(t + 0.5); printf "%d:%02d:%02d", s / 3600, s / 60 % 60, s % 60 }' "$run/metrics.csv")
grep -q "<td>tiny</td><td>stand</td><td class=\"num\">[0-9 ]*</td><td class=\"num\">$wall</td>" \
  "$html" || fail "header wall time is not both sessions' $wall"
others=$(grep -o 'https\?://[^"]*' "$html" | grep -vx 'http://www.w3.org/2000/svg' | head -n 3)
[ -z "$others" ] || fail "the page refers to the network: $others"

# The PNG: a real image of the whole curves SVG (1200 px wide).
python3 - "$work/curves.png" <<'EOF' || fail "bad PNG"
import struct, sys
data = open(sys.argv[1], "rb").read()
assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
width, height = struct.unpack(">II", data[16:24])
print(f"curves.png: {width}x{height}, {len(data) // 1000} kB")
assert width == 1200 and height > 2000 and len(data) > 20000, (width, height, len(data))
EOF

# Chromium, headless: the script logs one line when set up; any other console line (an error, an
# uncaught exception, a resource that failed to load) fails the test.
chromium --headless --disable-gpu --no-sandbox --enable-logging=stderr --v=0 \
  --virtual-time-budget=3000 --screenshot="$work/shot.png" --window-size=1280,2400 \
  "file://$html" > "$work/chromium.out" 2> "$work/chromium.err" ||
  fail "chromium: $(tail -n 5 "$work/chromium.err")"
console=$(grep "CONSOLE" "$work/chromium.err")
echo "console: $console"
[ "$(echo "$console" | grep -c .)" = 1 ] || fail "console lines other than the report's own"
echo "$console" | grep -q '"ragdoll report: 16 plots, 32 lines"' ||
  fail "the page script did not set up 16 plots with 2 runs' lines"
! grep -qi "uncaught" "$work/chromium.err" || fail "uncaught exception"

# Pixels: below the header, at least 1 % differ from the white background, and each run's colour
# (blue #1f77b4, red #d62728) covers curves, not just its swatches (about 300 px in view). Blue,
# the resumed run, shows only beyond the copy, which is drawn over it.
for image in shot.png curves.png; do
  ffmpeg -loglevel error -y -i "$work/$image" -f rawvideo -pix_fmt rgb24 "$work/$image.rgb" ||
    fail "ffmpeg could not read $image"
  size=$(ffprobe -v error -select_streams v:0 -show_entries stream=width,height -of csv=p=0 \
    "$work/$image")
  python3 - "$work/$image.rgb" "$size" "$image" <<'EOF' || fail "$image: curves not drawn"
import sys
raw = open(sys.argv[1], "rb").read()
width, height = map(int, sys.argv[2].split(","))
top = 150 if sys.argv[3] == "shot.png" else 0  # the screenshot's title and run table
colours = {"blue": (0x1F, 0x77, 0xB4), "red": (0xD6, 0x27, 0x28)}
counts = dict.fromkeys(colours, 0)
differ = 0
for y in range(top, height):
    row = raw[3 * width * y: 3 * width * (y + 1)]
    if row.count(255) == len(row):
        continue
    for x in range(0, 3 * width, 3):
        r, g, b = row[x], row[x + 1], row[x + 2]
        if r < 250 or g < 250 or b < 250:
            differ += 1
            for name, (cr, cg, cb) in colours.items():
                if abs(r - cr) + abs(g - cg) + abs(b - cb) < 60:
                    counts[name] += 1
total = width * (height - top)
print(f"{sys.argv[3]}: {width}x{height}, {100 * differ / total:.1f} % not background, "
      f"run colours {counts}")
assert differ >= 0.01 * total, differ
assert all(n >= 1000 for n in counts.values()), counts
EOF
done

# Bad input: a folder that is not a run, and a metrics.csv with a bad cell.
"$ragdoll" report "$work/nothing" --out "$work/x.html" --no-gif 2> "$work/err1.txt"
[ $? = 2 ] || fail "exit code for a missing run folder"
grep -q "report: $work/nothing: no such run folder" "$work/err1.txt" || fail "$(cat "$work/err1.txt")"
mkdir "$work/empty"
"$ragdoll" report "$work/empty" --out "$work/x.html" --no-gif 2> "$work/err2.txt"
[ $? = 2 ] || fail "exit code for a folder without metrics.csv"
grep -q "empty: no metrics.csv" "$work/err2.txt" || fail "$(cat "$work/err2.txt")"
awk -F, -v OFS=, 'NR == 3 { $8 = "oops" } { print }' "$copy/metrics.csv" > "$work/bad.csv"
mv "$work/bad.csv" "$copy/metrics.csv"
"$ragdoll" report "$copy" --out "$work/x.html" --no-gif 2> "$work/err3.txt"
[ $? = 2 ] || fail "exit code for a bad cell"
grep -q "tiny-before-resume/metrics.csv:3: column 8 (normalized_return): 'oops' is not a number" \
  "$work/err3.txt" || fail "message: $(cat "$work/err3.txt")"
[ ! -e "$work/x.html" ] || fail "a page was written for bad input"
echo "whole test: $((SECONDS - begin)) s"
echo "1 passed, 0 failed"
