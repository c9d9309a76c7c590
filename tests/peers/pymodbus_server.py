#!/usr/bin/python3
"""A pymodbus server for interop tests: the same data as libmodbus_server.

usage: pymodbus_server.py rtu DEVICE | tcp PORT
holding i = 10*i, input i = 1000+i, coil i = i%2, discrete i = (i+1)%2 (i < 200), unit 1.
Identification: vendor "pymodbus", product code "PM", revision "3.0".
"""
import sys

from pymodbus.datastore import ModbusSequentialDataBlock, ModbusServerContext, ModbusSlaveContext
from pymodbus.device import ModbusDeviceIdentification
from pymodbus.server import StartSerialServer, StartTcpServer
from pymodbus.transaction import ModbusRtuFramer


def main():
    mode, target = sys.argv[1], sys.argv[2]
    unit = ModbusSlaveContext(
        hr=ModbusSequentialDataBlock(0, [10 * i for i in range(200)]),
        ir=ModbusSequentialDataBlock(0, [1000 + i for i in range(200)]),
        co=ModbusSequentialDataBlock(0, [i % 2 for i in range(200)]),
        di=ModbusSequentialDataBlock(0, [(i + 1) % 2 for i in range(200)]),
        zero_mode=True,
    )
    context = ModbusServerContext(slaves={1: unit}, single=False)
    identity = ModbusDeviceIdentification(
        info_name={"VendorName": "pymodbus", "ProductCode": "PM", "MajorMinorRevision": "3.0"})
    print("ready", flush=True)
    if mode == "rtu":
        StartSerialServer(context=context, framer=ModbusRtuFramer, port=target, baudrate=9600, timeout=0.005,
                          identity=identity)
    else:
        StartTcpServer(context=context, address=("127.0.0.1", int(target)), identity=identity)


if __name__ == "__main__":
    main()
