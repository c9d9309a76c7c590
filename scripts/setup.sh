#!/usr/bin/env bash
# Installs the Debian packages a command of rtukit needs, and only those.
# Idempotent: packages already present are not reinstalled and
# `apt-get update` runs only when something is missing.
# Usage: scripts/setup.sh [PURPOSE]   (as root, or with sudo available)
#   programs  what building the programs needs (the compiler, CMake, the
#             libraries they link): the demo (scripts/demo.sh) asks for this
#   all       (the default) also what the tests, benchmarks, fuzzers, packages
#             and the Cortex-M check need: the peers we did not write
#             (libmodbus, pymodbus, mbpoll, tshark, Mosquitto, Chromium,
#             python3-dbusmock), GoogleTest, Benchmark, clang: scripts/test.sh
#   aarch64   all, and the RK3588 cross build: Debian's aarch64 cross compiler,
#             arm64 multiarch libraries, qemu-user with binfmt_misc, so the
#             aarch64 test binaries (and the programs they start) run here
set -euo pipefail
target="${1:-all}"
case "$target" in
  programs | all | aarch64) ;;
  *)
    echo "setup: unknown purpose '$target' (programs, all or aarch64)" >&2
    exit 2
    ;;
esac
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

PACKAGES=(
  # build (ccache: a clone elsewhere reuses this machine's compiles, scripts/ccache-env.sh;
  # mold: links four times faster than ld, CMakeLists.txt)
  cmake ninja-build g++ pkg-config ccache mold
  # libraries we use instead of writing them: the command line, formatting, JSON, logs, YAML profiles,
  # the event loop (Boost.Asio) and the web layer (Boost.Beast, both header-only), TLS (OpenSSL), the
  # pairing QR code, the MQTT bridge (libmosquitto), Bluetooth LE (BlueZ over D-Bus)
  libcli11-dev libfmt-dev nlohmann-json3-dev libspdlog-dev libyaml-cpp-dev
  libboost-dev libssl-dev libqrencode-dev libmosquitto-dev libsdbus-c++-dev
)
if [ "$target" != "programs" ]; then PACKAGES+=(
  # the clang builds (warnings, fuzzers), the format check
  clang clang-format libclang-rt-14-dev
  # packaging: the .deb contents check
  dpkg-dev file
  # the man page read by groff with every warning on (CliUsability)
  groff-base
  libgtest-dev libgmock-dev libbenchmark-dev
  # Cortex-M cross compile check of core
  gcc-arm-none-eabi libstdc++-arm-none-eabi-newlib binutils-arm-none-eabi
  # interop peers we did not write, and the pty pair maker
  libmodbus-dev python3-pymodbus python3-serial python3-serial-asyncio mbpoll socat
  # the sniffer's pcap files, decoded by Wireshark's dissector
  tshark
  # the web pages tested in a real browser (and the pairing QR code read back)
  chromium chromium-driver python3-selenium zbar-tools
  # the board's systemd units checked by systemd-analyze (verify, security); the kiosk unit starts cage
  systemd cage
  # the Inverjet MQTT bridge's tests: a real broker and its clients
  mosquitto mosquitto-clients
  # the Bluetooth LE tests: a private bus with a mock BlueZ (python3-dbusmock's bluez5 template)
  dbus-daemon python3-dbus python3-dbusmock python3-gi
); fi
if [ "$target" = "aarch64" ]; then
  if ! dpkg --print-foreign-architectures | grep -qx arm64; then
    $SUDO dpkg --add-architecture arm64
    $SUDO apt-get update -qq
  fi
  PACKAGES+=(
    g++-aarch64-linux-gnu qemu-user qemu-user-binfmt
    libfmt-dev:arm64 libspdlog-dev:arm64 libgtest-dev:arm64 libgmock-dev:arm64 libqrencode-dev:arm64
    libmosquitto-dev:arm64 libboost-dev:arm64 libssl-dev:arm64 libmodbus-dev:arm64 libsdbus-c++-dev:arm64
    # Debian 12's libyaml-cpp-dev is not multi-arch: its arm64 runtime library only (CMakeLists.txt)
    libyaml-cpp0.7:arm64
  )
fi

# aarch64 programs run through qemu by the kernel (binfmt_misc), so a test
# that starts `rtukit` starts it under qemu too. Registered here because a
# container or CI machine has no systemd to do it.
register_binfmt() {
  [ "$target" = "aarch64" ] || return 0
  local misc=/proc/sys/fs/binfmt_misc
  [ -e "$misc/register" ] || $SUDO mount -t binfmt_misc binfmt_misc "$misc"
  if [ ! -e "$misc/qemu-aarch64" ]; then
    grep -v '^#' /usr/lib/binfmt.d/qemu-aarch64.conf | $SUDO tee "$misc/register" >/dev/null
  fi
  echo "setup: aarch64 binaries run under $(sed -n 's/^interpreter //p' "$misc/qemu-aarch64")"
}

# Test tooling from the npm registry, never shipped (all, aarch64): axe-core,
# which the browser tests run in every page (WCAG 2.2 A and AA), at the
# version tests/browser/package-lock.json pins. Installed once.
install_test_tooling() {
  [ "$target" != "programs" ] || return 0
  local dir
  dir="$(cd "$(dirname "$0")/.." && pwd)/tests/browser"
  [ -f "$dir/node_modules/axe-core/axe.min.js" ] && return 0
  if ! command -v npm >/dev/null 2>&1; then
    echo "setup: npm is needed for the browser tests' test tooling (axe-core): install Node.js and npm" >&2
    exit 1
  fi
  npm ci --prefix "$dir" --no-audit --no-fund >/dev/null
  echo "setup: test tooling installed in tests/browser/node_modules (axe-core)"
}

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} packages present"
  register_binfmt
  install_test_tooling
  exit 0
fi

echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
register_binfmt
install_test_tooling
echo "setup: done"
