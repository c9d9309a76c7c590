#!/usr/bin/python3
"""pymodbus drives the simulated Inverjet through a timer-mode run.

usage: inverjet_pymodbus_run.py DEVICE   (the simulator at unit 21, 9600 8N1,
best run with --time-scale 10 so the frozen-time check is quick)
Start (FC10 mode/state/speed/time), read state and time, pause, check the
time is frozen, resume, stop. Prints OK and exits 0; else the failed check, exit 1.
"""
import sys
import time

from pymodbus.client import ModbusSerialClient

UNIT = 21


def check(cond, what):
    if not cond:
        print("inverjet_pymodbus_run: failed: " + what, file=sys.stderr)
        sys.exit(1)


def read_block(client):
    r = client.read_holding_registers(0x21, 4, slave=UNIT)
    check(not r.isError(), "read 0x0021 x4: %s" % r)
    return r.registers  # mode, state, speed, time


def main():
    client = ModbusSerialClient(port=sys.argv[1], baudrate=9600, timeout=2)
    check(client.connect(), "connect")
    r = client.write_registers(0x21, [0, 8, 60, 600], slave=UNIT)  # timer running, 60 %, 10:00
    check(not r.isError(), "start timer: %s" % r)
    mode, state, speed, left = read_block(client)
    check(mode == 0 and state in (7, 8) and speed == 60 and 0 < left <= 600,
          "timer started: %s" % [mode, state, speed, left])

    r = client.write_register(0x22, 9, slave=UNIT)  # timer paused
    check(not r.isError(), "pause: %s" % r)
    _, state, _, t1 = read_block(client)
    check(state == 9, "paused: state %d" % state)
    time.sleep(0.3)  # several device seconds at --time-scale 10
    _, state, _, t2 = read_block(client)
    check(state == 9 and t2 == t1, "time frozen while paused: %d then %d" % (t1, t2))

    r = client.write_register(0x22, 8, slave=UNIT)  # timer running again
    check(not r.isError(), "resume: %s" % r)
    deadline = time.monotonic() + 5
    while True:
        _, state, _, t3 = read_block(client)
        if t3 < t1 or time.monotonic() > deadline:
            break
        time.sleep(0.05)
    check(state in (7, 8) and t3 < t1, "counting down again: state %d, %d -> %d" % (state, t1, t3))

    r = client.write_register(0x22, 0, slave=UNIT)  # off
    check(not r.isError(), "stop: %s" % r)
    check(read_block(client)[1] == 0, "off after stop")
    r = client.read_input_registers(0x08, 1, slave=UNIT)
    check(not r.isError() and r.registers == [0], "no faults: %s" % r)
    r = client.write_register(0x23, 101, slave=UNIT)
    check(r.isError() and getattr(r, "exception_code", None) == 3, "speed 101 -> exception 03: %s" % r)
    client.close()
    print("OK")


if __name__ == "__main__":
    main()
