#!/usr/bin/env bash
# The whole test suite: installs what is missing, builds, runs every test
# (core, drivers, CLI, interop with libmodbus / pymodbus / mbpoll) under ctest.
# Usage: scripts/test.sh [PRESET]   (default: default; also: asan)
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${1:-default}"
scripts/build.sh "$preset"
ctest --preset "$preset" -j "$(nproc)"
