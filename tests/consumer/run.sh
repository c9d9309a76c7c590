#!/usr/bin/env bash
# Installs the build tree into a temporary prefix and builds the consumer
# project against it twice: with find_package(rtukit) and with pkg-config.
# Usage: tests/consumer/run.sh BUILD_DIR   (exit 0 = both consumers built and ran)
set -euo pipefail
build="$1"
here="$(cd "$(dirname "$0")" && pwd)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cmake --install "$build" --prefix "$work/prefix" >/dev/null
test -f "$work/prefix/lib/cmake/rtukit/rtukitConfig.cmake"
test -f "$work/prefix/include/rtukit/driver/master.hpp"

echo "--- find_package(rtukit)"
cmake -S "$here" -B "$work/cmake" -G Ninja -DCMAKE_PREFIX_PATH="$work/prefix" >/dev/null
cmake --build "$work/cmake" >/dev/null
"$work/cmake/consumer"

echo "--- pkg-config"
export PKG_CONFIG_PATH="$work/prefix/lib/pkgconfig"
pkg-config --exists rtukit
# shellcheck disable=SC2046
g++ -o "$work/consumer-pc" "$here/main.cpp" $(pkg-config --cflags --libs rtukit)
"$work/consumer-pc"
echo "consumer: ok (rtukit $(pkg-config --modversion rtukit))"
