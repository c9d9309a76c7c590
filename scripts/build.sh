#!/usr/bin/env bash
# Installs what is missing (scripts/setup.sh), configures and builds a preset.
# Usage: scripts/build.sh [PRESET] [TARGET...]   (default: default, everything)
#   PRESET `programs` needs only the packages that building the programs
#   needs (scripts/setup.sh programs); every other preset builds the tests
#   too and gets all of them. TARGETs: only those (and what they need).
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${1:-default}"
shift || true
if [ "$preset" = programs ]; then scripts/setup.sh programs; else scripts/setup.sh; fi
# Compiles are cached (ccache, from setup.sh): the cache is keyed on paths
# relative to the source folder, so a clean clone elsewhere reuses what
# earlier builds on this machine compiled (docs/reliability.md, "CI's time").
. scripts/ccache-env.sh
if [ ! -f "build/$preset/CMakeCache.txt" ]; then
  cmake --preset "$preset" >/dev/null
fi
if [ $# -gt 0 ]; then
  cmake --build --preset "$preset" --target "$@"
else
  cmake --build --preset "$preset"
fi
