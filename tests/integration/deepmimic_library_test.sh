#!/usr/bin/env bash
# Every DeepMimic humanoid3d motion file at hand, as published and with its rotations scaled to
# norms 0.85 and 1.06 (as found in DeepMimic's library), loads, inspects and renders; each file as
# published starts training, and so do the first clip's scaled variants (renormalised on load, a
# scaled file gives the published clip again, so training every variant only repeated it).
#   deepmimic_library_test.sh RAGDOLL MOTIONS_DIR PORT_BASE
set -u
ragdoll=$1 motions=$2 port=$3
work=$(mktemp -d /tmp/ragdoll-library.XXXXXX)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

# Scales every quaternion of a DeepMimic frame (44 values: duration, root position, root rotation,
# then per joint a quaternion or, for knees and elbows at 20, 29, 34 and 43, an angle).
scale() {
  jq -c --argjson s "$2" '.Frames |= map([to_entries[] |
      if .key >= 4 and (.key | IN(20, 29, 34, 43) | not) then .value * $s else .value end])' \
    "$1" > "$3"
}

passed=0 failed=0
check() {  # name, then the command; counts and reports
  local name=$1
  shift
  if "$@" > "$work/out.txt" 2>&1; then
    passed=$((passed + 1))
  else
    failed=$((failed + 1))
    echo "FAIL: $name"
    tail -n 20 "$work/out.txt"
  fi
}

# How many rotations of a DeepMimic file have a norm off by more than 0.001, and the largest
# |norm - 1| to 4 decimals, computed here from the file's numbers (the quaternions start at 4, 8,
# 12, 16, 21, 25, 30, 35 and 39). Published files differ: the get-up clips are off by up to 2 %.
norms() {
  jq -r '[.Frames[] as $f | (4, 8, 12, 16, 21, 25, 30, 35, 39) as $i
          | ([$f[$i:$i + 4][] | . * .] | add | sqrt) - 1 | if . < 0 then -. else . end]
         | "\(map(select(. > 0.001)) | length) \(max)"' "$1" |
    awk '{ printf "%d %.4f", $1, $2 }'
}

inspect() {  # clip: `motion inspect` reports the renormalised rotations the file holds
  "$ragdoll" motion inspect "$1" > "$work/inspect.txt" || return 1
  cat "$work/inspect.txt"
  local line count deviation
  read -r count deviation <<< "$(norms "$1")"
  line=$(grep "^rotations" "$work/inspect.txt")
  echo "expected: $count renormalised, largest |norm - 1| $deviation"
  [[ "$line" =~ ^rotations\ +$count\ renormalised.*\|norm\ -\ 1\|\ $deviation$ ]] || return 1
  # A scaled variant is off by at least its scale.
  [ "$2" = 1 ] || awk -v d="$deviation" -v s="$2" 'BEGIN { e = s - 1; if (e < 0) e = -e
                                                         exit !(d >= e - 0.00005) }'
}

render() {  # clip: one frame of the clip alone, a PNG of the expected size
  "$ragdoll" render --clip "$1" --out "$work/frame.png" --time 0.3 || return 1
  [ "$(head -c 8 "$work/frame.png" | od -An -tx1 | tr -d ' \n')" = 89504e470d0a1a0a ] || return 1
  [ "$(stat -c %s "$work/frame.png")" -gt 10000 ]
}

train() {  # clip, run id: a short training that stops by itself after two PPO updates
  cat > "$work/$2.yaml" <<EOF
environment:
  motion: $1
  action_mode: offset
  max_episode_steps: 60
trainer:
  hyperparameters: {batch_size: 256, buffer_size: 1024, num_epoch: 2}
  network_settings: {hidden_units: 32, num_layers: 2}
  max_steps: 2048
  time_horizon: 16
  checkpoint_interval: 1024
actors: {count: 1, environments: 4}
metrics: {enabled: false}
EOF
  timeout 120 "$ragdoll" train "$work/$2.yaml" --run-id "$2" --runs-dir "$work/runs" \
    --port-base "$port" || return 1
  # Two updates, each with finished episodes and a finite normalised return.
  [ "$(wc -l < "$work/runs/$2/metrics.csv")" -eq 3 ] || return 1
  awk -F, 'NR > 1 && !($8 >= 0 && $8 <= 1) { bad = 1 } END { exit bad }' \
    "$work/runs/$2/metrics.csv" || return 1
  ls "$work/runs/$2/checkpoints/"checkpoint-*.pt > /dev/null
}

shopt -s nullglob
clips=("$motions"/*.txt)
[ ${#clips[@]} -gt 0 ] || fail "no motion files in $motions"
for clip in "${clips[@]}"; do
  name=$(basename "$clip" .txt)
  for s in 1 0.85 1.06; do
    file="$work/${name}_x$s.txt"
    if [ "$s" = 1 ]; then cp "$clip" "$file"; else scale "$clip" "$s" "$file"; fi
    check "$name x$s: inspect" inspect "$file" "$s"
    check "$name x$s: render" render "$file"
    [ "$s" = 1 ] || [ "$clip" = "${clips[0]}" ] || continue
    check "$name x$s: train" train "$file" "${name}_x$s"
  done
done
echo "${#clips[@]} clips, 3 variants each: load, inspect, render; $((${#clips[@]} + 2)) trainings"
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
