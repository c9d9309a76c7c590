#!/usr/bin/python3
"""The Rehand 6600 host daemon's Bluetooth LE link against a mock BlueZ
(tests/ble/bluez_mock.py) on a private system bus, with the simulated
controller on a pty: registration, pairing on the display, the same session
rules as the web phone (a press lives while renewed, a lapse stops, a late
renewal never restarts, a lost phone stops with the emergency rate), an
unbonded device refused, forgetting removes the bond.

Usage: rehand_ble_scenarios.py RTUKIT [OUT]
OUT: where the display's screenshots go (the passkey on the HMI). Prints one line per check ("ok NAME ..." / "FAIL NAME ..."); exits 1 when a
check failed. Starts what it needs and stops it by PID.
"""
import json
import os
import re
import signal
import subprocess
import sys
import time
import urllib.request

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, ".."))
sys.path.insert(0, os.path.join(HERE, "..", "browser"))
from pyhelpers import display_request, START_DEADLINE, STOP_BOUND_S, check_child, connect_tcp, free_port, host_polls_later, start, stop_processes, temp_dir  # noqa: E402
from browser_common import Console, check, summary  # noqa: E402
from bluez_mock import MockBluez  # noqa: E402

RTUKIT = sys.argv[1]
OUT = sys.argv[2] if len(sys.argv) > 2 else None
SERVICE = "7e6a6600-0001-4b1e-9c3d-52e4a8f0c6a1"
STATE = "7e6a6600-0002-4b1e-9c3d-52e4a8f0c6a1"
COMMAND = "7e6a6600-0003-4b1e-9c3d-52e4a8f0c6a1"
RESULT = "7e6a6600-0004-4b1e-9c3d-52e4a8f0c6a1"
PHONE = "AA:BB:CC:DD:EE:01"
STRANGER = "AA:BB:CC:DD:EE:02"
UNUSED = "AA:BB:CC:DD:EE:09"  # bonded 31 days ago, never used since
PRESS, RENEW, RELEASE, PULSE = 1, 2, 3, 4
FORWARD, LEFT_SIGNAL = 1, 6


def command(op, function, press, sequence):
    return [1, op, function, 1, press & 0xFF, (press >> 8) & 0xFF, (press >> 16) & 0xFF, press >> 24,
            sequence & 0xFF, sequence >> 8]


BOUND_S = STOP_BOUND_S  # the bound of every stop path (tests/pyhelpers.py)


def state(port):
    with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/state", timeout=10) as r:
        return json.load(r)


def after_two_polls(bluez, port):
    """Pumps until the daemon has polled the controller twice more (its last
    contact moves at each poll): long enough for anything a command would
    have written to reach the controller. An event, not a sleep."""
    host_polls_later(lambda: state(port), 2, bluez.pump)


def hmi_passkey(port, passkey):
    """The passkey as the kiosk's Chromium shows it on the display page, at
    the display's two sizes (1280x800, 1024x600), with a screenshot of each.
    Returns what each size showed."""
    from browser_common import browser, layout  # noqa: E402 (selenium only when screenshots are asked for)
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait
    os.makedirs(OUT, exist_ok=True)
    shown = []
    for width, height in ((1280, 800), (1024, 600)):
        d = browser(width, height)
        try:
            d.get(f"http://127.0.0.1:{port}/")
            try:
                WebDriverWait(d, START_DEADLINE).until(
                    lambda drv: drv.find_element(By.ID, "ble-passkey").is_displayed() and
                    drv.find_element(By.ID, "ble-passkey").text == passkey)
            except Exception:  # noqa: BLE001 (the caller's check says what was shown)
                pass
            shown.append(d.find_element(By.ID, "ble-passkey").text)
            layout(d, f"hmi-ble-passkey-{width}x{height}", OUT)
        finally:
            d.quit()
    return shown


