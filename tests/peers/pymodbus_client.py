#!/usr/bin/python3
"""A pymodbus client that exercises a server as the interop tests expect.

usage: pymodbus_client.py rtu DEVICE | tcp PORT
Prints OK and exits 0 when every check passes; else the failed check, exit 1.
"""
import sys

from pymodbus.client import ModbusSerialClient, ModbusTcpClient


def check(cond, what):
    if not cond:
        print("pymodbus_client: failed: " + what, file=sys.stderr)
        sys.exit(1)


def main():
    mode, target = sys.argv[1], sys.argv[2]
    if mode == "rtu":
        client = ModbusSerialClient(port=target, baudrate=9600, timeout=2)
    else:
        client = ModbusTcpClient("127.0.0.1", port=int(target), timeout=2)
    check(client.connect(), "connect")
    r = client.write_register(5, 1234, slave=1)
    check(not r.isError(), "write_register: %s" % r)
    r = client.read_holding_registers(5, 1, slave=1)
    check(not r.isError() and r.registers == [1234], "read back 1234: %s" % r)
    r = client.write_registers(10, [1, 2, 65535], slave=1)
    check(not r.isError(), "write_registers: %s" % r)
    r = client.read_holding_registers(10, 3, slave=1)
    check(not r.isError() and r.registers == [1, 2, 65535], "read back 1 2 65535: %s" % r)
    r = client.write_coils(20, [True, False, True, True], slave=1)
    check(not r.isError(), "write_coils: %s" % r)
    r = client.read_coils(20, 4, slave=1)
    check(not r.isError() and r.bits[:4] == [True, False, True, True], "read_coils: %s" % r)
    r = client.read_input_registers(0, 2, slave=1)
    check(not r.isError() and len(r.registers) == 2, "read_input_registers: %s" % r)
    r = client.read_holding_registers(65000, 10, slave=1)
    check(r.isError() and getattr(r, "exception_code", None) == 2, "exception 02 expected: %s" % r)
    # FC16 mask write and FC17 read/write multiple (issue 14). Debian's
    # pymodbus 3.0 builds these two requests with `unit=`, not `slave=`
    # (with slave= they go to unit 0: a broadcast on RTU, rightly unanswered).
    check(not client.write_register(50, 0x12, slave=1).isError(), "write 50")
    r = client.mask_write_register(address=50, and_mask=0x00F2, or_mask=0x0025, unit=1)
    check(not r.isError(), "mask_write_register: %s" % r)
    r = client.read_holding_registers(50, 1, slave=1)
    check(not r.isError() and r.registers == [0x17], "mask result 0x17: %s" % r)
    r = client.readwrite_registers(read_address=59, read_count=3, write_address=60, write_registers=[7, 8], unit=1)
    check(not r.isError() and r.registers == [0, 7, 8], "readwrite_registers, the write first: %s" % r)
    client.close()
    print("OK")


if __name__ == "__main__":
    main()
