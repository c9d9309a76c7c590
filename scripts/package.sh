#!/usr/bin/env bash
# Builds the Debian packages (rtukit, librtukit-dev) from a release build,
# lists and checks their contents, and with --install installs them with
# dpkg -i and runs the packaged tool.
# Usage: scripts/package.sh [--aarch64] [--install] [BUILD_DIR]
#   BUILD_DIR: an existing Release build to package (CI passes its plain
#   Release build); without it, build/package is configured and built here.
#   --aarch64: the arm64 packages for the RK3588, cross-built in
#   build/package-aarch64 (cmake/aarch64-linux-gnu.cmake); with --install
#   they are installed here as arm64 packages (multiarch) and the packaged
#   tool runs under qemu-aarch64.
set -euo pipefail
cd "$(dirname "$0")/.."
arch=$(dpkg --print-architecture)
if [ "${1:-}" = "--aarch64" ]; then arch=arm64; shift; fi
install=no
if [ "${1:-}" = "--install" ]; then install=yes; shift; fi
build="${1:-}"
if [ "$arch" = arm64 ]; then scripts/setup.sh aarch64; else scripts/setup.sh; fi
if [ -z "$build" ]; then
  build=build/package
  cross=()
  if [ "$arch" = arm64 ]; then
    build=build/package-aarch64
    cross=(-DCMAKE_TOOLCHAIN_FILE="$PWD/cmake/aarch64-linux-gnu.cmake")
  fi
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX=/usr \
    -DRTUKIT_BUILD_TESTS=OFF -DRTUKIT_BUILD_BENCH=OFF "${cross[@]}" >/dev/null
  cmake --build "$build"
fi
rm -f "$build"/*.deb
# dpkg-shlibdeps finds the libraries of the package's architecture (arm64:
# /usr/lib/aarch64-linux-gnu) and names their packages in Depends.
(cd "$build" && DEB_HOST_ARCH="$arch" cpack -G DEB >/dev/null)
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
  ./usr/share/zsh/vendor-completions/_rtukit ./usr/share/rtukit/rehand6600-phone-app/app.html \
  ./usr/share/rtukit/rehand6600-phone-app/gatt.js ./usr/share/rtukit/rehand6600-phone-app/chair-text.js
check "$dev" ./usr/include/rtukit/core/slave.hpp ./usr/include/rtukit/driver/master.hpp \
  ./usr/include/rtukit/devices/profile/schema.hpp './usr/lib/([a-z0-9_-]+/)?librtukit_core\.a' \
  './usr/lib/([a-z0-9_-]+/)?cmake/rtukit/rtukitConfig\.cmake' './usr/lib/([a-z0-9_-]+/)?pkgconfig/rtukit\.pc'
dpkg-deb -f "$tool" Package Version Architecture Depends
dpkg-deb -f "$dev" Package Version Architecture Depends
for deb in "$tool" "$dev"; do
  [ "$(dpkg-deb -f "$deb" Architecture)" = "$arch" ] || { echo "$deb is not for $arch"; exit 1; }
done
file -b "$build/cli/rtukit"
echo "contents: ok"

if [ "$install" = yes ] && [ "$arch" = arm64 ] && [ "$arch" != "$(dpkg --print-architecture)" ]; then
  # The tool only: librtukit-dev:arm64 would want libyaml-cpp-dev:arm64,
  # which cannot sit beside the build machine's (not multi-arch in Debian 12).
  dpkg -i "$tool" >/dev/null
  rtukit --version  # the arm64 binary, run by qemu-aarch64 through binfmt_misc
  rtukit inverjet registers | head -n 3
  dpkg -r rtukit >/dev/null
  echo "installed (arm64), ran under qemu, removed: ok"
elif [ "$install" = yes ]; then
  dpkg -i "$tool" "$dev" >/dev/null
  rtukit --version
  pkg-config --modversion rtukit
  man -w rtukit >/dev/null 2>&1 || test -f /usr/share/man/man1/rtukit.1
  # Leave the machine as it was: installed headers in /usr/include would be
  # found by later builds of this tree for a header it no longer has.
  dpkg -r rtukit librtukit-dev >/dev/null
  echo "installed, ran, removed: ok"
fi
