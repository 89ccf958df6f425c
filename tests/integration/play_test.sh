#!/usr/bin/env bash
# `ragdoll play` as a player drives it: on its own Xvfb display, xdotool holds W in the play
# window for 6 s (walk), releases it (stand), then holds Q for 4 s (turn left). From play's
# per-step log: the commands follow the keys, the character travels more than 1 m within 30
# degrees of its desired heading while W is held, turns left by more than 45 degrees while Q is
# held, and never falls.
#   play_test.sh RAGDOLL [RUN]
# RUN is a trained steering run (folder or checkpoint): $PLAY_TEST_RUN, else the argument, else
# tests/data/steer_policy. The test is skipped (exit 77) when it does not exist.
# PLAY_TEST_MECHANICS_ONLY=1 checks only keys, commands, logging and pacing (for a barely
# trained policy, which cannot walk): travel, turning and falls are reported, not asserted.
# The clips the keys should pick: PLAY_TEST_STAND, PLAY_TEST_WALK, PLAY_TEST_TURN (default stand,
# walk, turn_left).
set -u
ragdoll=$1
here=$(cd "$(dirname "$0")" && pwd)
run=${PLAY_TEST_RUN:-${2:-$here/../data/steer_policy}}
if [ ! -e "$run" ]; then
  echo "SKIP: no trained steering policy at $run (train one, copy its run folder there, or set" \
    "PLAY_TEST_RUN)"
  exit 77
fi
fail() { echo "FAIL: $*"; exit 1; }
for tool in Xvfb xdotool python3; do
  command -v $tool > /dev/null || fail "$tool is missing (deploy/setup.sh installs it)"
done

source "$(dirname "$0")/play_session.sh" ragdoll-play

start_play "$run" --seconds 20 --log "$work/play.csv"

# The keys, as a player holds them.
key() { xdotool "$1" --window "$wid" "$2" || fail "xdotool $1 $2"; }
sleep 1
key keydown w
sleep 6
key keyup w
sleep 3
key keydown q
sleep 4
key keyup q
wait "$play"
code=$?
play=''
cat "$work/play.out"
[ $code = 0 ] || fail "play exited with $code"

python3 - "$work/play.csv" << 'EOF' || fail "the log does not show the character following the keys"
import csv, math, os, sys

rows = list(csv.DictReader(open(sys.argv[1])))
mechanics = os.environ.get("PLAY_TEST_MECHANICS_ONLY") == "1"
stand = os.environ.get("PLAY_TEST_STAND", "stand")
walk = os.environ.get("PLAY_TEST_WALK", "walk")
turn = os.environ.get("PLAY_TEST_TURN", "turn_left")
ok = True
def check(condition, message):
    global ok
    print(("ok:   " if condition else "FAIL: ") + message)
    ok &= bool(condition)

# Pacing is a figure, not an assertion (a loaded machine may lag): printed for the record.
wall, simulated = float(rows[-1]["wall"]), float(rows[-1]["time"])
check(len(rows) > 300, f"{len(rows)} control steps logged")
print(f"pacing: {simulated:.1f} s simulated in {wall:.1f} s of wall time")

# The commands follow the keys: stand, W: walk, stand, Q: turn, stand.
runs = []
for r in rows:
    if not runs or runs[-1][0] != r["command"]:
        runs.append((r["command"], []))
    runs[-1][1].append(r)
names = [name for name, _ in runs]
expected = [stand, walk, stand, turn, stand]
if turn == stand:
    expected = [stand, walk, stand]
check(names == expected, f"commands {' > '.join(names)} (expected {' > '.join(expected)})")
# An untrained policy (PLAY_TEST_MECHANICS_ONLY) is only reported on.
report = check if not mechanics else lambda condition, message: print("info: " + message)
falls = sum(int(r["fell"]) for r in rows)
report(falls == 0, f"{falls} falls")
if names != expected:
    sys.exit(1)

def segment(name, index):
    return [rs for n, rs in runs if n == name][index]

# While W is held (from the first episode's part of it, should it have fallen): travel along the
# desired heading.
w = segment(walk, 0)
w = [r for r in w if r["episode"] == w[0]["episode"]]
dx = float(w[-1]["x"]) - float(w[0]["x"])
dy = float(w[-1]["y"]) - float(w[0]["y"])
distance = math.hypot(dx, dy)
desired = math.atan2(sum(math.sin(float(r["desired_heading"])) for r in w),
                     sum(math.cos(float(r["desired_heading"])) for r in w))
off = abs(math.degrees(math.remainder(math.atan2(dy, dx) - desired, 2 * math.pi)))
report(distance > 1.0, f"walked {distance:.2f} m in {len(w) / 30:.1f} s")
report(off < 30, f"{off:.0f} degrees off the desired heading")

# While Q is held: the heading turns left (counter-clockwise), unwrapped.
if turn != stand:
    q = segment(turn, 0)
    q = [r for r in q if r["episode"] == q[0]["episode"]]
    headings = [float(r["heading"]) for r in q]
    turned = sum(math.remainder(b - a, 2 * math.pi) for a, b in zip(headings, headings[1:]))
    report(math.degrees(turned) > 45, f"turned {math.degrees(turned):.0f} degrees left")
sys.exit(0 if ok else 1)
EOF
echo "1 passed, 0 failed"
