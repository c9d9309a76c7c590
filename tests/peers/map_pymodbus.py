#!/usr/bin/python3
"""pymodbus as the master of the example energy-meter map served by `rtukit sim map`.

usage: map_pymodbus.py DEVICE
Prints OK and exits 0 when the simulated device validates exactly as the map
says; else the failed check, exit 1.
"""
import sys

from pymodbus.client import ModbusSerialClient


def check(cond, what):
    if not cond:
        print("map_pymodbus: failed: " + what, file=sys.stderr)
        sys.exit(1)


def exception(r, code, what):
    check(r.isError() and getattr(r, "exception_code", None) == code, "%s: exception %d expected: %s" % (what, code, r))


def main():
    client = ModbusSerialClient(port=sys.argv[1], baudrate=9600, timeout=2)
    check(client.connect(), "connect")
    r = client.read_input_registers(0, 1, slave=1)
    check(not r.isError() and r.registers == [2300], "voltage 230.0 V as 2300: %s" % r)
    r = client.write_register(3, 50, slave=1)
    check(not r.isError(), "ct_ratio 50: %s" % r)
    r = client.read_holding_registers(0, 4, slave=1)
    check(not r.isError() and r.registers == [1, 2, 900, 50], "settings read back: %s" % r)
    exception(client.write_register(3, 0, slave=1), 3, "ct_ratio 0 (range 1..9999)")
    exception(client.write_register(1, 7, slave=1), 3, "baud code 7 (not a listed value)")
    exception(client.read_holding_registers(0, 5, slave=1), 2, "read past the last setting (gap)")
    exception(client.write_register(0x10, 1, slave=1), 2, "write where no holding register is")
    # All or nothing: the bad demand period (30 s < 60 s) refuses the whole FC10.
    exception(client.write_registers(2, [30, 20], slave=1), 3,
              "FC10 with one bad value")
    r = client.read_holding_registers(2, 2, slave=1)
    check(not r.isError() and r.registers == [900, 50], "nothing written by the refused FC10: %s" % r)
    r = client.write_coil(0, True, slave=1)
    check(not r.isError(), "relay on: %s" % r)
    r = client.read_coils(0, 1, slave=1)
    check(not r.isError() and r.bits[0], "relay reads on: %s" % r)
    exception(client.read_coils(0, 2, slave=1), 2, "coil 1 does not exist")
    r = client.read_discrete_inputs(0, 1, slave=1)
    check(not r.isError() and not r.bits[0], "tamper off: %s" % r)
    client.close()
    print("OK")


if __name__ == "__main__":
    main()
