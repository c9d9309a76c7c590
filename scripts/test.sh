#!/usr/bin/env bash
# The whole test suite: installs what is missing, builds, runs every test
# (core, drivers, CLI, interop with libmodbus / pymodbus / mbpoll) under ctest,
# under AddressSanitizer + UndefinedBehaviorSanitizer: a memory error or
# undefined behaviour fails the test that met it, in the test or in a program
# it started (tests/process.hpp, tests/pyhelpers.py check every child's end).
# Ends with "N passed, N failed, N skipped"; a skip not in tests/skips.allowed
# fails the run.
# Usage: scripts/test.sh [--busy] [PRESET] [CTEST_ARGS...]
#   PRESET  asan (the default: build/asan) or default (the plain optimised
#           build the demo uses, build/default); CTEST_ARGS go to ctest
#           (-R, -E...)
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
preset="${1:-asan}"
shift || true
scripts/build.sh "$preset"
# Tests leave nothing behind: a run that leaves new rtukit-* files or folders
# in the temporary directory ($TMPDIR, else /tmp: the one root the tests use,
# tests/process.hpp and Python's tempfile alike) fails, with one line naming
# them, even when every test passed. Entries older than the run are ignored,
# as is the shared build lock (rtukit-build.lock); a test run by someone
# else at the same time can add its own.
tmp="${TMPDIR:-/tmp}"
tmp="${tmp%/}"
rtukit_entries() {
  find "${tmp:-/}" -mindepth 1 -maxdepth 1 -name 'rtukit-*' ! -name 'rtukit-build.lock' -printf '%f\n' 2>/dev/null |
    sort
}
before="$(rtukit_entries)"
rc=0
# The verdict in one line (N passed, N failed, N skipped) from ctest's JUnit
# file: a skip that tests/skips.allowed does not allow for this preset fails
# the run (CTest alone counts a skipped test as passed).
junit="$PWD/build/$preset/suite-junit.xml"
rm -f "$junit"
if [ "$busy" != "0" ]; then
  RTUKIT_BUSY=1 scripts/busy.sh ctest --preset "$preset" -j "$(nproc)" --no-tests=error --output-junit "$junit" "$@" || rc=$?
else
  ctest --preset "$preset" -j "$(nproc)" --no-tests=error --output-junit "$junit" "$@" || rc=$?
fi
if [ -f "$junit" ]; then
  scripts/test-report.py "$junit" "$preset" || [ "$rc" -ne 0 ] || rc=1
else
  echo "test.sh: FAILED: ctest wrote no report ($junit)" >&2
  [ "$rc" -ne 0 ] || rc=1
fi
left="$(comm -13 <(echo "$before") <(rtukit_entries) | sed '/^$/d' | paste -sd ' ' -)"
if [ -n "$left" ]; then
  echo "test.sh: FAILED: the run left in ${tmp:-/}: $left (a test that does not clean up)" >&2
  [ "$rc" -ne 0 ] || rc=1
fi
exit "$rc"
