#!/usr/bin/python3
"""pymodbus's diagnostic, identification and report-server-id requests
against a server (issue 14).

usage: pymodbus_diag.py rtu DEVICE | tcp PORT
Prints OK and exits 0 when every check passes; else the failed check, exit 1.
Debian's pymodbus 3.0 builds requests by class with `unit=`: its diag_*
helpers pass `slave` as the data field (08 00 0A 00 01), which a server
rightly answers 03.
"""
import sys

from pymodbus.client import ModbusSerialClient, ModbusTcpClient
from pymodbus.diag_message import (ClearCountersRequest, ReturnBusExceptionErrorCountRequest,
                                   ReturnBusMessageCountRequest, ReturnSlaveMessageCountRequest)
from pymodbus.mei_message import ReadDeviceInformationRequest
from pymodbus.other_message import (GetCommEventCounterRequest, GetCommEventLogRequest,
                                    ReadExceptionStatusRequest, ReportSlaveIdRequest)


def check(cond, what):
    if not cond:
        print("pymodbus_diag: failed: " + what, file=sys.stderr)
        sys.exit(1)


def counter(response):
    """The 16-bit value of an FC08 counter response (a list in pymodbus 3.0)."""
    m = response.message
    return m[0] if isinstance(m, (list, tuple)) else m


def main():
    mode, target = sys.argv[1], sys.argv[2]
    if mode == "rtu":
        client = ModbusSerialClient(port=target, baudrate=9600, timeout=2)
    else:
        client = ModbusTcpClient("127.0.0.1", port=int(target), timeout=2)
    check(client.connect(), "connect")
    r = client.diag_query_data(0xA537, slave=1)
    check(not r.isError() and list(r.message) == [0xA537], "return query data: %r" % (r.message,))
    r = client.execute(ClearCountersRequest(unit=1))
    check(not r.isError(), "clear counters: %s" % r)
    r = client.read_holding_registers(0, 1, slave=1)
    check(not r.isError(), "a read: %s" % r)
    r = client.execute(ReturnBusMessageCountRequest(unit=1))
    check(not r.isError() and counter(r) == 2, "bus message count 2 (the read, this): %r" % counter(r))
    r = client.execute(ReturnSlaveMessageCountRequest(unit=1))
    check(not r.isError() and counter(r) == 3, "server message count 3: %r" % counter(r))
    r = client.execute(ReturnBusExceptionErrorCountRequest(unit=1))
    check(not r.isError() and counter(r) == 0, "exception count 0: %r" % counter(r))
    r = client.execute(ReadExceptionStatusRequest(unit=1))
    check(not r.isError() and r.status == 0, "read exception status: %s" % r)
    r = client.execute(GetCommEventCounterRequest(unit=1))
    check(not r.isError() and r.count > 0, "comm event counter: %s" % r)
    r = client.execute(GetCommEventLogRequest(unit=1))
    check(not r.isError() and len(r.events) > 0, "comm event log: %s" % r)
    r = client.execute(ReadDeviceInformationRequest(read_code=1, object_id=0, unit=1))
    check(not r.isError() and r.information.get(0) == b"rtukit", "device identification: %s" % r)
    r = client.execute(ReadDeviceInformationRequest(read_code=4, object_id=2, unit=1))
    check(not r.isError() and 2 in r.information and 0 not in r.information, "one object: %s" % r)
    r = client.execute(ReportSlaveIdRequest(unit=1))
    check(not r.isError() and b"rtukit" in r.identifier, "report slave id: %s" % r)
    client.close()
    print("OK")


if __name__ == "__main__":
    main()
