#!/bin/bash
# The board's systemd units (packaging/rk3588/) as systemd itself reads them:
#  - both pass `systemd-analyze verify`: every directive known, the programs
#    they start present (the built rtukit stands in for /usr/bin/rtukit;
#    cage and chromium are Debian's), with no diagnostic at all (an unknown
#    key is only a warning to systemd: here it fails);
#  - the daemon's passes `systemd-analyze security` at "OK" or better
#    (overall exposure at most 4.9: --threshold=49). The unit before issue 37
#    scored 8.2, "EXPOSED", and failed this.
# Usage: units.sh RTUKIT_BINARY SOURCE_DIR
set -euo pipefail
rtukit=$(realpath "$1")
units=$2/packaging/rk3588
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
sed "s#/usr/bin/rtukit#${rtukit}#" "$units/rtukit-rehand6600-host.service" >"$work/rtukit-rehand6600-host.service"
cp "$units/rtukit-rehand6600-kiosk.service" "$work/"
cd "$work"
if ! out=$(systemd-analyze verify --man=no ./rtukit-rehand6600-host.service ./rtukit-rehand6600-kiosk.service 2>&1) ||
  [ -n "$out" ]; then
  echo "systemd-analyze verify: $out"
  exit 1
fi
echo "verify: both units clean"
if ! systemd-analyze security --offline=yes --threshold=49 ./rtukit-rehand6600-host.service >security.txt 2>&1; then
  grep -E "✗|Overall" security.txt
  echo "the host daemon's unit is above exposure 4.9 (systemd-analyze security's \"OK\")"
  exit 1
fi
grep "Overall" security.txt
