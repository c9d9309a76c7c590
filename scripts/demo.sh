#!/usr/bin/env bash
# The main job, end to end: builds rtukit if needed, starts a generic slave on a
# new pty, writes and reads it with the rtukit CLI (plain, typed, JSON), shows
# an exception and the exit codes, then stops the slave.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/build.sh default >/dev/null
rtukit=build/default/cli/rtukit
dir=$(mktemp -d /tmp/rtukit-demo.XXXXXX)
tty="$dir/tty"

"$rtukit" slave --listen "pty:$tty" --unit 1 --registers 100 -v >"$dir/slave.log" 2>&1 &
slave=$!
trap 'kill "$slave" 2>/dev/null; wait "$slave" 2>/dev/null; rm -rf "$dir"' EXIT
for _ in $(seq 100); do [ -e "$tty" ] && break; sleep 0.05; done
echo "== slave: $(head -1 "$dir/slave.log")"

run() { echo "\$ rtukit $*"; "$rtukit" "$@" 2>&1 && echo "(exit 0)" || echo "(exit $?)"; }
run write --port "$tty" --unit 1 0x10 100 200 300
run read  --port "$tty" --unit 1 0x10 3
run write --port "$tty" --unit 1 --type f32 0x20 -- -12.5
run read  --port "$tty" --unit 1 0x20 --type f32 --json
run write --port "$tty" --unit 1 --coils 5 1 0 1
run read  --port "$tty" --unit 1 --coils 5 3 --stats
run read  --port "$tty" --unit 1 99 5          # past the end: Modbus exception 02, exit 1
run read  --port "$tty" --unit 9 0 --timeout 200   # nobody at unit 9: exit 3
echo "== what the slave saw:"
tail -n +2 "$dir/slave.log"
