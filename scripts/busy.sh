#!/usr/bin/env bash
# Runs a command while other work keeps cores busy: the machine a CI runner or
# a shared desk is on a bad day. A test that passes only on an idle machine
# times something by the wall clock (a fixed sleep, a tight deadline, a
# connect that races a process start); under this script it fails.
#
# Usage: scripts/busy.sh [-n LOOPS] COMMAND [ARGS...]
#   -n LOOPS   how many busy loops to run beside COMMAND (default 1: one core
#              of a two-core machine kept busy; RTUKIT_BUSY_LOOPS sets it too)
# Examples:
#   scripts/busy.sh ctest --test-dir build/default -j2 --output-on-failure
#   scripts/test.sh --busy            (the whole suite, the same way)
#
# The loops are plain shell loops at normal priority, started here and
# stopped by their PIDs when this script ends, however it ends (EXIT trap);
# the exit code is COMMAND's.
set -euo pipefail

loops="${RTUKIT_BUSY_LOOPS:-1}"
if [ "${1:-}" = "-n" ]; then
  loops="${2:?-n needs a number}"
  shift 2
fi
if [ $# -eq 0 ] || ! [[ "$loops" =~ ^[0-9]+$ ]]; then
  sed -n '7,12p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
fi

# The tests read it: a bound on the host's own clock gets its busy margin.
export RTUKIT_BUSY=1
busy_pids=()
stop_loops() {
  for pid in "${busy_pids[@]}"; do
    kill "$pid" 2>/dev/null || true
    wait "$pid" 2>/dev/null || true
  done
  busy_pids=()
}
trap stop_loops EXIT
trap 'exit 130' INT
trap 'exit 143' TERM HUP

for ((i = 0; i < loops; ++i)); do
  bash -c 'while :; do :; done' </dev/null >/dev/null 2>&1 &
  busy_pids+=("$!")
done
echo "busy.sh: $loops busy loop(s) running (pid ${busy_pids[*]:-none}) beside: $*" >&2

status=0
"$@" || status=$?
exit "$status"
