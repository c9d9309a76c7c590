"""The Rehand 6600's stop paths, end to end: the simulated controller, the
relay (`rtukit relay`) that sees every frame and can lose chosen ones, and the
host daemon (`rtukit rehand6600 host`) driven as the display and a phone drive
it, over its WebSocket API. Each path returns the milliseconds from its cause
(the release sent, the phone's last renewal, its connection dropped, STOP
touched, the frame lost) to the moment the write that makes the controller
safe reached it (the relay's record of that request passing: the controller
executes a request as it arrives). Both clocks are the machine's monotonic
clock (Python's time.monotonic, the relay's CLOCK_MONOTONIC).

Used by tests/faults/rehand_stop_paths.py (each path once, against a bound)
and bench/rehand_stop_bench.py (p50/p99/max over many cycles). Import with
the tests/ folder on sys.path."""
import json
import os
import re
import subprocess
import time
import urllib.request

from pyhelpers import Console, PhoneKey, WebSocket, connect_tcp, free_port, stop_processes, wait_for

PHONE = "0123456789ab"  # the paired phone's id (its key: Chair.key)
LEASE_MS = 300
POLL_MS = 50
TIMEOUT_MS = 200  # the daemon's response timeout (--timeout)
RECORD = re.compile(r"^(\d+\.\d+) (request|reply) (\w+) ([0-9A-F ]+?)(  #.*)?$")

# The controller's writes that make it safe, as the relay prints them.
STOP_COMMAND = "01 06 00 6A 00 01"
SEAT_LIFT_0 = "01 06 00 63 00 00"


def now_ms():
    return time.monotonic() * 1000.0


class Chair:
    """The simulator, the relay between it and the daemon, and the daemon,
    started in `work` and stopped by PID (stop())."""

    def __init__(self, rtukit, work, bluez=None):
        """`bluez`: a MockBluez (tests/ble/bluez_mock.py): the daemon runs
        with --ble on its bus (on the mock's chair adapter), and every wait
        here runs its main loop (the mock answers the daemon's calls only
        while it runs) until the mock runs its loop in a thread of its own
        (MockBluez.run_in_thread)."""
        self.work = work
        self.bluez = bluez
        chair, host = os.path.join(work, "chair"), os.path.join(work, "host")
        sim_sock, relay_sock = os.path.join(work, "sim.sock"), os.path.join(work, "relay.sock")
        self.relay_log = os.path.join(work, "relay.log")
        pairing = os.path.join(work, "pairing.json")
        self.key = PhoneKey()
        self.key.pairing_file(pairing, PHONE, "stop phone")
        self.http, self.phone_port = free_port(), free_port()
        self.procs = []
        self.logs = []
        self.procs.append(self._start([rtukit, "sim", "rehand6600", "--listen", f"pty:{chair}", "--no-state",
                                       "--no-console", "--console", f"unix:{sim_sock}"], "sim"))
        self.con = Console(sim_sock)
        self.procs.append(self._start([rtukit, "relay", "--port", chair, "--listen", f"pty:{host}", "--no-console",
                                       "--console", f"unix:{relay_sock}", "-v"], "relay", self.relay_log))
        self.relay = Console(relay_sock)
        self.procs.append(self._start([rtukit, "rehand6600", "host", "--port", host, "--http",
                                       f"127.0.0.1:{self.http}", "--phone", f"127.0.0.1:{self.phone_port}",
                                       "--pairing-file", pairing] + ([f"--ble={bluez.adapter_name}"] if bluez else []), "host",
                                      env=bluez.env if bluez else None))
        if bluez and not self.wait(lambda: bluez.app is not None, 20):
            raise RuntimeError("the daemon did not register its Bluetooth LE application")
        connect_tcp(self.http).close()
        if not self.wait(lambda: self.state()["connected"]):
            raise RuntimeError("the daemon did not connect to the controller")

    def wait(self, until, timeout=10.0, step=0.005):
        """until()'s first true value within `timeout` s (None when it never
        came), the mock BlueZ's loop run meanwhile when there is one."""
        if self.bluez is None or getattr(self.bluez, "loop", None):
            return wait_for(until, timeout, step)
        seen = []
        self.bluez.pump(timeout, lambda: bool(seen.append(until()) or seen[-1]))
        return seen[-1] if seen and seen[-1] else None

    def _start(self, argv, name, log=None, env=None):
        path = log or os.path.join(self.work, f"{name}.log")
        out = open(path, "w")
        self.logs.append((name, path))
        err = None if log is None else os.path.join(self.work, f"{name}.err")
        p = subprocess.Popen(argv, stdout=out, stderr=subprocess.STDOUT if err is None else open(err, "w"), env=env)
        p.stderr_path = err or path  # checked when stopped (pyhelpers.check_child)
        return p

    def stop(self):
        pump = self.bluez and not getattr(self.bluez, "loop", None)
        stop_processes(self.procs, wait=self.bluez.pump if pump else None)

    # ---- what the controller and the daemon say

    def state(self):
        try:
            with urllib.request.urlopen(f"http://127.0.0.1:{self.http}/api/state", timeout=5) as r:
                return json.load(r)
        except OSError:
            return {"connected": False}

    def controller(self, key):
        """A register of the controller (table 2 too), from the simulator's console."""
        m = re.search(r"\((\d+)\)", self.con.ask(f"get {key}"))
        return int(m.group(1)) if m else -1

    def records(self):
        """The relay's record so far (read on from where the last call stopped)."""
        if not hasattr(self, "_records"):
            self._records, self._offset = [], 0
        with open(self.relay_log) as f:
            f.seek(self._offset)
            for line in f:
                if not line.endswith("\n"):
                    break  # the relay is still writing it
                self._offset += len(line.encode())
                m = RECORD.match(line.rstrip("\n"))
                if m:
                    self._records.append((float(m.group(1)), m.group(2), m.group(3), m.group(4)))
        return self._records

    def passed(self, hex_prefix, after_ms, timeout=5.0):
        """When the relay passed the first request starting with `hex_prefix` after `after_ms`."""
        def find():
            for ms, way, kind, hx in self.records():
                if ms >= after_ms and way == "request" and kind in ("pass", "sent") and hx.startswith(hex_prefix):
                    return ms
            return None
        return self.wait(find, timeout)

    def fault(self, rule):
        answer = self.relay.ask(rule)
        if not answer.startswith("added"):
            raise RuntimeError(f"relay refused '{rule}': {answer}")

    def ready(self, timeout=10.0):
        """Still, nothing held, no stop command, nothing refused: ready for the next cycle."""
        def ok():
            s = self.state()
            return (s.get("connected") and not s.get("emergency") and not s.get("stop") and not s.get("presses")
                    and s["values"]["motion"] == 1 and s["values"]["speed"] == 0
                    and not s["disabled"]["all"] and self.controller("anti_pinch") == 0)
        return self.wait(ok, timeout, 0.02)

    # ---- clients

    def display(self):
        return WebSocket(self.http, "/ws?role=display")

    def phone(self):
        ws = WebSocket(self.phone_port, "/ws", tls=True)
        r = self.key.auth(ws, PHONE)
        if not (r and r.get("ok")):
            raise RuntimeError(f"the phone was not admitted: {r}")
        return ws


