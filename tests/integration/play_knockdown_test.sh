#!/usr/bin/env bash
# A knock-down in `ragdoll play`, as a player does it: on its own Xvfb display, the trained run
# (one with environment.recovery) walks for 3 s with W held, xdotool presses K (a hard push on
# the chest), and the character must fall, get up and walk on. From play's per-step log: a fall within 1.5 s of the
# knock, then standing (no get-up playing, pelvis upright and high) and travelling at least 0.3 m/s
# over the next second, from a moment within PLAY_TEST_UP_SECONDS (default 6) of the knock; several knock-downs are tried
# (PLAY_TEST_KNOCKS, default 3) and each is reported, the share that made it asserted
# (PLAY_TEST_KNOCK_SHARE, default 1.0).
#   play_knockdown_test.sh RAGDOLL [RUN]
# RUN: $PLAY_TEST_RUN, else the argument; skipped (exit 77) when it does not exist.
set -u
ragdoll=$1
run=${PLAY_TEST_RUN:-${2:-}}
if [ -z "$run" ] || [ ! -e "$run" ]; then
  echo "SKIP: no trained run with recovery at '$run' (set PLAY_TEST_RUN)"
  exit 77
fi
fail() { echo "FAIL: $*"; exit 1; }
for tool in Xvfb xdotool python3; do
  command -v $tool > /dev/null || fail "$tool is missing (deploy/setup.sh installs it)"
done
knocks=${PLAY_TEST_KNOCKS:-3} up_seconds=${PLAY_TEST_UP_SECONDS:-6}

source "$(dirname "$0")/play_session.sh" ragdoll-knock

period=$((up_seconds + 3))  # time to fall, get up, and walk for the check's second
start_play "$run" --seconds $((2 + knocks * period)) --log "$work/play.csv"
# W held throughout: the player keeps telling it to walk, through the fall and after.
xdotool keydown --window "$wid" w || fail "xdotool keydown w"
for _ in $(seq 1 "$knocks"); do
  sleep 3
  xdotool key --window "$wid" k || fail "xdotool key k"
  sleep $((period - 3))
done
wait "$play"
code=$?
play=''
cat "$work/play.out"
[ $code = 0 ] || fail "play exited with $code"

python3 - "$work/play.csv" "$knocks" "$up_seconds" "${PLAY_TEST_KNOCK_SHARE:-1.0}" << 'PY' ||
import csv, math, sys

rows = list(csv.DictReader(open(sys.argv[1])))
knocks, up_seconds, share = int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
t = [float(r["time"]) for r in rows]
def fell(i):  # the recovery task saw a fall, or one ended the episode
    return rows[i]["fell"] == "1" or int(rows[i]["falls"]) > int(rows[i - 1]["falls"])
knocked = [i for i, r in enumerate(rows) if i > 0 and float(r["pushed"]) > 0]
made = 0
for k in knocked:
    window = [i for i in range(k, len(rows)) if t[i] - t[k] <= up_seconds]
    f = next((i for i in window if t[i] - t[k] <= 1.5 and fell(i)), None)
    up = None
    for i in window if f is not None else []:
        if i <= f or rows[i]["getting_up"] == "1" or rows[i]["standing"] == "0":
            continue
        # walking again from here: at least 0.3 m/s of travel over the next second
        j = next((n for n in range(i, len(rows)) if t[n] - t[i] >= 1.0), None)
        if j is None:
            break
        d = math.hypot(float(rows[j]["x"]) - float(rows[i]["x"]),
                       float(rows[j]["y"]) - float(rows[i]["y"]))
        if d / (t[j] - t[i]) >= 0.3:
            up = t[i] - t[k]
            break
    print(f"knocked at {t[k]:.1f} s: " + ("no fall" if f is None else f"fell after {t[f] - t[k]:.1f} s, " +
          (f"walking again {up:.1f} s after the knock" if up else f"not walking again within {up_seconds:.0f} s")))
    made += up is not None
print(f"{len(knocked)} knock-downs, {made} walking again within {up_seconds:.0f} s")
sys.exit(0 if len(knocked) == knocks and made >= math.ceil(share * knocks) else 1)
PY
  fail "the character did not get up and walk on after the knock-downs"
echo "PASS: knocked down, up and walking again"
