#!/usr/bin/python3
"""The Rehand 6600 host daemon's pages in a real browser (Debian's Chromium,
headless, driven by Selenium through chromedriver), against the simulated
controller on a pty: the display at 1024x600, 1280x800 and 1920x1080, the
phone at 390x844 over TLS (Chromium trusts the daemon's self-signed
certificate by its SPKI hash, as a user trusts it by its fingerprint).
Starts what it needs, stops it by PID.

Usage: rehand_host_browser.py RTUKIT OUTDIR
Prints one line per check ("ok NAME ..." / "FAIL NAME ..."), figures as
"figure NAME VALUE"; exits 1 when a check failed. Screenshots go to OUTDIR.
"""
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
import urllib.error
import urllib.request

from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from browser_common import Console, accessibility_violations, browser, check, console_tail, free_port, layout, small_text, start, stop_processes, summary, temp_dir, wait_for  # noqa: E402
from pyhelpers import STOP_BOUND_S, host_polls_later  # noqa: E402

RTUKIT, OUT = sys.argv[1], sys.argv[2]
os.makedirs(OUT, exist_ok=True)
def state(port):
    with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/state", timeout=10) as r:
        return json.load(r)


def controller_value(con, key):
    """A number register of the simulated controller, from its console
    ("actuator1_position = 28 per-mille" -> 28). Raises when the answer is
    not that (a check must never compare two failed reads)."""
    import re
    answer = con.ask(f"get {key}")
    m = re.fullmatch(re.escape(key) + r" = (\d+)\b.*", answer)
    if not m:
        raise RuntimeError(f"the controller's console answered {answer!r} to 'get {key}'")
    return int(m.group(1))


def spki_pin(cert):
    """base64(SHA-256(SubjectPublicKeyInfo)) of a PEM certificate, with Debian's openssl."""
    der = subprocess.run(["openssl", "x509", "-in", cert, "-pubkey", "-noout"], capture_output=True, check=True).stdout
    der = subprocess.run(["openssl", "pkey", "-pubin", "-outform", "der"], input=der, capture_output=True,
                         check=True).stdout
    import base64
    import hashlib
    return base64.b64encode(hashlib.sha256(der).digest()).decode()


def _try(fn):
    try:
        return fn()
    except Exception:
        return None


# s, for what a page, the daemon or the simulator shows after an action: a
# deadline on an event, generous for a busy machine (only a failure waits it out).
DEADLINE = 30


def commands_held(con):
    """The commands the simulated controller holds, but the host's boot-complete flag."""
    return [h for h in con.held().split() if h != "none" and not h.startswith("host_ready=")]


def text(d, css):
    return d.find_element(By.CSS_SELECTOR, css).text