def hmi_forget_all(bluez, port, names):
    """The display's phone list in Chromium shows the bonded Bluetooth
    phones (a screenshot, hmi-ble-phones-1280x800.png); then "Forget all
    phones" and its confirmation, tapped as a person would. Returns the rows
    the list showed."""
    from browser_common import browser, layout  # noqa: E402
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait
    d = browser(1280, 800)
    try:
        d.get(f"http://127.0.0.1:{port}/")
        # In one script: the list may be redrawn between finding a row and reading it.
        rows = lambda: d.execute_script(  # noqa: E731
            "return [...document.querySelectorAll('#phone-list > .phone')].map(e => e.innerText)")
        try:
            WebDriverWait(d, START_DEADLINE).until(
                lambda _d: all(any(n in r and "(Bluetooth)" in r for r in rows()) for n in names))
        except Exception:  # noqa: BLE001 (the caller's check says what was shown)
            pass
        shown = rows()
        d.execute_script("document.getElementById('phones').scrollIntoView()")
        layout(d, "hmi-ble-phones-1280x800", OUT)
        WebDriverWait(d, START_DEADLINE).until(lambda _d: d.find_element(By.ID, "forget-all").is_enabled())
        d.find_element(By.ID, "forget-all").click()
        WebDriverWait(d, START_DEADLINE).until(lambda _d: d.find_element(By.ID, "confirm-yes").is_displayed())
        d.find_element(By.ID, "confirm-yes").click()
        # BlueZ removes the devices while its mock runs: the list empties then.
        emptied = bluez.pump(START_DEADLINE, lambda: not rows())
        return shown, emptied
    finally:
        d.quit()


def register(con, key):
    """A register of the simulated controller, as its console reads it ("phone_forward = on (1)" -> 1)."""
    m = re.search(r"\((\d+)\)", con.ask(f"get {key}"))
    return int(m.group(1)) if m else -1


def start_chair(bluez, work, port, procs):
    """The simulated controller on a pty (its console on a unix socket) and
    the daemon with --ble on the mock's bus, both added to `procs`.
    Returns the console, the daemon's process and its log's path."""
    pty, console_path = os.path.join(work, "chair"), os.path.join(work, "console.sock")
    procs.append(start([RTUKIT, "sim", "rehand6600", "--listen", f"pty:{pty}", "--no-state",
                        "--no-console", "--console", f"unix:{console_path}"], work))
    con = Console(console_path)
    log_path = os.path.join(work, "host.log")
    host = start([RTUKIT, "rehand6600", "host", "--port", pty, "--http", f"127.0.0.1:{port}",
                  "--pairing-file", os.path.join(work, "pairing.json"), "--ble"], work,
                 stderr=open(log_path, "w"), env=bluez.env)
    procs.append(host)
    return con, host, log_path


class Client:
    """`rtukit rehand6600 remote --ble` with its keys on a pipe; its output
    collected by a thread (the test's thread pumps the mock BlueZ)."""

    def __init__(self, bluez, args):
        import threading
        self.proc = subprocess.Popen([RTUKIT, "rehand6600", "remote"] + args, stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=bluez.env)
        self.lines = []
        self.reader = threading.Thread(target=lambda: self.lines.extend(iter(self.proc.stdout.readline, b"")),
                                       daemon=True)
        self.reader.start()

    def output(self):
        return b"".join(self.lines).decode(errors="replace")

    def key(self, k):
        self.proc.stdin.write(k.encode())
        self.proc.stdin.flush()

    def stop(self):
        """SIGTERM, as a user's terminal would end it; its end checked
        (pyhelpers.check_child: no sanitizer report, a clean exit)."""
        terminated = self.proc.poll() is None
        if terminated:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.killed_here = True
                self.proc.wait()
        self.reader.join(5)
        check_child(self.proc, terminated, self.output())


