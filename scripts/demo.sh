#!/usr/bin/env bash
# The main job, end to end, in well under a minute (after the first build):
#  1. the Inverjet simulator on a new pty, time x30, driven through
#     `rtukit inverjet`: a timer run started, watched, paused, resumed, a plan
#     written and read, a fault injected on the simulator's console, stopped;
#  2. the Rehand 6600 controller simulated on a pty and the host controller
#     against it: handshake, a posture command held and released (lease),
#     a light pulsed, a fault injected (overlay: commands refused), a wrong ID;
#  3. a generic slave written and read with the generic commands.
set -euo pipefail
cd "$(dirname "$0")/.."
# Only what the demo runs: the rtukit binary (Release, no tests), with only the
# packages building it needs (scripts/setup.sh programs).
scripts/build.sh programs rtukit >/dev/null
rtukit=build/programs/cli/rtukit
dir=$(mktemp -d /tmp/rtukit-demo.XXXXXX)
pids=()
trap 'exec 3>&- 4>&- 2>/dev/null; for p in "${pids[@]}"; do kill "$p" 2>/dev/null; wait "$p" 2>/dev/null; done; rm -rf "$dir"' EXIT
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
echo "===== 2. Rehand 6600 wheelchair (simulated controller, host controller against it)"
chair="$dir/chair"
mkfifo "$dir/chair-console"
"$rtukit" sim rehand6600 --listen "pty:$chair" <"$dir/chair-console" >"$dir/chair.log" 2>&1 &
pids+=($!)
exec 4>"$dir/chair-console"
wait_for "$chair"
echo "== simulator: $(grep 'listening on' "$dir/chair.log")"
run rehand6600 status --port "$chair" --json
run rehand6600 hold stand stand --for 2s --port "$chair"      # stand/sit is press-and-hold: held 2 s (lease renewed), then released
run rehand6600 pulse light --port "$chair"
echo "== console: joystick 0 100 (the user drives)"
echo "joystick 0 100" >&4
run rehand6600 watch --port "$chair" --count 3 --interval 300
run rehand6600 hold phone_forward --port "$chair"              # refused: the chair is not fully seated after standing (D-10, exit 5)
echo "joystick 0 0" >&4
echo "== console: error 10C3 (seat lift fault)"
echo "error 10C3" >&4
sleep 0.3
run rehand6600 hold seat_lift up --port "$chair"               # refused: the error overlay (exit 5)
echo "error clear" >&4
echo "id 0x42" >&4
sleep 0.2
run rehand6600 status --port "$chair"                          # handshake: wrong device, 1010 Master Error (exit 5)
exec 4>&-

echo
echo "===== 3. a generic slave"
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

echo
echo "===== 4. any other device: a register-map file (examples/maps/energy-meter.yaml), no C++"
map="$(dirname "$0")/../examples/maps/energy-meter.yaml"
meter="$dir/meter"
run map check "$map"
"$rtukit" sim map "$map" --listen "pty:$meter" --no-state --no-console >"$dir/meter.log" 2>&1 &
pids+=($!)
wait_for "$meter"
run read --port "$meter" --map "$map" voltage current power demand_period relay
run read --port "$meter" --unit 1 0x0002 1                      # the same register by address: 900 s
run write --port "$meter" --unit 1 0x0002 30                    # 30 s is below the map's 60..3600: exception 03
run map watch --port "$meter" --map "$map" voltage frequency --count 2 --interval 300