def main():
    work = temp_dir("rtukit-rehand-host-")  # removed at exit, on every path
    pty, console_path = os.path.join(work, "chair"), os.path.join(work, "console.sock")
    http_port, phone_port = free_port(), free_port()
    pairing = os.path.join(work, "pairing.json")
    procs = []
    drivers = []

    def start_host(err_name):
        return start([RTUKIT, "rehand6600", "host", "--port", pty, "--http", f"127.0.0.1:{http_port}",
                      "--phone", f"127.0.0.1:{phone_port}", "--pairing-file", pairing], work,
                     stdout=subprocess.PIPE, stderr=open(os.path.join(work, err_name), "w"), text=True)

    try:
        sim = start([RTUKIT, "sim", "rehand6600", "--listen", f"pty:{pty}", "--no-state", "--no-console",
                     "--console", f"unix:{console_path}"], work)
        procs.append(sim)
        con = Console(console_path)
        host = start_host("host1.err")
        procs.append(host)
        check("daemon prints the display URL", f"http://127.0.0.1:{http_port}" in host.stdout.readline())
        check("daemon prints the phones' TLS URL", f"https://127.0.0.1:{phone_port}" in host.stdout.readline())
        fp_line = host.stdout.readline()
        check("daemon prints the certificate's fingerprint", "SHA-256" in fp_line, fp_line.strip())
        check("host connected", wait_for(lambda: _try(lambda: state(http_port)["connected"]), 30))

        # ---- the display at 1280x800
        hmi = browser(1280, 800)
        drivers.append(hmi)
        hmi.get(f"http://127.0.0.1:{http_port}/")
        check("hmi shows the battery", wait_for(lambda: text(hmi, "#battery").startswith("80 %")))
        check("the Stop button is visible", hmi.find_element(By.ID, "stop").is_displayed())

        # live values follow the simulator
        t0 = time.monotonic()
        con.cmd("joystick 0 100")
        moved = wait_for(lambda: text(hmi, "#motion") == "forward", DEADLINE, 0.005)
        latency = (time.monotonic() - t0) * 1000
        check("joystick on the simulator shows on the page", bool(moved), f"{latency:.0f} ms")
        print(f"figure joystick_to_page_ms {latency:.0f}")
        con.cmd("joystick 0 0")
        wait_for(lambda: text(hmi, "#speed") == "0 km/h", DEADLINE)
        con.cmd("distance left 250")
        check("the distances show from above", wait_for(
            lambda: hmi.execute_script(
                "const z = document.querySelector('#distances [data-side=left]');"
                "return z && z.classList.contains('danger');"), DEADLINE))
        layout(hmi, "hmi-1280x800", OUT)
        v = accessibility_violations(hmi)
        check("the display: no WCAG 2.2 A/AA violation (axe-core)", not v, "; ".join(v))
        con.cmd("distance left 2000")

        # press and hold a posture: moves while held, shows its state, stops on release
        up = hmi.find_element(By.CSS_SELECTOR, '[data-cmd="seat_lift"][data-value="up"]')
        ActionChains(hmi).click_and_hold(up).perform()
        check("seat lift moves while held", bool(wait_for(
            lambda: state(http_port)["values"]["actuator1_position"] > 100, DEADLINE)))
        check("the controller holds seat_lift", "seat_lift=1" in con.held())
        check("the display shows the posture moving", wait_for(
            lambda: hmi.find_element(By.ID, "posture-state-seat_lift").get_attribute("data-state") == "moving", DEADLINE),
            hmi.find_element(By.ID, "posture-state-seat_lift").text)
        # Stand/sit shares actuator 1 with seat lift: only the posture held moves.
        postures = {p["key"]: p for p in state(http_port)["postures"]}
        check("the daemon says which posture is held and moves",
              postures["seat_lift"]["held"] == "up" and postures["seat_lift"]["moving"] is True
              and postures["stand"]["held"] == "" and postures["stand"]["moving"] is False,
              json.dumps({k: postures[k] for k in ("seat_lift", "stand")}))
        stand_state = hmi.find_element(By.ID, "posture-state-stand")
        check("holding Seat lift does not show Stand / sit moving",
              stand_state.get_attribute("data-state") != "moving" and "moving" not in stand_state.text
              and "standing" not in stand_state.text, f"{stand_state.get_attribute('data-state')}: {stand_state.text}")
        hmi.save_screenshot(os.path.join(OUT, "hmi-posture-moving.png"))
        ActionChains(hmi).release(up).perform()
        # From the finger lifted (the pointer event dispatched: WebDriver's
        # own round trip is no part of the stop path).
        t0 = time.monotonic()
        released = wait_for(lambda: "seat_lift" not in con.held(), STOP_BOUND_S + 1, 0.01)
        took = time.monotonic() - t0
        check("nothing held after release, within the bound of a stop path", bool(released) and took <= STOP_BOUND_S,
              f"{took * 1000:.0f} ms (bound {STOP_BOUND_S * 1000:.0f} ms)")
        # On the controller itself (the daemon's copy may be a poll old), and
        # again once the daemon has polled five times more (>= 250 ms: at the
        # seat's speed, 5 per-mille or more): the same.
        stopped = controller_value(con, "actuator1_position")
        host_polls_later(lambda: state(http_port), 5)
        later = controller_value(con, "actuator1_position")
        check("seat lift stops on release (the controller's position, five polls later)",
              later == stopped, f"{stopped} then {later} per-mille")

        # STOP: an emergency stop (0x006A) that releases a command another
        # connection holds, and stays on until the display lifts it.
        HOLD_JS = """
const [url, command, value, done] = [arguments[0], arguments[1], arguments[2], arguments[arguments.length - 1]];
const ws = new WebSocket(url); window.__held = ws; window.__released = null;
ws.onmessage = (e) => { const m = JSON.parse(e.data);
  if (m.type === 'event' && m.event === 'released') { window.__released = m; clearInterval(window.__renew); }
  if (m.type === 'result' && m.op === 'press') done(m); };
ws.onopen = () => { ws.send(JSON.stringify({op: 'press', command, value, press: 1, id: 1}));
  window.__renew = setInterval(() => ws.send(JSON.stringify({op: 'renew', press: 1})), 100); };
setTimeout(() => done({timeout: true}), 5000);
"""
        r = hmi.execute_async_script(HOLD_JS, f"ws://127.0.0.1:{http_port}/ws?role=display", "backrest", "back")
        check("a second connection holds backrest", r.get("ok") is True and bool(
            wait_for(lambda: "backrest=2" in con.held(), DEADLINE)), json.dumps(r))
        own = hmi.find_element(By.CSS_SELECTOR, '[data-cmd="seat_lift"][data-value="up"]')
        ActionChains(hmi).click_and_hold(own).perform()  # the display's own press too: its end is an event here
        check("the display holds seat lift", bool(wait_for(lambda: "seat_lift" in con.held(), DEADLINE)), con.held())
        hmi.execute_script("document.getElementById('stop').dispatchEvent(new PointerEvent('pointerdown', {bubbles: true}))")
        check("Stop releases every command at once", bool(wait_for(lambda: "backrest" not in con.held(), 3, 0.01)))
        check("...with the controller's stop command, held", bool(wait_for(lambda: "anti_pinch=1" in con.held(), 3, 0.01)),
              con.held())
        ActionChains(hmi).release().perform()
        released = wait_for(lambda: hmi.execute_script("return window.__released"), 3)
        check("the holder hears why", bool(released) and "STOP" in released.get("reason", ""), json.dumps(released))
        hmi.execute_script("window.__held.close()")
        check("STOP stays on, saying so", bool(wait_for(lambda: hmi.find_element(By.ID, "stop-latched").is_displayed(), 3)))
        hmi.save_screenshot(os.path.join(OUT, "hmi-stop-latched.png"))
        check("...and its confirmation stays whole (the events of the presses it ended once overwrote it)",
              text(hmi, "#notice").startswith("Stopped: every command released"), text(hmi, "#notice"))
        r = hmi.execute_async_script(HOLD_JS, f"ws://127.0.0.1:{http_port}/ws?role=display", "backrest", "back")
        check("nothing is pressed while STOP is on", r.get("ok") is False and "STOP" in r.get("error", "")
              and "backrest" not in con.held(), json.dumps(r))
        hmi.execute_script("window.__held.close()")
        hmi.find_element(By.ID, "lift-stop").click()
        check("Lift STOP releases the stop command once the chair is still",
              bool(wait_for(lambda: "anti_pinch" not in con.held(), 3, 0.01)), con.held())
        check("...and the banner goes", bool(wait_for(lambda: not hmi.find_element(By.ID, "stop-latched").is_displayed(), 3)))

        # closing the tab while holding stops within the lease
        hmi.switch_to.new_window("tab")
        hmi.get(f"http://127.0.0.1:{http_port}/")
        wait_for(lambda: text(hmi, "#battery").startswith("80 %"))
        down = hmi.find_element(By.CSS_SELECTOR, '[data-cmd="seat_lift"][data-value="down"]')
        ActionChains(hmi).click_and_hold(down).perform()
        check("the second tab holds seat_lift down", bool(wait_for(lambda: "seat_lift=2" in con.held(), DEADLINE)))
        t0 = time.monotonic()
        hmi.close()
        gone = wait_for(lambda: "seat_lift" not in con.held(), STOP_BOUND_S + 1, 0.01)
        took = time.monotonic() - t0
        check("closing the tab releases within the bound of a stop path", bool(gone) and took <= STOP_BOUND_S,
              f"{took * 1000:.0f} ms (bound {STOP_BOUND_S * 1000:.0f} ms)")
        hmi.switch_to.window(hmi.window_handles[0])

        # stand and sit are press-and-hold: a tap does not latch
        stand = hmi.find_element(By.ID, "stand")
        stand.click()
        check("a tap on Stand up holds nothing after the lease", bool(wait_for(lambda: "stand" not in con.held(), 3)),
              con.held())

        # The joystick's horn button: the display sounds the horn while it is
        # held (before, one beep at its rising edge and a 1.5-s banner).
        con.cmd("horn on")
        on = wait_for(lambda: hmi.execute_script("return document.body.dataset.horn") == "on" and
                      hmi.find_element(By.ID, "horn-banner").is_displayed(), DEADLINE)
        host_polls_later(lambda: state(http_port), 40)  # 2 s at least: longer than the old banner
        still = hmi.execute_script("return document.body.dataset.horn") == "on"
        con.cmd("horn off")
        off = wait_for(lambda: hmi.execute_script("return document.body.dataset.horn") == "off" and
                       not hmi.find_element(By.ID, "horn-banner").is_displayed(), DEADLINE)
        check("the horn sounds while the joystick's horn button is held, and stops when it is let go",
              bool(on) and still and bool(off), f"on {on}, still {still}, off {off}")

        # error overlay; clearing restarts nothing (D-8); Stop stays usable above it
        leg = hmi.find_element(By.CSS_SELECTOR, '[data-cmd="leg_rotate"][data-value="up"]')
        ActionChains(hmi).click_and_hold(leg).perform()
        wait_for(lambda: "leg_rotate=1" in con.held(), DEADLINE)
        con.cmd("error 10C3")
        overlay = wait_for(lambda: hmi.find_element(By.ID, "error-overlay").is_displayed(), DEADLINE)
        check("error overlay shown", bool(overlay), text(hmi, "#error-text"))
        check("overlay text is table 3's", text(hmi, "#error-text") == "10C3 Seat lift Error", text(hmi, "#error-text"))
        check("...with table 3's advice: what to check (the device layer's, as `rehand6600 errors` prints it)",
              wait_for(lambda: text(hmi, "#error-advice").startswith("The seat-lift actuator (actuator 1)") and
                       "check:" in text(hmi, "#error-advice"), DEADLINE), text(hmi, "#error-advice"))
        check("...and a device error is no lost link", text(hmi, "#error-detail")
              == "Every function is disabled until the error clears.", text(hmi, "#error-detail"))
        other = hmi.find_element(By.CSS_SELECTOR, '[data-cmd="backrest"][data-value="forward"]')
        check("buttons disabled under the overlay", not other.is_enabled())
        check("Stop stays enabled above the overlay", hmi.find_element(By.ID, "stop").is_enabled() and hmi.execute_script(
            "const r = document.getElementById('stop').getBoundingClientRect();"
            "return document.elementFromPoint(r.left + r.width / 2, r.top + r.height / 2).closest('#stop') !== null;"))
        hmi.save_screenshot(os.path.join(OUT, "hmi-error-overlay.png"))
        con.cmd("error clear")
        wait_for(lambda: state(http_port)["error"] == 0, DEADLINE)
        pos = controller_value(con, "actuator4_position")
        # The finger is still down: ten polls later (>= 500 ms), on the controller itself.
        host_polls_later(lambda: state(http_port), 10)
        check("clearing the error restarts nothing (D-8)", controller_value(con, "actuator4_position") == pos
              and "leg_rotate" not in con.held(), f"held: {con.held()}")
        check("overlay stays until acknowledged", hmi.find_element(By.ID, "error-overlay").is_displayed())
        ActionChains(hmi).release().perform()
        check("...saying the error cleared", wait_for(lambda: text(hmi, "#error-detail").startswith(
            "The error has cleared."), DEADLINE), text(hmi, "#error-detail"))
        # The daemon frozen (SIGSTOP: its sockets stay open, nothing comes):
        # within the pages' 3 s of silence the display shows no contact, and
        # its overlay no longer says the error cleared (nothing is known).
        # Before the heartbeat and the pages' silence check, a frozen daemon's
        # last state looked live for ever.
        os.kill(host.pid, signal.SIGSTOP)
        try:
            t0 = time.monotonic()
            frozen = wait_for(lambda: hmi.find_element(By.ID, "lost").is_displayed()
                              and text(hmi, "#error-detail").startswith("Whether the error has cleared is not known"),
                              DEADLINE)
            took = time.monotonic() - t0
            check("a frozen daemon: the display shows no contact within its 3 s of silence, the error not known",
                  bool(frozen) and "has cleared." not in text(hmi, "#error-detail"),
                  f"{took:.1f} s: {text(hmi, '#error-detail')!r}")
            hmi.save_screenshot(os.path.join(OUT, "hmi-daemon-frozen.png"))
        finally:
            os.kill(host.pid, signal.SIGCONT)
        check("the daemon back: the display live again, the cleared error's overlay as it was",
              wait_for(lambda: not hmi.find_element(By.ID, "lost").is_displayed()
                       and text(hmi, "#error-detail").startswith("The error has cleared."), 30),
              text(hmi, "#error-detail"))
        # The error cleared, the overlay still up: another connection may hold
        # a command again, and Stop on the overlay releases it and every other.
        r = hmi.execute_async_script(HOLD_JS, f"ws://127.0.0.1:{http_port}/ws?role=display", "seat_tilt", "back")
        check("under the acknowledged-later overlay a second connection holds seat_tilt", r.get("ok") is True and bool(
            wait_for(lambda: "seat_tilt=2" in con.held(), DEADLINE)), json.dumps(r))
        check("the overlay is still shown", hmi.find_element(By.ID, "error-overlay").is_displayed())
        hmi.find_element(By.ID, "stop").click()
        check("Stop on the overlay releases every command, the stop command held",
              bool(wait_for(lambda: commands_held(con) == ["anti_pinch=1"] and state(http_port)["presses"] == [], 3,
                            0.01)), f"held: {con.held()}")
        released = wait_for(lambda: hmi.execute_script("return window.__released"), 3)
        check("...and the holder hears it was STOP", bool(released) and "STOP" in released.get("reason", ""),
              json.dumps(released))
        hmi.execute_script("window.__held.close()")
        hmi.find_element(By.ID, "ack").click()
        check("acknowledged overlay goes away",
              wait_for(lambda: not hmi.find_element(By.ID, "error-overlay").is_displayed()))
        hmi.find_element(By.ID, "lift-stop").click()
        check("...STOP lifted", bool(wait_for(lambda: not commands_held(con), 3, 0.01)), con.held())

        # ---- the API: bad input gets a clear error on that connection and changes nothing
        API_JS = """
const [url, msgs, done] = [arguments[0], arguments[1], arguments[arguments.length - 1]];
const ws = new WebSocket(url); const out = [];
ws.onmessage = (e) => { const m = JSON.parse(e.data); if (m.type === 'result' || m.type === 'error') out.push(m);
  if (out.length === msgs.length) { ws.close(); done(out); } };
ws.onopen = () => { for (const m of msgs) ws.send(typeof m === 'string' ? m : JSON.stringify(m)); };
ws.onclose = (e) => done(out.length === msgs.length ? out : {closed: e.reason, got: out});
setTimeout(() => done({timeout: out}), 8000);
"""
        ws_display = f"ws://127.0.0.1:{http_port}/ws?role=display"
        replies = hmi.execute_async_script(API_JS, ws_display, [
            "not json", {"op": "fly"}, {"op": "press", "command": 5, "press": 1},
            {"op": "press", "command": "phone_forward", "value": 1, "press": 2},
            {"op": "set", "key": "speed_level", "value": 9},
            {"op": "press", "command": "seat_lift", "value": "sideways", "press": 3},
            {"op": "press", "command": "seat_lift", "value": "up"},
            {"op": "set", "key": "speed_level", "value": [1]}])
        expect = ["JSON object", "unknown command 'fly'", "must be a register key", "not a command this page may send",
                  "speed_level", "sideways", "press id", "must be a name or a number"]
        ok = isinstance(replies, list) and len(replies) == len(expect) and all(
            (not r.get("ok", False)) and e in r.get("error", "") for r, e in zip(replies, expect))
        check("bad API input: a clear error each", ok, json.dumps(replies)[:500])
        check("bad API input changed nothing", state(http_port)["speed_level"] == 1 and "seat_lift" not in con.held())
        FLOOD_JS = """
const [url, done] = [arguments[0], arguments[arguments.length - 1]];
const ws = new WebSocket(url);
ws.onopen = () => { for (let i = 0; i < 3000; ++i) ws.send('{"op":"nothing"}'); };
ws.onclose = (e) => done(e.reason || 'closed');
setTimeout(() => done('still open'), 10000);
"""
        reason = hmi.execute_async_script(FLOOD_JS, ws_display)
        check("a flooding client is dropped", reason == "too many messages", str(reason))
        check("the poll loop went on", bool(wait_for(lambda: state(http_port)["connected"])))

        # the display at 1920x1080 and at 1024x600 (the board's panel)
        for w, h in ((1920, 1080), (1024, 600)):
            d = browser(w, h)
            drivers.append(d)
            d.get(f"http://127.0.0.1:{http_port}/")
            wait_for(lambda: text(d, "#battery").startswith("80 %"))
            layout(d, f"hmi-{w}x{h}", OUT)
            small = d.execute_script(
                "return [...document.querySelectorAll('main button, #stop')].filter((b) => {"
                " const r = b.getBoundingClientRect(); return r.width > 0 && (r.width < 48 || r.height < 48); })"
                ".map((b) => b.textContent.trim() + ' ' + Math.round(b.getBoundingClientRect().width) + 'x'"
                " + Math.round(b.getBoundingClientRect().height));")
            check(f"touch targets at least 48 px at {w}x{h}", not small, "; ".join(small[:6]))
            # Read at arm's length from the chair (issue 37): no text under 16 px.
            tiny = small_text(d, 16)
            check(f"no text under 16 px at {w}x{h}", not tiny, "; ".join(tiny))

        # ---- the phone, over TLS, its certificate pinned as a user checks its fingerprint
        cert = os.path.join(work, "rehand6600-phone.crt")
        pin = spki_pin(cert)
        phone = browser(390, 844, [f"--ignore-certificate-errors-spki-list={pin}"])
        drivers.append(phone)
        phone.get(f"https://127.0.0.1:{phone_port}/")
        check("unpaired phone shows the pairing form", wait_for(
            lambda: phone.find_element(By.ID, "pairing").is_displayed(), DEADLINE))
        check("unpaired phone shows no state", phone.find_element(By.ID, "battery").text in ("", "--"))
        layout(phone, "phone-pairing-390x844", OUT, scrolls=True)
        phone.find_element(By.ID, "pair-code").send_keys("123456")
        phone.find_element(By.ID, "pair-go").click()
        check("no code shown: refused with the reason",
              wait_for(lambda: "code" in text(phone, "#pair-reason"), DEADLINE),
              f"{text(phone, '#pair-reason')!r}; console: {console_tail(phone)}")

        hmi.find_element(By.ID, "pair").click()
        code = wait_for(lambda: re.fullmatch(r"\d{6}", text(hmi, "#code")) and text(hmi, "#code"))
        check("the display shows a one-time code", bool(code), str(code))
        fingerprint = state(http_port)["fingerprint"]
        check("the display shows the certificate's fingerprint",
              wait_for(lambda: fingerprint[:11] in text(hmi, "#fingerprint").replace("\n", " "), DEADLINE),
              text(hmi, "#fingerprint"))
        hmi.save_screenshot(os.path.join(OUT, "hmi-pairing-code.png"))
        # The QR code, read by zbar (a decoder we did not write), opens the
        # phone page with the code and the fingerprint in its fragment.
        qr = hmi.find_element(By.ID, "qr")
        wait_for(lambda: hmi.execute_script("return arguments[0].complete && arguments[0].naturalWidth > 0", qr))
        qr.screenshot(os.path.join(OUT, "pairing-qr.png"))
        decoded = subprocess.run(["zbarimg", "-q", "--raw", os.path.join(OUT, "pairing-qr.png")],
                                 capture_output=True, text=True).stdout.strip()
        check("the QR code holds the TLS address, the code and the fingerprint (in the fragment)",
              decoded == f"https://127.0.0.1:{phone_port}/#code={code}&fp={fingerprint}", decoded)
        phone.get(decoded or f"https://127.0.0.1:{phone_port}/")
        check("the code is filled in from the QR code",
              wait_for(lambda: phone.find_element(By.ID, "pair-code").get_attribute("value") == code),
              phone.find_element(By.ID, "pair-code").get_attribute("value"))
        check("the fragment leaves the address bar", "#" not in phone.current_url, phone.current_url)
        phone.find_element(By.ID, "pair-name").send_keys("Test phone")
        phone.find_element(By.ID, "pair-go").click()
        check("phone paired", wait_for(lambda: phone.find_element(By.ID, "remote").is_displayed()
                                       and re.fullmatch(r"\d+ %", text(phone, "#battery")), DEADLINE))
        check("the display lists the phone", wait_for(lambda: "Test phone" in text(hmi, "#phone-list")))
        check("...and no banner says it drives", not hmi.find_element(By.ID, "driver-banner").is_displayed())
        # What the phone keeps is a WebCrypto key the page cannot read out
        # (a phishing page at another origin cannot reach it at all; one at
        # this origin can only ask it to sign while open): no token anywhere.
        kept = phone.execute_async_script("""
            const done = arguments[arguments.length - 1];
            import('/rehand/phone-key.js').then(async (m) => {
              const id = await m.loadIdentity();
              let exported = 'no key';
              if (id) {
                try { await crypto.subtle.exportKey('pkcs8', id.keys.privateKey); exported = 'exported'; }
                catch (e) { exported = e.name; }
              }
              done({ phone: id && id.phone, extractable: id && id.keys.privateKey.extractable, exported,
                     storage: JSON.stringify(localStorage) });
            }, (e) => done({ error: String(e) }));""")
        check("the phone keeps a key the page cannot export, and no token",
              kept.get("phone") and kept.get("extractable") is False and kept.get("exported") == "InvalidAccessError"
              and "token" not in kept.get("storage", "") and kept["phone"] in open(pairing).read()
              and "token" not in open(pairing).read(), json.dumps(kept))
        # a new phone drives once the person at the display, seeing its
        # name, allows it; until then its drive press is refused, saying where.
        check("...as one that may not drive yet, with \"Allow to drive\" beside its name",
              wait_for(lambda: "may not drive yet" in text(hmi, "#phone-list")
                       and hmi.find_elements(By.CSS_SELECTOR, "#phone-list .phone button.allow")),
              text(hmi, "#phone-list"))
        cut = hmi.execute_script(
            "return [...document.querySelectorAll('#phone-list .phone:has(button.allow) :is(.phone-name, .phone-status)')]"
            ".filter((e) => e.scrollWidth > e.clientWidth + 1).map((e) => e.textContent);")
        check("...its name and status read in full (the person allows what they read)", not cut, f"{cut}")
        layout(phone, "phone-remote-390x844", OUT, scrolls=True)
        v = accessibility_violations(phone)
        check("the Wi-Fi phone page: no WCAG 2.2 A/AA violation (axe-core)", not v, "; ".join(v))

        # D-10: the seat is still raised from the posture checks
        check("raised: the phone shows why it cannot drive",
              wait_for(lambda: "not fully seated" in text(phone, "#reason"), DEADLINE), text(phone, "#reason"))
        down = hmi.find_element(By.CSS_SELECTOR, '[data-cmd="seat_lift"][data-value="down"]')
        # Held until the seat is down. A browser starved by a busy machine can
        # miss renewals; the press then ends for good (the lease, by design)
        # and, as a person would, the test presses again.
        for _ in range(10):
            ActionChains(hmi).click_and_hold(down).perform()
            lowered = wait_for(lambda: state(http_port)["values"]["actuator1_position"] == 0, 10)
            ActionChains(hmi).release(down).perform()
            if lowered:
                break
        check("seated again: the phone may drive", wait_for(lambda: text(phone, "#reason") == "", DEADLINE),
              text(phone, "#reason"))
        # (R-18, continued: its drive buttons are live now, the seat down)
        fwd = phone.find_element(By.ID, "fwd")
        ActionChains(phone).click_and_hold(fwd).perform()
        refused = wait_for(lambda: "Allow to drive" in text(phone, "#reason"), DEADLINE)
        check("a drive press before the display allows it is refused, saying where to allow it", bool(refused),
              text(phone, "#reason"))
        check("...nothing of it reached the controller", "phone_forward" not in con.held(), con.held())
        ActionChains(phone).release(fwd).perform()
        hmi.find_element(By.CSS_SELECTOR, "#phone-list .phone button.allow").click()
        check("the display allows it", wait_for(lambda: "may not drive yet" not in text(hmi, "#phone-list")),
              text(hmi, "#phone-list"))

        # driving is held while the finger is down, and released
        fwd = phone.find_element(By.ID, "fwd")
        ActionChains(phone).click_and_hold(fwd).perform()
        drove = wait_for(lambda: state(http_port)["values"]["speed"] > 0, DEADLINE)
        check("phone forward drives the chair", bool(drove), con.held())
        check("the display shows which phone drives", "driving" in text(hmi, "#phone-list"))
        # ...and in large text where everyone at the chair sees it (issue 38:
        # it was the phone list's status alone, small, in the side column).
        banner = hmi.find_element(By.ID, "driver-banner")
        size = float(hmi.execute_script("return parseFloat(getComputedStyle(arguments[0]).fontSize)", banner))
        check("...in a banner, in large text: the phone's name", banner.is_displayed()
              and text(hmi, "#driver-banner") == "Test phone drives the chair. STOP stops it." and size >= 20,
              f"{text(hmi, '#driver-banner')!r}, {size} px")
        hmi.save_screenshot(os.path.join(OUT, "hmi-phone-drives.png"))
        t0 = time.monotonic()
        ActionChains(phone).release(fwd).perform()
        seen = []
        released = wait_for(lambda: seen.append(con.held()) or "phone_forward" not in seen[-1], DEADLINE, 0.005)
        print(f"figure phone_release_to_register_ms {(time.monotonic() - t0) * 1000:.0f}")
        # A release, not the lease: a phone press that lapses is a loss of
        # control, whose stop command (0x006A) goes before the 0, so it would
        # be on the controller when the 0 is seen.
        check("release writes 0 (a release: no stop command with it)",
              bool(released) and "anti_pinch" not in seen[-1], seen[-1] if seen else "")

        # refused while charging, with the reason
        wait_for(lambda: state(http_port)["values"]["speed"] == 0, 20)
        con.cmd("charger on")
        wait_for(lambda: state(http_port)["values"]["charging"] == 1)
        reason = wait_for(lambda: "charging" in text(phone, "#reason") and text(phone, "#reason"), DEADLINE)
        check("phone shows why it cannot drive", bool(reason), text(phone, "#reason"))
        check("drive buttons disabled while charging", not phone.find_element(By.ID, "fwd").is_enabled())
        phone.save_screenshot(os.path.join(OUT, "phone-charging.png"))
        con.cmd("charger off")
        wait_for(lambda: phone.find_element(By.ID, "fwd").is_enabled(), DEADLINE)
        # The light's button says whether the light is on (a pulse toggles it).
        light = phone.find_element(By.ID, "light")
        was = state(http_port)["values"]["main_light"]
        light.click()
        toggled = wait_for(lambda: state(http_port)["values"]["main_light"] != was, DEADLINE)
        shown = wait_for(lambda: light.get_attribute("aria-pressed") == ("true" if was == 0 else "false"), DEADLINE)
        check("the phone's Light button shows the light's state (a pulse toggled it)", bool(toggled and shown),
              f"main_light {was} -> {state(http_port)['values']['main_light']}, aria-pressed "
              f"{light.get_attribute('aria-pressed')!r}")
        phone.save_screenshot(os.path.join(OUT, "phone-light-390x844.png"))
        if toggled and state(http_port)["values"]["main_light"] == 1:
            light.click()  # back off, as the rest of the test expects the chair
            wait_for(lambda: state(http_port)["values"]["main_light"] == 0, DEADLINE)

        # The same phone opens the remote in a second tab (its key from
        # IndexedDB signs the new connection's challenge): the new connection
        # replaces the old one, and the display says so.
        first_tab = phone.current_window_handle
        phone.switch_to.new_window("tab")
        phone.get(f"https://127.0.0.1:{phone_port}/")
        check("a second tab of the phone takes over", wait_for(
            lambda: phone.find_element(By.ID, "remote").is_displayed() and re.fullmatch(r"\d+ %", text(phone, "#battery")),
            DEADLINE))
        line = wait_for(lambda: "replaced the old one" in text(hmi, "#phone-event") and text(hmi, "#phone-event"),
                        DEADLINE)
        check("the display says a new connection replaced the phone's old one",
              bool(line) and "Phone Test phone: a new connection replaced the old one" in line, str(line))
        hmi.save_screenshot(os.path.join(OUT, "hmi-phone-replaced.png"))
        phone.switch_to.window(first_tab)
        check("the old tab says it was replaced",
              wait_for(lambda: phone.find_element(By.ID, "replaced").is_displayed(), DEADLINE))
        phone.close()
        phone.switch_to.window(phone.window_handles[0])

        # pairing survives a restart of the daemon (stored atomically); the
        # page authenticates again by itself, in its first message
        check("pairing file is private", (os.stat(pairing).st_mode & 0o077) == 0)
        host.send_signal(signal.SIGTERM)
        code = host.wait(20)
        check("the daemon ends cleanly on SIGTERM", code == 0, f"exit {code}")
        host = start_host("host2.err")
        procs.append(host)
        check("after a restart the paired phone is live again",
              wait_for(lambda: phone.find_element(By.ID, "remote").is_displayed()
                       and "connected" in text(hmi, "#phone-list") + " " and _try(lambda: state(http_port)["connected"])
                       and not phone.execute_script("return document.body.classList.contains('lost')"), 30))

        # the controller unplugged: nothing looks live, on the display and the phone
        hmi.refresh()
        wait_for(lambda: text(hmi, "#link") == "connected", 20)
        sim.send_signal(signal.SIGKILL)
        sim.killed_on_purpose = True  # the controller unplugged: its end is not checked
        check("link lost: the 1010 overlay", wait_for(
            lambda: hmi.find_element(By.ID, "error-overlay").is_displayed()
            and text(hmi, "#error-text") == "1010 Master Error", DEADLINE), text(hmi, "#error-text"))
        # Told by the state's link, not by the page knowing the code 1010 (the lint of restated facts).
        check("...which says the controller does not answer", text(hmi, "#error-detail")
              == "No communication with the controller. Every function is disabled.", text(hmi, "#error-detail"))
        hmi.save_screenshot(os.path.join(OUT, "hmi-1010.png"))
        hmi.find_element(By.ID, "ack").click()
        check("the display says since when and what to do", wait_for(
            lambda: hmi.find_element(By.ID, "lost").is_displayed() and "No contact since" in text(hmi, "#lost")
            and "joystick" in text(hmi, "#lost"), DEADLINE), text(hmi, "#lost"))
        check("every control is disabled but Stop", hmi.execute_script(
            "return [...document.querySelectorAll('main button')].filter((b) => b.closest('#units') === null"
            " && b.closest('#phones') === null).every((b) => b.disabled)")
              and hmi.find_element(By.ID, "stop").is_enabled())
        hmi.save_screenshot(os.path.join(OUT, "hmi-lost-1280x800.png"))
        check("the phone says the link is lost, not live", wait_for(
            lambda: phone.find_element(By.ID, "lost").is_displayed() and "No contact since" in text(phone, "#lost"), DEADLINE),
              text(phone, "#lost"))
        check("the phone's controls are disabled", not phone.find_element(By.ID, "fwd").is_enabled())
        phone.save_screenshot(os.path.join(OUT, "phone-lost-390x844.png"))
        # The board's 1024x600 panel with the link lost, its overlay acknowledged.
        small = next(d for d in drivers[1:] if d is not phone and d.get_window_size()["width"] < 1100)
        wait_for(lambda: small.find_element(By.ID, "error-overlay").is_displayed(), DEADLINE)
        small.find_element(By.ID, "ack").click()
        check("1024x600: the lost link shown, acknowledged", wait_for(
            lambda: small.find_element(By.ID, "error-contact").is_displayed()
            and "No contact since" in text(small, "#error-contact") and text(small, "#ack").startswith("Acknowledged"),
            DEADLINE), text(small, "#error-contact"))
        small.save_screenshot(os.path.join(OUT, "hmi-lost-1024x600.png"))
    finally:
        for d in drivers:
            try:
                d.quit()
            except Exception:
                pass
        stop_processes(procs)
    # A sanitizer build (ASan, TSan) reports on the daemon's stderr.
    for name in ("host1.err", "host2.err"):
        path = os.path.join(work, name)
        report = open(path).read() if os.path.exists(path) else ""
        check(f"no sanitizer report from the daemon ({name})", "Sanitizer" not in report, report[:2000])
    shutil.rmtree(work, ignore_errors=True)
    return summary()


if __name__ == "__main__":
    sys.exit(main())
