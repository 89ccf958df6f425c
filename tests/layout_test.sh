#!/usr/bin/env bash
# The rooms' order: a room's files include only rooms before it in this list (and itself), so
# that lower rooms never include higher ones. A new room is added here at its place, and to the
# root CMakeLists.txt and README.md's layout table in the same order.
set -euo pipefail
cd "$(dirname "$0")/.."
rooms=(common character sim motion actor learner broker eval run render report exports bench cli)
# Outside the rooms: schemas/ (the generated ragdoll/v1/*.pb.h) may be included by any room.
failed=0
for ((i = 0; i < ${#rooms[@]}; ++i)); do
  room=${rooms[$i]}
  [ -d "$room" ] || { echo "FAIL: room $room/ is missing"; failed=1; continue; }
  allowed=("${rooms[@]:0:$((i + 1))}" ragdoll)
  while IFS= read -r hit; do
    file=${hit%%:*}
    included=$(sed -E 's/.*#include "([a-z_]+)\/.*/\1/' <<< "$hit")
    if [[ ! " ${allowed[*]} " == *" $included "* ]]; then
      echo "FAIL: $file includes $included/, a room above $room/ ($hit)"
      failed=1
    fi
  done < <(grep -rnE '^#include "[a-z_]+/' "$room" --include='*.h' --include='*.cc' --include='*.in' || true)
done
# Every top-level folder with C++ sources is a room of the list (the sources git tracks; outside
# a checkout, every folder but the build folders).
if git rev-parse --is-inside-work-tree > /dev/null 2>&1; then
  source_dirs=$(git ls-files '*.cc' '*.h' | grep / | cut -d/ -f1 | sort -u)
else
  source_dirs=$(find . -mindepth 2 \( -name '*.cc' -o -name '*.h' \) -not -path './build*' |
    cut -d/ -f2 | sort -u)
fi
for dir in $source_dirs; do
  case " ${rooms[*]} tests " in *" $dir "*) continue ;; esac
  echo "FAIL: $dir/ holds C++ sources but is not in the rooms' order (tests/layout_test.sh)"
  failed=1
done
[ "$failed" -eq 0 ] && echo "PASS: ${#rooms[@]} rooms, each including only rooms below it"
exit "$failed"
