#!/usr/bin/env bash
# The main job, end to end, in well under a minute (after the first build):
#  1. the Inverjet simulator on a new pty, time x30, driven through
#     `rtukit inverjet`: a timer run started, watched, paused, resumed, a plan
#     written and read, a fault injected on the simulator's console, stopped;
#  2. a generic slave written and read with the generic commands.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/build.sh default >/dev/null
rtukit=build/default/cli/rtukit
dir=$(mktemp -d /tmp/rtukit-demo.XXXXXX)
pids=()
trap 'exec 3>&- 2>/dev/null; for p in "${pids[@]}"; do kill "$p" 2>/dev/null; wait "$p" 2>/dev/null; done; rm -rf "$dir"' EXIT
run() { echo "\$ rtukit $*"; "$rtukit" "$@" 2>&1 && echo "(exit 0)" || echo "(exit $?)"; }
wait_for() { for _ in $(seq 100); do [ -e "$1" ] && return 0; sleep 0.05; done; echo "no $1"; exit 1; }

echo "===== 1. Inverjet swimming machine (simulated, time x30: a minute every 2 s)"
jet="$dir/inverjet"
mkfifo "$dir/console"
"$rtukit" sim inverjet --listen "pty:$jet" --state-file "$dir/inverjet.json" --time-scale 30 \
  <"$dir/console" >"$dir/sim.log" 2>&1 &
pids+=($!)
exec 3>"$dir/console"   # the simulator's console: we type into it below
wait_for "$jet"
echo "== simulator: $(grep 'listening on' "$dir/sim.log")"
run inverjet status --port "$jet"
run inverjet start --port "$jet" --timer 3:00 --speed 80
run inverjet watch --port "$jet" --count 5 --interval 500
run inverjet pause --port "$jet"
run inverjet resume --port "$jet"
printf 'speed,end\n30,02:00\n70,05:00\n40,08:00\n' >"$dir/plan.csv"
run inverjet plan set 1 "$dir/plan.csv" --port "$jet"
run inverjet plan show 1 --port "$jet" --json
run inverjet speed 101 --port "$jet"                          # out of range: exit 2, nothing sent
echo "== console: fault motor-drive"
echo "fault motor-drive" >&3
sleep 0.3
run inverjet status --port "$jet" --json
run inverjet start --port "$jet" --free --speed 50              # refused while faulted: exception 04, exit 1
echo "== console: fault clear"
echo "fault clear" >&3
sleep 0.3
run inverjet start --port "$jet" --plan 1
run inverjet watch --port "$jet" --count 3 --interval 500
run inverjet stop --port "$jet"
echo "== what the simulator's console printed:"
grep -E "^faults" "$dir/sim.log" || true

echo
echo "===== 2. a generic slave"
tty="$dir/tty"
"$rtukit" slave --listen "pty:$tty" --unit 1 --registers 100 -v >"$dir/slave.log" 2>&1 &
pids+=($!)
wait_for "$tty"
echo "== slave: $(head -1 "$dir/slave.log")"
run write --port "$tty" --unit 1 0x10 100 200 300
run read  --port "$tty" --unit 1 0x10 3
run write --port "$tty" --unit 1 --type f32 0x20 -- -12.5
run read  --port "$tty" --unit 1 0x20 --type f32 --json
run read  --port "$tty" --unit 1 99 5          # past the end: Modbus exception 02, exit 1
run read  --port "$tty" --unit 9 0 --timeout 200   # nobody at unit 9: exit 3
echo "== what the slave saw:"
tail -n +2 "$dir/slave.log"
