#!/usr/bin/env bash
# Builds the Debian packages (rtukit, librtukit-dev) from a release build,
# lists and checks their contents, and with --install installs them with
# dpkg -i and runs the packaged tool.
# Usage: scripts/package.sh [--install] [BUILD_DIR]
#   BUILD_DIR: an existing Release build to package (CI passes its plain
#   Release build); without it, build/package is configured and built here.
set -euo pipefail
cd "$(dirname "$0")/.."
install=no
if [ "${1:-}" = "--install" ]; then install=yes; shift; fi
build="${1:-}"
scripts/setup.sh
if [ -z "$build" ]; then
  build=build/package
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX=/usr \
    -DRTUKIT_BUILD_TESTS=OFF -DRTUKIT_BUILD_BENCH=OFF >/dev/null
  cmake --build "$build"
fi
rm -f "$build"/*.deb
(cd "$build" && cpack -G DEB >/dev/null)
tool=$(ls "$build"/rtukit_*.deb)
dev=$(ls "$build"/librtukit-dev_*.deb)
echo "packages: $tool $dev"

# The tool: binary, man page, completion; the dev package: headers, libraries, CMake and pkg-config files.
check() {  # check PACKAGE PATTERN...   (extended regex, anchored at the end of the path)
  local list
  list=$(dpkg-deb -c "$1")
  shift
  for pattern in "$@"; do
    grep -qE -- "$pattern\$" <<<"$list" || { echo "missing in the package: $pattern"; exit 1; }
  done
}
check "$tool" ./usr/bin/rtukit ./usr/share/man/man1/rtukit.1 ./usr/share/bash-completion/completions/rtukit \
  ./usr/share/zsh/vendor-completions/_rtukit
check "$dev" ./usr/include/rtukit/core/slave.hpp ./usr/include/rtukit/driver/master.hpp \
  ./usr/include/rtukit/devices/profile/schema.hpp './usr/lib/([a-z0-9_-]+/)?librtukit_core\.a' \
  './usr/lib/([a-z0-9_-]+/)?cmake/rtukit/rtukitConfig\.cmake' './usr/lib/([a-z0-9_-]+/)?pkgconfig/rtukit\.pc'
dpkg-deb -f "$tool" Package Version Depends
dpkg-deb -f "$dev" Package Version Depends
echo "contents: ok"

if [ "$install" = yes ]; then
  dpkg -i "$tool" "$dev" >/dev/null
  rtukit --version
  pkg-config --modversion rtukit
  man -w rtukit >/dev/null 2>&1 || test -f /usr/share/man/man1/rtukit.1
  # Leave the machine as it was: installed headers in /usr/include would be
  # found by later builds of this tree for a header it no longer has.
  dpkg -r rtukit librtukit-dev >/dev/null
  echo "installed, ran, removed: ok"
fi
