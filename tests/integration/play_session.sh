# Sourced by the play tests: a work folder ($work), an Xvfb display of their own on the first
# free display number, `ragdoll play` started on it ($play) with its window found ($wid), and a
# cleanup that stops both. Needs `fail` defined and the prefix of the work folder in $1.
work=$(mktemp -d "/tmp/$1.XXXXXX")
xvfb='' play=''
cleanup() {
  [ -n "$play" ] && kill "$play" 2> /dev/null
  [ -n "$xvfb" ] && kill "$xvfb" 2> /dev/null
  wait 2> /dev/null
  rm -rf "$work"
}
trap cleanup EXIT

for n in $(seq 91 199); do
  [ -e /tmp/.X$n-lock ] || [ -e /tmp/.X11-unix/X$n ] || { display=:$n; break; }
done
Xvfb "$display" -screen 0 1280x720x24 -nolisten tcp > "$work/xvfb.log" 2>&1 &
xvfb=$!
export DISPLAY=$display
for _ in $(seq 1 50); do xdotool getdisplaygeometry > /dev/null 2>&1 && break; sleep 0.1; done
xdotool getdisplaygeometry > /dev/null 2>&1 || fail "Xvfb did not start: $(cat "$work/xvfb.log")"

# start_play ARGS...: `ragdoll play ARGS` in the background, output in $work/play.out; sets $wid
# and returns once the simulation runs.
start_play() {
  "$ragdoll" play "$@" > "$work/play.out" 2>&1 &
  play=$!
  wid=''
  for _ in $(seq 1 300); do
    wid=$(xdotool search --name "ragdoll play" 2> /dev/null | head -n 1)
    [ -n "$wid" ] && break
    kill -0 "$play" 2> /dev/null || break
    sleep 0.1
  done
  [ -n "$wid" ] || { cat "$work/play.out"; fail "no 'ragdoll play' window appeared"; }
  # The window is there before its first frame is drawn (slow in software GL on a loaded
  # machine): keys count only once play says its clock runs.
  for _ in $(seq 1 600); do
    grep -q '^play: started' "$work/play.out" && return
    kill -0 "$play" 2> /dev/null || break
    sleep 0.1
  done
  cat "$work/play.out"
  fail "'ragdoll play' did not start its clock within 60 s"
}
