#!/usr/bin/python3
"""The Rehand 6600's stop paths, timed over many cycles: from each cause to
the write that makes the controller safe reaching it, end to end through the
daemon and `rtukit relay` (tests/rehand_stops.py says how each is measured).

Usage: bench/rehand_stop_bench.py RTUKIT [--cycles N] [--busy]
  --busy  one busy loop beside the run (as scripts/busy.sh): the other core taken
Prints a Markdown table (p50 / p99 / max, ms) for bench/README.md and
docs/rehand6600.md. Not a test: figures, no verdict (the bounds are
tests/faults/rehand_stop_paths.py's).
"""
import os
import subprocess
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests"))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "ble"))
from pyhelpers import pct, temp_dir  # noqa: E402
import rehand_stops as stops  # noqa: E402
from bluez_mock import MockBluez  # noqa: E402

RTUKIT = sys.argv[1]
CYCLES = int(sys.argv[sys.argv.index("--cycles") + 1]) if "--cycles" in sys.argv else 50
BUSY = "--busy" in sys.argv


def main():
    busy = subprocess.Popen(["bash", "-c", "while :; do :; done"]) if BUSY else None
    work = temp_dir("rtukit-stop-bench-")
    bluez = MockBluez(work)
    chair = stops.Chair(RTUKIT, work, bluez)
    rows = {name: [] for name in ("release", "lost release", "answers lost (1010)", "phone silent",
                                  "phone connection dropped", "STOP on the display", "Bluetooth phone silent",
                                  "Bluetooth phone disconnected")}
    try:
        display = chair.display()
        ble = stops.BlePhone(chair)
        press = iter(range(1, 100000))
        for _ in range(CYCLES):
            for name, run in (("release", lambda: stops.release(chair, display, next(press))),
                              ("lost release", lambda: stops.lost_release(chair, display, next(press))),
                              ("answers lost (1010)", lambda: stops.answers_lost(chair, display, next(press))),
                              ("phone silent", lambda: stops.phone_silent(chair, chair.phone(), next(press))),
                              ("phone connection dropped", lambda: stops.tcp_dropped(chair, chair.phone(), next(press))),
                              ("STOP on the display",
                               lambda: stops.display_stop(chair, chair.phone(), display, next(press))),
                              ("Bluetooth phone silent", lambda: stops.ble_silent(chair, ble, next(press))),
                              ("Bluetooth phone disconnected", lambda: stops.ble_disconnect(chair, ble, next(press)))):
                ms = run()
                if ms is not None:
                    rows[name].append(ms)
                if not chair.ready(20):
                    raise RuntimeError(f"not ready after {name}")
    finally:
        chair.stop()
        bluez.stop()
        if busy:
            busy.kill()
            busy.wait()
    print(f"{CYCLES} cycles, {'one core busy' if BUSY else 'idle'}; daemon defaults (20 Hz, 200-ms timeout, "
          f"300-ms lease); pty at 115200 baud through the relay; Bluetooth through the mock BlueZ "
          f"(tests/ble/bluez_mock.py, D-Bus, no radio)")
    print()
    print("| path | from | to | p50 | p99 | max | samples |")
    print("|---|---|---|---|---|---|---|")
    frm = {"release": "the release sent", "lost release": "the 0 lost", "answers lost (1010)": "answers lost",
           "phone silent": "the last renewal", "phone connection dropped": "the socket closed",
           "STOP on the display": "STOP sent", "Bluetooth phone silent": "the last renewal",
           "Bluetooth phone disconnected": "BlueZ: disconnected"}
    for name, xs in rows.items():
        to = "0x006A = 1 arrives" if name.startswith(("phone", "STOP", "Bluetooth")) else "the 0 arrives"
        print(f"| {name} | {frm[name]} | {to} | {pct(xs, 50):.0f} | {pct(xs, 99):.0f} | {max(xs):.0f} | {len(xs)} |")


if __name__ == "__main__":
    main()
