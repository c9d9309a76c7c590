#!/usr/bin/env bash
# Installs every Debian package that rtukit's build, tests, benchmarks and
# fuzzers need. Idempotent: packages already present are not reinstalled and
# `apt-get update` runs only when something is missing.
# Usage: scripts/setup.sh            (as root, or with sudo available)
#        scripts/setup.sh aarch64    also the RK3588 cross build: Debian's aarch64 cross compiler,
#                                    arm64 multiarch libraries, qemu-user with binfmt_misc, so the
#                                    aarch64 test binaries (and the programs they start) run here
set -euo pipefail
target="${1:-}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

PACKAGES=(
  # build
  cmake ninja-build g++ clang clang-format libclang-rt-14-dev pkg-config
  # libraries we use instead of writing them
  libcli11-dev libfmt-dev nlohmann-json3-dev libspdlog-dev libyaml-cpp-dev
  # packaging: man page, .deb contents check
  help2man dpkg-dev file
  libgtest-dev libgmock-dev libbenchmark-dev
  # Cortex-M cross compile check of core
  gcc-arm-none-eabi libstdc++-arm-none-eabi-newlib binutils-arm-none-eabi
  # interop peers we did not write, and the pty pair maker
  libmodbus-dev python3-pymodbus python3-serial python3-serial-asyncio mbpoll socat
  # the sniffer's pcap files, decoded by Wireshark's dissector
  tshark
  # the event loop of io/, driver/, cli/ and web/ (Boost.Asio, header-only), the web layer (Boost.Beast,
  # header-only; TLS listeners on OpenSSL) and its pages tested in a real browser
  libboost-dev libssl-dev libqrencode-dev chromium chromium-driver python3-selenium zbar-tools
  # the Inverjet MQTT bridge (libmosquitto) and its tests (a real broker and its clients)
  libmosquitto-dev mosquitto mosquitto-clients
  # the Rehand host daemon's Bluetooth LE link (BlueZ over D-Bus) and its tests: a private bus with a
  # mock BlueZ (python3-dbusmock's bluez5 template)
  libsdbus-c++-dev dbus-daemon python3-dbus python3-dbusmock python3-gi
)
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

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} packages present"
  register_binfmt
  exit 0
fi

echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
register_binfmt
echo "setup: done"
