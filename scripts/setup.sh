#!/usr/bin/env bash
# Installs every Debian package that rtukit's build, tests, benchmarks and
# fuzzers need. Idempotent: packages already present are not reinstalled and
# `apt-get update` runs only when something is missing.
# Usage: scripts/setup.sh            (as root, or with sudo available)
set -euo pipefail

PACKAGES=(
  # build
  cmake ninja-build g++ clang clang-format libclang-rt-14-dev pkg-config
  # libraries we use instead of writing them
  libasio-dev libcli11-dev libfmt-dev nlohmann-json3-dev libspdlog-dev libyaml-cpp-dev
  # packaging: man page, .deb contents check
  help2man dpkg-dev file
  libgtest-dev libgmock-dev libbenchmark-dev
  # Cortex-M cross compile check of core
  gcc-arm-none-eabi libstdc++-arm-none-eabi-newlib binutils-arm-none-eabi
  # interop peers we did not write, and the pty pair maker
  libmodbus-dev python3-pymodbus python3-serial python3-serial-asyncio mbpoll socat
  # the sniffer's pcap files, decoded by Wireshark's dissector
  tshark
  # the web layer (Boost.Beast, header-only) and its pages tested in a real browser
  libboost-dev libqrencode-dev chromium chromium-driver python3-selenium zbar-tools
  # the Inverjet MQTT bridge (libmosquitto) and its tests (a real broker and its clients)
  libmosquitto-dev mosquitto mosquitto-clients
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "setup: done"
