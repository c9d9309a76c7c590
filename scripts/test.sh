#!/usr/bin/env bash
# The whole test suite: installs what is missing, builds, runs every test
# (core, drivers, CLI, interop with libmodbus / pymodbus / mbpoll) under ctest.
# Usage: scripts/test.sh [--busy] [PRESET] [CTEST_ARGS...]
#   PRESET  default (the default) or asan; CTEST_ARGS go to ctest (-R, -E...)
#   --busy  (or RTUKIT_BUSY=1): run the suite with one core kept busy by a
#           busy loop this script starts and stops by PID (scripts/busy.sh;
#           RTUKIT_BUSY_LOOPS=N for more). Timing in the tests comes from the
#           virtual clock or from generous deadlines on events, never from how
#           fast the machine happens to be: the suite must pass this way too.
set -euo pipefail
cd "$(dirname "$0")/.."
busy="${RTUKIT_BUSY:-0}"
if [ "${1:-}" = "--busy" ]; then
  busy=1
  shift
fi
preset="${1:-default}"
shift || true
scripts/build.sh "$preset"
# Tests leave nothing behind: rtukit-* folders in the temporary folder that
# appeared during the run are listed at the end (a test run by someone else
# at the same time can add its own; folders older than the run are ignored).
tmp="${TMPDIR:-/tmp}"
rtukit_dirs() { find "$tmp" -maxdepth 1 -type d -name 'rtukit-*' 2>/dev/null | sort; }
before="$(rtukit_dirs)"
rc=0
if [ "$busy" != "0" ]; then
  scripts/busy.sh ctest --preset "$preset" -j "$(nproc)" "$@" || rc=$?
else
  ctest --preset "$preset" -j "$(nproc)" "$@" || rc=$?
fi
left="$(comm -13 <(echo "$before") <(rtukit_dirs) | sed '/^$/d')"
if [ -n "$left" ]; then
  echo "test.sh: folders left in $tmp during this run (a test that does not clean up?):" >&2
  echo "$left" | sed 's/^/  /' >&2
fi
exit "$rc"
