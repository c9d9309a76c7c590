#!/usr/bin/python3
"""Bluetooth LE latency of the Rehand 6600 host daemon (`rtukit rehand6600
host --ble`), against the mock BlueZ of the tests (tests/ble/bluez_mock.py)
on a private system bus, with the simulated controller on a pty:

  write -> register: from a bonded phone's WriteValue of a press (forward)
      to the command register (phone_forward) reading 1 in the simulated
      controller (its console, polled every 0.2 ms or so);
  change -> notify: from a change on the controller (the battery, through
      its console, at a random moment of the 50-ms poll period) to the state
      notification that carries it.

The radio is not in it (no Bluetooth here): add the connection interval of
the real link (7.5..50 ms, the phone's choice) to both. A documented run,
not a CI test. Usage: bench/ble_latency.py RTUKIT [ROUNDS]
"""
import os
import random
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests"))
sys.path.insert(0, os.path.join(HERE, "..", "tests", "browser"))
sys.path.insert(0, os.path.join(HERE, "..", "tests", "ble"))
from pyhelpers import START_DEADLINE, connect_tcp, free_port, pct, stop_processes, temp_dir  # noqa: E402
from bluez_mock import MockBluez  # noqa: E402
from rehand_ble_scenarios import (COMMAND, FORWARD, PRESS, RELEASE, STATE, command, display_request,  # noqa: E402
                                  register, start_chair)

RTUKIT = sys.argv[1]
ROUNDS = int(sys.argv[2]) if len(sys.argv) > 2 else 200
PHONE = "AA:BB:CC:DD:EE:07"


def main():
    work = temp_dir("rtukit-blebench-")
    port = free_port()
    procs = []
    bluez = MockBluez(work)
    try:
        con, _, _ = start_chair(bluez, work, port, procs)
        assert bluez.pump(START_DEADLINE, lambda: bluez.app is not None and bluez.advertisement is not None)
        connect_tcp(port).close()
        display_request(port, {"op": "pair_start"})
        bluez.add_phone(PHONE, "Bench")
        bluez.connect(PHONE)
        bluez.pump(0.2)
        bluez.display_passkey(PHONE, 123456)
        bluez.bond(PHONE)
        display_request(port, {"op": "pair_cancel"})
        display_request(port, {"op": "confirm", "phone": f"ble:{PHONE}"})  # allowed to drive
        bluez.pump(0.5)
        bluez.start_notify(STATE)
        state_path = bluez.characteristic(STATE)

        write_to_register = []
        for n in range(1, ROUNDS + 1):
            t0 = time.perf_counter()
            bluez.write(PHONE, COMMAND, command(PRESS, FORWARD, 2 * n - 1, n))
            while register(con, "phone_forward") != 1:
                if time.perf_counter() - t0 > START_DEADLINE:
                    raise SystemExit(f"press {n} never reached the controller")
            write_to_register.append((time.perf_counter() - t0) * 1000)
            bluez.write(PHONE, COMMAND, command(RELEASE, FORWARD, 2 * n - 1, n))
            while register(con, "phone_forward") != 0:
                pass
            bluez.pump(0.0)

        change_to_notify = []
        for n in range(ROUNDS):
            level = 40 + n % 2
            # A change comes at any moment of the poll period (50 ms), not right after a notification.
            bluez.pump(random.uniform(0, 0.05))
            bluez.notified.clear()
            t0 = time.perf_counter()
            con.ask(f"battery {level}")
            if not bluez.pump(START_DEADLINE, lambda: any(p == state_path and v[2] == level
                                                          for p, v in bluez.notified)):
                raise SystemExit(f"change {n} was never notified")
            change_to_notify.append((time.perf_counter() - t0) * 1000)

        for name, xs in (("write -> register", write_to_register), ("change -> notify", change_to_notify)):
            print(f"{name}: n={len(xs)} p50={pct(xs, 50):.2f} ms p99={pct(xs, 99):.2f} ms max={max(xs):.2f} ms")
    finally:
        stop_processes(procs)
        bluez.stop()


if __name__ == "__main__":
    main()