class Hold:
    """A press renewed every 100 ms by its page, pinged messages drained."""

    def __init__(self, ws, command, value, press_id):
        self.ws, self.press = ws, press_id
        r = ws.request({"op": "press", "command": command, "value": value, "press": press_id})
        if not (r and r.get("ok")):
            raise RuntimeError(f"press {command}={value} refused: {r}")
        self.last_renewal = now_ms()

    def renew_for(self, seconds):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.ws.send(json.dumps({"op": "renew", "press": self.press}))
            self.last_renewal = now_ms()
            t = time.monotonic() + 0.1
            while time.monotonic() < t:
                self.ws.recv(max(0.001, t - time.monotonic()))


def release(chair, display, press_id):
    """A deliberate release: the finger lifts; the controller's 0 arrives."""
    hold = Hold(display, "seat_lift", "down", press_id)
    hold.renew_for(0.5)
    t0 = now_ms()
    display.send(json.dumps({"op": "release", "press": press_id}))
    at = chair.passed(SEAT_LIFT_0, t0)
    return at - t0 if at else None


def lost_release(chair, display, press_id):
    """The release's 0 lost on the line: from the loss to the 0 written again."""
    hold = Hold(display, "seat_lift", "down", press_id)
    hold.renew_for(0.5)
    chair.fault("drop request fc06 0x0063=0")
    t0 = now_ms()
    display.send(json.dumps({"op": "release", "press": press_id}))
    dropped = chair.wait(lambda: next((ms for ms, way, kind, hx in chair.records()
                                     if ms >= t0 and kind == "drop" and hx.startswith(SEAT_LIFT_0)), None), 5)
    at = chair.passed(SEAT_LIFT_0, dropped or t0)
    return at - dropped if at and dropped else None


def answers_lost(chair, display, press_id):
    """The controller's answers lost while a press is held and renewed: the
    host sees nothing for three request timeouts, raises 1010 and ends the
    press (any doubt about motion: stop); its 0 reaches the controller, which
    hears every request."""
    hold = Hold(display, "seat_lift", "down", press_id)
    hold.renew_for(0.5)
    t0 = now_ms()
    chair.fault("drop replies for 1000ms")
    hold.renew_for(1.2)  # the page keeps renewing (refused once the press has ended)
    at = chair.passed(SEAT_LIFT_0, t0)
    return at - t0 if at else None


def _drive(chair, phone, press_id):
    hold = Hold(phone, "phone_forward", 1, press_id)
    hold.renew_for(0.6)
    return hold


