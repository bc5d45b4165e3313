#!/bin/sh
# usage: run_with_xvfb.sh COMMAND [ARGS...]
# Starts a private Xvfb on a free display number, runs COMMAND with DISPLAY pointing at it,
# stops that Xvfb (by its pid) and returns COMMAND's exit code. Exits 77 (ctest: skipped) with
# a message when Xvfb is not installed. Free display: Xvfb -displayfd picks an unused number
# itself and reports it once it accepts connections, so parallel tests never collide.
# -noreset: without it Xvfb resets when its last client disconnects (as a probe does) and
# refuses the next connection during the reset.
command -v Xvfb >/dev/null 2>&1 || { echo "SKIP: Xvfb not installed (Debian: apt-get install xvfb)"; exit 77; }
dir=$(mktemp -d "${TMPDIR:-/tmp}/btflod-xvfb.XXXXXX") || exit 1
Xvfb -displayfd 3 -screen 0 640x480x24 -nolisten tcp -noreset 3>"$dir/display" >"$dir/log" 2>&1 &
pid=$!
cleanup() { kill "$pid" 2>/dev/null; wait "$pid" 2>/dev/null; rm -rf "$dir"; }
trap cleanup EXIT INT TERM
n=""
i=0
while [ $i -lt 200 ]; do  # up to 10 s
  n=$(tr -dc 0-9 <"$dir/display")
  [ -n "$n" ] && [ -S "/tmp/.X11-unix/X$n" ] && break
  kill -0 "$pid" 2>/dev/null || { echo "FAIL: Xvfb exited:"; cat "$dir/log"; exit 1; }
  sleep 0.05
  i=$((i + 1))
done
[ -n "$n" ] || { echo "FAIL: Xvfb did not report a display within 10 s"; cat "$dir/log"; exit 1; }
echo "run_with_xvfb: Xvfb :$n (pid $pid)"
DISPLAY=":$n" "$@"
rc=$?
exit $rc
