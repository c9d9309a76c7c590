#!/usr/bin/env bash
# Installs what is missing (scripts/setup.sh), configures and builds a preset.
# Usage: scripts/build.sh [PRESET]   (default: default)
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${1:-default}"
scripts/setup.sh
if [ ! -f "build/$preset/CMakeCache.txt" ]; then
  cmake --preset "$preset" >/dev/null
fi
cmake --build --preset "$preset"
