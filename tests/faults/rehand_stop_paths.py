#!/usr/bin/python3
"""Every stop path of the Rehand 6600 host daemon, end to end, each timed and
held to a bound: the release, a lost release, the answers lost for 400 ms, a
driving phone gone silent, its connection dropped, STOP on the display,
a phone over Bluetooth LE (the mock BlueZ) gone silent and disconnected
(tests/rehand_stops.py says how each is measured). The bound is the lease
plus one poll plus 500 ms for the machine (lease + 50 + 500 = 850 ms; 1300 ms
with RTUKIT_BUSY=1, scripts/test.sh --busy), never seconds; the answers-lost
path adds the three request timeouts (3 x 200 ms) after which the host calls
the link lost. Each figure is printed.

Usage: rehand_stop_paths.py RTUKIT
Prints "ok NAME N ms (bound B ms)" or "FAIL ..." per path; exits 1 when one failed.
Starts what it needs and stops it by PID.
"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, ".."))
sys.path.insert(0, os.path.join(HERE, "..", "browser"))
sys.path.insert(0, os.path.join(HERE, "..", "ble"))
from pyhelpers import temp_dir  # noqa: E402
from browser_common import check, summary  # noqa: E402
import rehand_stops as stops  # noqa: E402
from bluez_mock import MockBluez  # noqa: E402

RTUKIT = sys.argv[1]
BOUND = stops.LEASE_MS + stops.POLL_MS + (950 if os.environ.get("RTUKIT_BUSY") else 500)


def timed(name, ms, bound=BOUND):
    check(f"{name}: {ms:.0f} ms (bound {bound} ms)" if ms is not None else f"{name}: never",
          ms is not None and ms <= bound)


def main():
    work = temp_dir("rtukit-stops-")
    bluez = MockBluez(work)
    chair = stops.Chair(RTUKIT, work, bluez)
    try:
        display = chair.display()
        press = iter(range(1, 1000))
        timed("release", stops.release(chair, display, next(press)))
        check("ready after the release", chair.ready())
        timed("lost release, from the loss", stops.lost_release(chair, display, next(press)))
        check("ready after the lost release", chair.ready())
        timed("answers lost (1010), from the loss", stops.answers_lost(chair, display, next(press)),
              BOUND + 3 * stops.TIMEOUT_MS)
        check("ready after the answers came back", chair.ready())
        timed("phone silent, from its last renewal", stops.phone_silent(chair, chair.phone(), next(press)))
        check("the stop command held until still, then released", chair.ready())
        timed("phone connection dropped", stops.tcp_dropped(chair, chair.phone(), next(press)))
        check("ready after the dropped phone", chair.ready())
        timed("STOP on the display", stops.display_stop(chair, chair.phone(), display, next(press)))
        check("STOP lifted, released when still", chair.ready())
        ble = stops.BlePhone(chair)
        timed("Bluetooth phone silent, from its last renewal", stops.ble_silent(chair, ble, next(press)))
        check("ready after the silent Bluetooth phone", chair.ready())
        timed("Bluetooth phone disconnected", stops.ble_disconnect(chair, ble, next(press)))
        check("ready after the disconnected Bluetooth phone", chair.ready())
        display.close()
    finally:
        chair.stop()
        bluez.stop()
    return summary()


if __name__ == "__main__":
    sys.exit(main())
