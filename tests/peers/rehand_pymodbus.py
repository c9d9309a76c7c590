#!/usr/bin/python3
"""pymodbus, as a host would, reads table 1 and writes table 2 of the
simulated Rehand 6600 controller (unit 1, 115200 8N1).

usage: rehand_pymodbus.py DEVICE
Prints OK and exits 0; else the failed check, exit 1.
"""
import sys
import time

from pymodbus.client import ModbusSerialClient

UNIT = 1


def check(cond, what):
    if not cond:
        print("rehand_pymodbus: failed: " + what, file=sys.stderr)
        sys.exit(1)


def main():
    client = ModbusSerialClient(port=sys.argv[1], baudrate=115200, timeout=1)
    check(client.connect(), "connect")
    r = client.read_holding_registers(0x0000, 48, slave=UNIT)
    check(not r.isError() and len(r.registers) == 48, "read table 1: %s" % r)
    check(r.registers[0] == 0x68, "device ID 0x68: %s" % r.registers[0])
    check(r.registers[1] == 80 and r.registers[5] == 1, "battery 80, static: %s" % r.registers[:6])

    r = client.write_register(0x0063, 1, slave=UNIT)  # seat lift up (hold)
    check(not r.isError(), "hold seat lift: %s" % r)
    deadline = time.monotonic() + 3
    lifted = False
    while time.monotonic() < deadline and not lifted:  # polling also feeds the watchdog
        r = client.read_holding_registers(0x0010, 6, slave=UNIT)
        lifted = not r.isError() and r.registers[0] == 1 and r.registers[5] > 0
        time.sleep(0.05)
    check(lifted, "seat rising, actuator 1 moving: %s" % r)
    r = client.write_register(0x0063, 0, slave=UNIT)
    check(not r.isError(), "release: %s" % r)

    r = client.write_registers(0x0060, [3, 1], slave=UNIT)  # outdoor + light pulse (rising edge)
    check(not r.isError(), "write drive mode and light: %s" % r)
    r = client.read_holding_registers(0x000D, 1, slave=UNIT)
    check(not r.isError() and r.registers == [1], "main light on: %s" % r)

    r = client.write_register(0x0060, 4, slave=UNIT)
    check(r.isError() and getattr(r, "exception_code", None) == 3, "drive mode 4 -> exception 03: %s" % r)
    r = client.read_holding_registers(0x0060, 1, slave=UNIT)
    check(r.isError() and getattr(r, "exception_code", None) == 2, "table 2 read -> exception 02: %s" % r)
    r = client.write_register(0x0001, 50, slave=UNIT)
    check(r.isError() and getattr(r, "exception_code", None) == 2, "table 1 write -> exception 02: %s" % r)
    client.close()
    print("OK")


if __name__ == "__main__":
    main()