def reference_client(bluez, con, port):
    chair, laptop = "00:1A:7D:DA:71:13", "AA:BB:CC:DD:EE:03"
    bluez.add_central(chair, laptop)
    allowed = display_request(port, {"op": "confirm", "phone": f"ble:{laptop}"})
    check("the display allows the laptop to drive", bool(allowed and allowed.get("ok")), f"{allowed}")
    check("the chair is still before the client connects",
          bluez.pump(START_DEADLINE, lambda: not state(port)["emergency"] and register(con, "phone_forward") == 0))
    client = Client(bluez, ["--ble", chair, "--adapter", "hci1", "--key-gap", "400"])
    try:
        check("the client connects and prints the chair's state",
              bluez.pump(START_DEADLINE, lambda: "battery" in client.output()), client.output())
        # A held key: the terminal repeats it every 50 ms for a second.
        driving = False
        for _ in range(20):
            client.key("w")
            bluez.pump(0.05)
            driving = driving or register(con, "phone_forward") == 1
        check("a held key drives the chair (pressed, renewed while the key repeats)",
              driving and register(con, "phone_forward") == 1 and "forward: accepted" in client.output(),
              client.output()[-300:])
        let_go = time.monotonic()
        check("letting go of the key stops it (released, not lapsed: no emergency stop)",
              bluez.pump(START_DEADLINE, lambda: register(con, "phone_forward") == 0) and
              not state(port)["emergency"], f"after {time.monotonic() - let_go:.2f} s")
        light = register(con, "main_light")
        for _ in range(5):  # a pulse key held: one pulse, not one per repeat
            client.key("l")
            bluez.pump(0.05)
        check("a pulse key toggles the light once however long it is held",
              bluez.pump(START_DEADLINE, lambda: register(con, "main_light") == 1 - light) and
              client.output().count("light: accepted") == 1, client.output()[-300:])
        client.key("x")
        check("x quits: the client exits 0 and disconnects",
              bluez.pump(START_DEADLINE, lambda: client.proc.poll() is not None) and client.proc.returncode == 0,
              client.output()[-300:])
    finally:
        client.stop()
    unknown = Client(bluez, ["--ble", "00:00:00:00:00:01", "--adapter", "hci1"])
    try:
        bluez.pump(START_DEADLINE, lambda: unknown.proc.poll() is not None)
        check("a chair BlueZ does not know is one clear line, exit 4",
              unknown.proc.returncode == 4 and "does not know 00:00:00:00:00:01" in unknown.output() and
              unknown.output().count("\n") == 1, unknown.output())
    finally:
        unknown.stop()
    # A key gap of 0 would let go of every key at once; a long one would move the chair on long after
    # the key is let go: refused before anything is opened.
    for gap in ("0", "5000"):
        refused = Client(bluez, ["--ble", chair, "--adapter", "hci1", "--key-gap", gap])
        try:
            bluez.pump(START_DEADLINE, lambda: refused.proc.poll() is not None)
            check(f"a key gap of {gap} ms is refused in one line, exit 2, nothing opened",
                  refused.proc.returncode == 2 and "--key-gap" in refused.output() and
                  refused.output().count("\n") == 1 and "connected" not in refused.output(), refused.output())
        finally:
            refused.stop()