def phone_silent(chair, phone, press_id):
    """A phone driving stops renewing (out of range, frozen): from its last
    renewal to the stop command (0x006A) on the controller."""
    hold = _drive(chair, phone, press_id)
    t0 = hold.last_renewal
    at = chair.passed(STOP_COMMAND, t0)
    return at - t0 if at else None


def tcp_dropped(chair, phone, press_id):
    """A phone driving, its connection gone (TCP closed without a goodbye)."""
    _drive(chair, phone, press_id)
    t0 = now_ms()
    phone.s.close()
    at = chair.passed(STOP_COMMAND, t0)
    return at - t0 if at else None


def display_stop(chair, phone, display, press_id):
    """A phone driving, STOP touched on the display: the stop command; then lifted."""
    _drive(chair, phone, press_id)
    t0 = now_ms()
    display.send(json.dumps({"op": "stop"}))
    at = chair.passed(STOP_COMMAND, t0)
    chair.wait(lambda: chair.state().get("stop"), 5, 0.02)
    display.request({"op": "lift_stop"})
    return at - t0 if at else None


# ---- a phone over Bluetooth LE (the mock BlueZ: tests/ble/bluez_mock.py)

BLE_COMMAND = "7e6a6600-0003-4b1e-9c3d-52e4a8f0c6a1"
BLE_PRESS, BLE_RENEW = 1, 2
BLE_FORWARD = 1  # phone_forward (devices/rehand6600/include/rtukit/devices/rehand6600/ble_gatt.hpp)
PHONE_FORWARD_1 = "01 06 00 6E 00 01"


class BlePhone:
    """A phone bonded to the chair over Bluetooth LE, as a person pairs one:
    "Pair a phone" on the display, the passkey shown, the bond; then its
    commands are GATT writes (docs/rehand6600-ble.md gives their bytes)."""

    def __init__(self, chair, address="AA:BB:CC:DD:EE:01"):
        self.chair, self.bluez, self.address, self.sequence = chair, chair.bluez, address, 0
        display = chair.display()
        try:
            r = display.request({"op": "pair_start"})
            if not (r and r.get("ok")):
                raise RuntimeError(f"the display did not open pairing: {r}")
            if not chair.wait(lambda: bool(self.bluez.adapter_property("Pairable"))):
                raise RuntimeError("the adapter did not become pairable")
            self.bluez.add_phone(address, "stop phone")
            self.bluez.connect(address)
            if self.bluez.display_passkey(address, 123456):
                raise RuntimeError("the agent refused to show the passkey")
            self.bluez.bond(address)
            if not chair.wait(lambda: f"ble:{address}" in [p["phone"] for p in chair.state().get("phones", [])]):
                raise RuntimeError("the bonded phone is not in the display's list")
            display.request({"op": "pair_cancel"})
            # the person at the display allows it to drive.
            r = display.request({"op": "confirm", "phone": f"ble:{address}"})
            if not (r and r.get("ok")):
                raise RuntimeError(f"the display could not allow the phone to drive: {r}")
        finally:
            display.close()

    def send(self, op, press_id):
        self.sequence = (self.sequence + 1) & 0xFFFF
        value = [1, op, BLE_FORWARD, 1, press_id & 0xFF, (press_id >> 8) & 0xFF, (press_id >> 16) & 0xFF,
                 press_id >> 24, self.sequence & 0xFF, self.sequence >> 8]
        err = self.bluez.write(self.address, BLE_COMMAND, value)
        if err:
            raise RuntimeError(f"the chair refused the phone's write: {err}")

    def drive(self, press_id, seconds=0.6):
        """Presses forward and renews every 50 ms (on a schedule) for
        `seconds`; checks on the relay's record that the drive reached the
        controller. Returns the time of the last renewal (ms)."""
        t0 = now_ms()
        self.send(BLE_PRESS, press_id)
        last = time.monotonic()
        end = last + seconds
        while last < end:
            self.bluez.pump(max(0.0, 0.05 - (time.monotonic() - last)))
            last = time.monotonic()
            self.send(BLE_RENEW, press_id)
        if not self.chair.passed(PHONE_FORWARD_1, t0, 1.0):
            raise RuntimeError("the phone's press never reached the controller")
        return last * 1000.0


def ble_silent(chair, phone, press_id):
    """A phone driving over Bluetooth stops renewing (out of range, frozen):
    from its last renewal to the stop command (0x006A) on the controller."""
    t0 = phone.drive(press_id)
    at = chair.passed(STOP_COMMAND, t0)
    return at - t0 if at else None


def ble_disconnect(chair, phone, press_id):
    """A phone driving over Bluetooth, its link gone (BlueZ reports the
    device disconnected): to the stop command on the controller. The phone
    connects again afterwards (still bonded)."""
    phone.drive(press_id)
    t0 = now_ms()
    chair.bluez.disconnect(phone.address)
    at = chair.passed(STOP_COMMAND, t0)
    chair.bluez.connect(phone.address)
    return at - t0 if at else None