def main():
    work = temp_dir("rtukit-ble-")
    port = free_port()
    procs = []
    bluez = MockBluez(work)
    try:
        # A phone bonded 31 days ago and not used since (the daemon's record
        # of it in the pairing file, its bond in BlueZ): forgotten at start.
        with open(os.path.join(work, "pairing.json"), "w") as f:
            json.dump({"format": "rtukit rehand6600 pairing 3", "phones": [],
                       "bluetooth": [{"id": f"ble:{UNUSED}", "confirmed": True,
                                      "last_contact": int(time.time()) - 31 * 86400}]}, f)
        bluez.add_phone(UNUSED, "Unused")
        bluez.bond(UNUSED)
        con, host, log_path = start_chair(bluez, work, port, procs)

        # ---- registration: BlueZ calls back before RegisterApplication returns
        registered = bluez.pump(START_DEADLINE, lambda: bluez.app is not None and bluez.advertisement is not None)
        check("the daemon registers its GATT application and advertisement (answering BlueZ's call back)",
              registered, open(log_path).read()[-400:] if not registered else "")
        if not registered:
            return summary()
        connect_tcp(port).close()
        check("the daemon connects to the controller",
              bluez.pump(START_DEADLINE, lambda: state(port)["connected"]))
        # Bonds expire like web pairings: 30 days unused, and the bond goes from BlueZ too.
        check("a Bluetooth bond unused for more than 30 days is forgotten: BlueZ removes it",
              bluez.pump(START_DEADLINE, lambda: not bluez.known(UNUSED)) and
              "unused for more than 30 days" in open(log_path).read(), open(log_path).read()[-400:])
        # Privacy: with no bonded phone and the pairing window closed, the
        # chair sends nothing that tells a chair is there.
        check("with no bonded phone and the window closed the chair does not advertise",
              bluez.pump(START_DEADLINE, lambda: bluez.advertisement is None), f"{bluez.advertisement}")
        # "notify" alone would let BlueZ accept any central's subscription (its
        # CCC descriptor writable unencrypted) and send it every notification;
        # "encrypt-authenticated-notify" makes BlueZ require the bonded link.
        check("state and result are read and notified only over an authenticated encrypted link",
              bluez.flags(STATE) == ["encrypt-authenticated-read", "encrypt-authenticated-notify"] and
              bluez.flags(RESULT) == ["encrypt-authenticated-read", "encrypt-authenticated-notify"],
              f"{bluez.flags(STATE)} {bluez.flags(RESULT)}")
        check("commands are written only over an authenticated encrypted link",
              bluez.flags(COMMAND) == ["encrypt-authenticated-write"], f"{bluez.flags(COMMAND)}")
        _, agent_path, caps = bluez.agent()
        check("the pairing agent shows a passkey (DisplayOnly)", caps.get(agent_path) == "DisplayOnly", f"{caps}")
        check("the adapter is not pairable until the display asks",
              not bluez.adapter_property("Pairable") and not bluez.adapter_property("Discoverable"))

        # ---- a device that has not bonded gets nothing
        bluez.add_phone(STRANGER, "Stranger")
        bluez.connect(STRANGER)
        bluez.pump(0.2)
        err = bluez.write(STRANGER, COMMAND, command(PRESS, FORWARD, 1, 1))
        check("an unbonded device's command is refused", err == "org.bluez.Error.NotAuthorized", err)
        value, err = bluez.read(STRANGER, STATE)
        check("an unbonded device cannot read the state", value is None and err == "org.bluez.Error.NotAuthorized",
              err)
        after_two_polls(bluez, port)
        check("and the chair did not move (two polls later)", register(con, "phone_forward") == 0 and
              state(port)["values"]["speed"] == 0)
        err = bluez.display_passkey(STRANGER, 111111)
        check("outside the pairing window the agent refuses to pair", err == "org.bluez.Error.Rejected", err)

        # ---- pairing: the display opens the window, the passkey is shown there
        r = display_request(port, {"op": "pair_start"})
        check("the display opens \"Pair a phone\"", r is not None and r.get("ok"), f"{r}")
        check("the adapter is pairable and discoverable while it is open, for at most 2 minutes",
              bluez.pump(START_DEADLINE, lambda: bool(bluez.adapter_property("Pairable")) and
                         bool(bluez.adapter_property("Discoverable"))) and
              int(bluez.adapter_property("PairableTimeout")) == 120)
        check("...and the chair advertises while the window is open",
              bluez.pump(START_DEADLINE, lambda: bluez.advertisement is not None))
        adv = (bluez.advertisement or (None, None, {}))[2]
        check("the advertisement names the chair and its service",
              adv.get("LocalName") == "Rehand 6600" and SERVICE in [str(u) for u in adv.get("ServiceUUIDs", [])],
              f"{dict(adv)}")
        bluez.add_phone(PHONE, "Pixel")
        bluez.connect(PHONE)
        err = bluez.display_passkey(PHONE, 48213)
        check("the agent accepts to show the passkey while the window is open", err == "", err)
        check("the display shows the passkey (6 digits)",
              bluez.pump(START_DEADLINE, lambda: state(port).get("ble_passkey") == "048213"),
              f"{state(port).get('ble_passkey')}")
        if OUT:
            shown = hmi_passkey(port, "048213")
            check("the HMI in Chromium shows the passkey at both display sizes (hmi-ble-passkey-*.png)",
                  shown == ["048213", "048213"], f"{shown!r}")
        bluez.bond(PHONE)
        phone_id = f"ble:{PHONE}"
        check("the bonded phone is in the display's phone list",
              bluez.pump(START_DEADLINE, lambda: phone_id in [p["phone"] for p in state(port)["phones"]]))
        display_request(port, {"op": "pair_cancel"})
        check("closing the window makes the adapter unpairable and hides the passkey",
              bluez.pump(START_DEADLINE, lambda: not bluez.adapter_property("Pairable") and
                         state(port).get("ble_passkey") == ""))
        bluez.pump(0.3)
        check("...and the chair goes on advertising: a bonded phone may connect", bluez.advertisement is not None)

        # ---- the bonded phone drives under the session's rules
        bluez.start_notify(STATE)
        bluez.start_notify(RESULT)
        state_path, result_path = bluez.characteristic(STATE), bluez.characteristic(RESULT)
        value, err = bluez.read(PHONE, STATE)
        check("the bonded phone reads the state (20 bytes, version 1, the link up)",
              value is not None and len(value) == 20 and value[0] == 1 and value[1] & 1, f"{value} {err}")

        def result(sequence):
            for path, v in reversed(bluez.notified):
                if path == result_path and len(v) >= 4 and v[1] | v[2] << 8 == sequence:
                    return v
            return None

        # bonded, but not allowed to drive until the display says so.
        err = bluez.write(PHONE, COMMAND, command(PRESS, FORWARD, 1, 9))
        early = bluez.pump(START_DEADLINE, lambda: result(9) is not None) and result(9)
        check("a press before the display allows the phone is refused (R-18), with its reason and its code (12)",
              err == "" and early and early[0] == 2 and early[3] != 0 and early[4] == 12 and
              bytes(early[5:]).startswith(b"not allowed"), f"{err} {early}")
        check("...and nothing reaches the controller", register(con, "phone_forward") == 0)
        allowed = display_request(port, {"op": "confirm", "phone": phone_id})
        check("the display allows it", bool(allowed and allowed.get("ok")), f"{allowed}")
        # A new pairing at an allowed address (its bond removed elsewhere and
        # made again) is a new phone to the person at the display: not allowed.
        display_request(port, {"op": "pair_start"})
        bluez.pump(START_DEADLINE, lambda: bool(bluez.adapter_property("Pairable")))

        def allowed_now():
            return next((p for p in state(port)["phones"] if p["phone"] == phone_id), {}).get("confirmed")
        check("...and a new pairing at that address takes the leave back (R-18)",
              bluez.display_passkey(PHONE, 222222) == "" and bluez.pump(START_DEADLINE, lambda: allowed_now() is False),
              f"{allowed_now()}")
        display_request(port, {"op": "pair_cancel"})
        allowed = display_request(port, {"op": "confirm", "phone": phone_id})
        check("...until the display allows it again", bool(allowed and allowed.get("ok")) and allowed_now() is True,
              f"{allowed}")

        err = bluez.write(PHONE, COMMAND, command(PRESS, FORWARD, 1, 10))
        got = bluez.pump(START_DEADLINE, lambda: result(10) is not None) and result(10)
        check("a press is accepted (result notified with its sequence)", err == "" and got and got[3] == 0,
              f"{err} {got}")
        check("the chair drives forward while the press is renewed",
              bluez.pump(START_DEADLINE, lambda: register(con, "phone_forward") == 1))
        # A finger on the button: a renewal every 50 ms (the page renews every
        # 100 ms; the lease is 300 ms), on a schedule, with nothing slow in
        # between (a console read of the controller under a loaded machine
        # once took long enough to leave a gap past the lease). Each renewal's
        # result says whether the press was still alive; the controller is
        # read once, at the end.
        gaps, last_renewal = [], time.monotonic()
        for n in range(12):
            bluez.pump(max(0.0, 0.05 - (time.monotonic() - last_renewal)))
            now = time.monotonic()
            gaps.append(now - last_renewal)
            bluez.write(PHONE, COMMAND, command(RENEW, FORWARD, 1, 11 + n))
            last_renewal = now
        answers = bluez.pump(START_DEADLINE, lambda: all(result(11 + n) is not None for n in range(12))) and \
            [result(11 + n)[3] for n in range(12)]
        check("renewals keep it driving (every renewal answered ok, the controller still driving)",
              answers == [0] * 12 and register(con, "phone_forward") == 1,
              f"answers {answers}, largest gap {max(gaps) * 1000:.0f} ms")
        stopped = bluez.pump(START_DEADLINE, lambda: register(con, "phone_forward") == 0)
        took = time.monotonic() - last_renewal
        check("a lapse (no renewal) stops it within lease + poll + 500 ms of the last renewal",
              stopped and took <= BOUND_S, f"{took * 1000:.0f} ms (bound {BOUND_S * 1000:.0f} ms)")
        bluez.write(PHONE, COMMAND, command(RENEW, FORWARD, 1, 30))
        got = bluez.pump(START_DEADLINE, lambda: result(30) is not None) and result(30)
        after_two_polls(bluez, port)
        check("a late renewal is answered 'ended' and never restarts the chair (two polls later)",
              got and got[3] == 3 and register(con, "phone_forward") == 0, f"{got}")
        check("the state was notified", any(p == state_path for p, _ in bluez.notified))

        # ---- a phone lost mid-press stops with the emergency rate
        # (the lapse was a loss of control too: the chair first stops, then a new press may drive)
        check("the lapse's emergency stop ends once the chair is still",
              bluez.pump(START_DEADLINE, lambda: not state(port)["emergency"]))
        bluez.write(PHONE, COMMAND, command(PRESS, FORWARD, 2, 40))
        got = bluez.pump(START_DEADLINE, lambda: result(40) is not None) and result(40)
        check("a new press drives again", got and got[3] == 0 and
              bluez.pump(START_DEADLINE, lambda: register(con, "phone_forward") == 1), f"{got}")
        bluez.write(PHONE, COMMAND, command(RENEW, FORWARD, 2, 41))
        lost_at = time.monotonic()
        bluez.disconnect(PHONE)
        # The controller's own registers: the stop command (0x006A) written,
        # and the drive command gone, within the bound from the disconnect.
        braked = bluez.pump(START_DEADLINE, lambda: register(con, "anti_pinch") == 1)
        stopped = bluez.pump(START_DEADLINE, lambda: register(con, "phone_forward") == 0)
        took = time.monotonic() - lost_at
        check("a disconnect mid-press stops it through the controller's stop command (0x006A) within the bound",
              braked and stopped and took <= BOUND_S, f"{took * 1000:.0f} ms (bound {BOUND_S * 1000:.0f} ms)")
        check("the log says the phone was lost", "Bluetooth phone 'Pixel'" in open(log_path).read())

        # ---- a malformed command is answered, and moves nothing
        bluez.connect(PHONE)
        bad = [1, PRESS, FORWARD, 1, 0, 0, 0, 0, 50, 0]  # press id 0
        err = bluez.write(PHONE, COMMAND, bad)
        got = bluez.pump(START_DEADLINE, lambda: result(50) is not None) and result(50)
        after_two_polls(bluez, port)
        check("a malformed command is answered 'invalid' with the reason, and moves nothing (two polls later)",
              got and got[3] == 2 and b"press id" in got and register(con, "phone_forward") == 0, f"{got}")

        # ---- a bonded phone that floods is refused before the daemon, and nobody is slowed
        # A real press first, so the flood renews a press that drives: its
        # refused renewals must let it lapse, and the chair stop.
        bluez.pump(START_DEADLINE, lambda: not state(port)["emergency"])
        bluez.write(PHONE, COMMAND, command(PRESS, FORWARD, 7, 99))
        got = bluez.pump(START_DEADLINE, lambda: result(99) is not None) and result(99)
        check("the phone presses again before its flood, and drives", got and got[3] == 0 and
              bluez.pump(START_DEADLINE, lambda: register(con, "phone_forward") == 1), f"{got}")
        flood_started = time.monotonic()
        errors, last_passed = [], flood_started
        for n in range(400):
            errors.append(bluez.write(PHONE, COMMAND, command(RENEW, FORWARD, 7, 100 + n)))
            if errors[-1] == "":
                last_passed = time.monotonic()
        flood_end = time.monotonic()
        flood_s = flood_end - flood_started
        passed = errors.count("")
        check("a flood of commands is cut at 50 a second (bursts of 100): the rest refused 'Failed'",
              passed <= 100 + 50 * flood_s + 2 and errors.count("org.bluez.Error.Failed") == 400 - passed,
              f"{passed} of 400 passed in {flood_s:.2f} s")
        stopped = bluez.pump(START_DEADLINE, lambda: register(con, "phone_forward") == 0)
        took = time.monotonic() - last_passed
        allowed = max(0.0, flood_end - last_passed) + BOUND_S
        check("a flooding phone's press lapses once its renewals are refused, and the chair stops",
              stopped and took <= allowed,
              f"{took * 1000:.0f} ms after its last renewal that passed (bound {allowed * 1000:.0f} ms)")
        check("the display still answers meanwhile", state(port)["connected"])
        bluez.pump(1.0)
        check("after a second's pause the phone's commands pass again",
              bluez.write(PHONE, COMMAND, command(RENEW, FORWARD, 7, 600)) == "")

        # ---- forgetting on the display removes the bond
        r = display_request(port, {"op": "forget", "phone": phone_id})
        check("the display forgets the Bluetooth phone", r is not None and r.get("ok"), f"{r}")
        check("and BlueZ removed the device and its bond", bluez.pump(START_DEADLINE, lambda: not bluez.known(PHONE)))
        check("it left the display's list",
              bluez.pump(START_DEADLINE, lambda: phone_id not in [p["phone"] for p in state(port)["phones"]]))
        check("...and with no bonded phone left the chair stops advertising",
              bluez.pump(START_DEADLINE, lambda: bluez.advertisement is None), f"{bluez.advertisement}")

        # ---- the reference client (`rtukit rehand6600 remote --ble`) on the laptop's adapter
        reference_client(bluez, con, port)

        # ---- "Forget all phones" removes every Bluetooth bond too
        other = "AA:BB:CC:DD:EE:04"
        bluez.add_phone(other, "Galaxy")
        bluez.bond(other)
        laptop = "AA:BB:CC:DD:EE:03"
        check("the display lists both bonded Bluetooth phones",
              bluez.pump(START_DEADLINE, lambda: {f"ble:{other}", f"ble:{laptop}"} <=
                         {p["phone"] for p in state(port)["phones"]}), f"{state(port)['phones']}")
        if OUT:
            shown, emptied = hmi_forget_all(bluez, port, ["Galaxy", "laptop"])
            check("the HMI lists them as Bluetooth phones (hmi-ble-phones-1280x800.png), the laptop "
                  "with its last contact (it drove), the other not allowed to drive yet (R-18)",
                  len(shown) == 2 and all("(Bluetooth)" in r for r in shown) and
                  any("laptop" in r and re.search(r"last contact \d{4}-\d\d-\d\d", r) for r in shown) and
                  any("Galaxy" in r and "may not drive yet" in r and "Allow to drive" in r for r in shown),
                  f"{shown}")
            check("\"Forget all phones\", confirmed on the HMI, empties its list", emptied)
        else:
            r = display_request(port, {"op": "forget_all"})
            check("the display forgets all phones", r is not None and r.get("ok"), f"{r}")
        check("BlueZ removed both devices and their bonds",
              bluez.pump(START_DEADLINE, lambda: not bluez.known(other) and not bluez.known(laptop)))
        check("and the display's list is empty", bluez.pump(START_DEADLINE, lambda: not state(port)["phones"]))

        # ---- on SIGTERM the daemon unregisters from BlueZ
        host.send_signal(signal.SIGTERM)
        ended = bluez.pump(START_DEADLINE, lambda: host.poll() is not None)
        check("SIGTERM ends the daemon, which unregisters its application and advertises nothing",
              ended and host.returncode == 0 and bluez.app[1] in bluez.unregistered and
              bluez.advertisement is None, f"exit {host.returncode} {bluez.unregistered}")
    finally:
        stop_processes(procs)
        bluez.stop()
    return summary()


if __name__ == "__main__":
    sys.exit(main())
