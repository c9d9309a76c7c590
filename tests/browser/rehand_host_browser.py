#!/usr/bin/python3
"""The Rehand 6600 host daemon's pages in a real browser (Debian's Chromium,
headless, driven by Selenium through chromedriver), against the simulated
controller on a pty. Starts what it needs, stops it by PID.

Usage: rehand_host_browser.py RTUKIT OUTDIR
Prints one line per check ("ok NAME ..." / "FAIL NAME ..."), figures as
"figure NAME VALUE"; exits 1 when a check failed. Screenshots go to OUTDIR.
"""
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request

from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from browser_common import Console, browser, check, free_port, layout, stop_processes, summary, wait_for  # noqa: E402

RTUKIT, OUT = sys.argv[1], sys.argv[2]
os.makedirs(OUT, exist_ok=True)
def state(port, token=None):
    url = f"http://127.0.0.1:{port}/api/state" + (f"?token={token}" if token else "")
    with urllib.request.urlopen(url, timeout=2) as r:
        return json.load(r)


def _try(fn):
    try:
        return fn()
    except Exception:
        return None


def text(d, css):
    return d.find_element(By.CSS_SELECTOR, css).text


def main():
    work = tempfile.mkdtemp(prefix="rtukit-rehand-host-")
    pty, console_path = os.path.join(work, "chair"), os.path.join(work, "console.sock")
    http_port, phone_port = free_port(), free_port()
    procs = []
    drivers = []
    try:
        sim = subprocess.Popen([RTUKIT, "sim", "rehand6600", "--listen", f"pty:{pty}", "--no-state", "--no-console",
                                "--console", f"unix:{console_path}"], stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)
        procs.append(sim)
        wait_for(lambda: os.path.exists(console_path) and os.path.exists(pty))
        host = subprocess.Popen([RTUKIT, "rehand6600", "host", "--port", pty, "--http", f"127.0.0.1:{http_port}",
                                 "--phone", f"127.0.0.1:{phone_port}", "--pairing-file",
                                 os.path.join(work, "pairing.json")], stdout=subprocess.PIPE,
                                stderr=open(os.path.join(work, "host1.err"), "w"), text=True)
        procs.append(host)
        check("daemon prints the display URL", f"http://127.0.0.1:{http_port}" in host.stdout.readline())
        con = Console(console_path)
        check("host connected", wait_for(lambda: state(http_port)["connected"], 5))

        # ---- the display at 1280x800
        hmi = browser(1280, 800)
        drivers.append(hmi)
        hmi.get(f"http://127.0.0.1:{http_port}/")
        check("hmi shows the battery", wait_for(lambda: text(hmi, "#battery").startswith("80 %")))

        # live values follow the simulator
        t0 = time.monotonic()
        con.s.sendall(b"joystick 0 100\n")
        moved = wait_for(lambda: text(hmi, "#motion") == "forward", 3, 0.005)
        latency = (time.monotonic() - t0) * 1000
        check("joystick on the simulator shows on the page", bool(moved), f"{latency:.0f} ms")
        print(f"figure joystick_to_page_ms {latency:.0f}")
        check("within 500 ms", latency < 500, f"{latency:.0f} ms")
        con.cmd("joystick 0 0")
        wait_for(lambda: text(hmi, "#speed") == "0 km/h", 5)
        layout(hmi, "hmi-1280x800", OUT)

        # press and hold a posture: moves while held, stops on release
        up = hmi.find_element(By.CSS_SELECTOR, '[data-cmd="seat_lift"][data-value="up"]')
        ActionChains(hmi).click_and_hold(up).perform()
        time.sleep(1.0)
        held_pos = state(http_port)["values"]["actuator1_position"]
        check("seat lift moves while held", held_pos > 0, f"{held_pos} per-mille")
        check("the controller holds seat_lift", "seat_lift=1" in con.held())
        ActionChains(hmi).release(up).perform()
        time.sleep(0.4)
        stopped = state(http_port)["values"]["actuator1_position"]
        time.sleep(0.6)
        check("seat lift stops on release", state(http_port)["values"]["actuator1_position"] == stopped,
              f"{stopped} per-mille")
        check("nothing held after release", "seat_lift" not in con.held())

        # closing the tab while holding stops within the lease
        hmi.switch_to.new_window("tab")
        hmi.get(f"http://127.0.0.1:{http_port}/")
        wait_for(lambda: text(hmi, "#battery").startswith("80 %"))
        down = hmi.find_element(By.CSS_SELECTOR, '[data-cmd="seat_lift"][data-value="down"]')
        ActionChains(hmi).click_and_hold(down).perform()
        time.sleep(0.5)
        check("the second tab holds seat_lift down", "seat_lift=2" in con.held())
        t0 = time.monotonic()
        hmi.close()
        gone = wait_for(lambda: "seat_lift" not in con.held(), 2, 0.02)
        check("closing the tab releases within the lease", bool(gone), f"{(time.monotonic() - t0) * 1000:.0f} ms")
        hmi.switch_to.window(hmi.window_handles[0])

        # error overlay; clearing restarts nothing (D-8)
        leg = hmi.find_element(By.CSS_SELECTOR, '[data-cmd="leg_rotate"][data-value="up"]')
        ActionChains(hmi).click_and_hold(leg).perform()
        time.sleep(0.5)
        con.cmd("error 10C3")
        overlay = wait_for(lambda: hmi.find_element(By.ID, "error-overlay").is_displayed(), 3)
        check("error overlay shown", bool(overlay), text(hmi, "#error-text"))
        check("overlay text is table 3's", text(hmi, "#error-text") == "10C3 Seat lift Error", text(hmi, "#error-text"))
        check("buttons disabled under the overlay", not leg.is_enabled())
        hmi.save_screenshot(os.path.join(OUT, "hmi-error-overlay.png"))
        con.cmd("error clear")
        time.sleep(1.5)  # the finger is still down
        pos = state(http_port)["values"]["actuator4_position"]
        time.sleep(1.0)
        check("clearing the error restarts nothing (D-8)", state(http_port)["values"]["actuator4_position"] == pos
              and "leg_rotate" not in con.held(), f"held: {con.held()}")
        check("overlay stays until acknowledged", hmi.find_element(By.ID, "error-overlay").is_displayed())
        ActionChains(hmi).release().perform()
        hmi.find_element(By.ID, "ack").click()
        check("acknowledged overlay goes away", wait_for(lambda: not hmi.find_element(By.ID, "error-overlay").is_displayed()))


        # ---- the API: bad input gets a clear error on that connection and changes nothing
        API_JS = """
const [url, msgs, done] = [arguments[0], arguments[1], arguments[arguments.length - 1]];
const ws = new WebSocket(url); const out = []; let n = 0;
ws.onmessage = (e) => { const m = JSON.parse(e.data); if (m.type === 'result' || m.type === 'error') out.push(m);
  if (out.length === msgs.length) { ws.close(); done(out); } };
ws.onopen = () => { for (const m of msgs) ws.send(typeof m === 'string' ? m : JSON.stringify(m)); };
ws.onclose = (e) => done(out.length === msgs.length ? out : {closed: e.reason, got: out});
setTimeout(() => done({timeout: out}), 4000);
"""
        ws_display = f"ws://127.0.0.1:{http_port}/ws?role=display"
        replies = hmi.execute_async_script(API_JS, ws_display, [
            "not json", {"op": "fly"}, {"op": "hold", "command": 5}, {"op": "hold", "command": "phone_forward", "value": 1},
            {"op": "set", "key": "speed_level", "value": 9}, {"op": "hold", "command": "seat_lift", "value": "sideways"},
            {"op": "set", "key": "speed_level", "value": [1]}])
        expect = ["JSON object", "unknown command 'fly'", "must be a register key", "not a command this page may send",
                  "speed_level", "sideways", "must be a name or a number"]
        ok = isinstance(replies, list) and len(replies) == len(expect) and all(
            (not r.get("ok", False)) and e in r.get("error", "") for r, e in zip(replies, expect))
        check("bad API input: a clear error each", ok, json.dumps(replies)[:400])
        check("bad API input changed nothing", state(http_port)["speed_level"] == 1 and "seat_lift" not in con.held())
        ws_phone = f"ws://127.0.0.1:{phone_port}/ws?role=phone"
        replies = hmi.execute_async_script(API_JS, ws_phone, [{"op": "drive", "dir": "forward"}])
        check("an unpaired phone commands nothing", isinstance(replies, list) and "not paired" in replies[0].get("error", ""),
              json.dumps(replies)[:200])
        FLOOD_JS = """
const [url, done] = [arguments[0], arguments[arguments.length - 1]];
const ws = new WebSocket(url);
ws.onopen = () => { for (let i = 0; i < 3000; ++i) ws.send('{"op":"nothing"}'); };
ws.onclose = (e) => done(e.reason || 'closed');
setTimeout(() => done('still open'), 5000);
"""
        before = state(http_port)["values"]["battery"]
        reason = hmi.execute_async_script(FLOOD_JS, ws_display)
        check("a flooding client is dropped", reason == "too many messages", str(reason))
        check("the poll loop went on", wait_for(lambda: state(http_port)["connected"]) and before is not None)

        # the display at 1920x1080
        big = browser(1920, 1080)
        drivers.append(big)
        big.get(f"http://127.0.0.1:{http_port}/")
        wait_for(lambda: text(big, "#battery").startswith("80 %"))
        layout(big, "hmi-1920x1080", OUT)

        # ---- the phone: unpaired clients see and command nothing
        try:
            urllib.request.urlopen(f"http://127.0.0.1:{phone_port}/api/state", timeout=2)
            check("unpaired state refused", False)
        except urllib.error.HTTPError as e:
            check("unpaired state refused", e.code == 401, str(e.code))
        phone = browser(390, 844)
        drivers.append(phone)
        phone.get(f"http://127.0.0.1:{phone_port}/")
        check("unpaired phone shows the pairing form", wait_for(lambda: phone.find_element(By.ID, "pairing").is_displayed()))
        check("unpaired phone shows no state", phone.find_element(By.ID, "battery").text in ("", "--"))
        layout(phone, "phone-pairing-390x844", OUT)
        phone.find_element(By.ID, "pair-code").send_keys("123456")
        phone.find_element(By.ID, "pair-go").click()
        check("no code shown: refused with the reason",
              wait_for(lambda: "ask the display" in text(phone, "#pair-reason") or "wrong" in text(phone, "#pair-reason")),
              text(phone, "#pair-reason"))

        hmi.find_element(By.ID, "pair").click()
        code = wait_for(lambda: re.fullmatch(r"\d{6}", text(hmi, "#code")) and text(hmi, "#code"))
        check("the display shows a one-time code", bool(code), str(code))
        hmi.save_screenshot(os.path.join(OUT, "hmi-pairing-code.png"))
        # The QR code, read by zbar (a decoder we did not write), opens the
        # phone page with the code filled in.
        qr = hmi.find_element(By.ID, "qr")
        wait_for(lambda: hmi.execute_script("return arguments[0].complete && arguments[0].naturalWidth > 0", qr))
        qr.screenshot(os.path.join(OUT, "pairing-qr.png"))
        decoded = subprocess.run(["zbarimg", "-q", "--raw", os.path.join(OUT, "pairing-qr.png")],
                                 capture_output=True, text=True).stdout.strip()
        check("the QR code holds the phone address and the code",
              decoded == f"http://127.0.0.1:{phone_port}/?code={code}", decoded)
        phone.get(decoded or f"http://127.0.0.1:{phone_port}/")
        check("the code is filled in from the QR code",
              wait_for(lambda: phone.find_element(By.ID, "pair-code").get_attribute("value") == code),
              phone.find_element(By.ID, "pair-code").get_attribute("value"))
        phone.find_element(By.ID, "pair-name").send_keys("Test phone")
        phone.find_element(By.ID, "pair-go").click()
        check("phone paired", wait_for(lambda: phone.find_element(By.ID, "remote").is_displayed()
                                       and re.fullmatch(r"\d+ %", text(phone, "#battery")), 5))
        check("the display lists the phone", wait_for(lambda: "Test phone" in text(hmi, "#phone-list")))
        layout(phone, "phone-remote-390x844", OUT)

        # D-10: the seat is still raised from the posture checks
        check("raised: the phone shows why it cannot drive",
              wait_for(lambda: "not fully seated" in text(phone, "#reason")), text(phone, "#reason"))
        down = hmi.find_element(By.CSS_SELECTOR, '[data-cmd="seat_lift"][data-value="down"]')
        ActionChains(hmi).click_and_hold(down).perform()
        wait_for(lambda: state(http_port)["values"]["actuator1_position"] == 0, 5)
        ActionChains(hmi).release(down).perform()
        check("seated again: the phone may drive", wait_for(lambda: text(phone, "#reason") == "", 3),
              text(phone, "#reason"))

        # driving is held while the finger is down, and released
        fwd = phone.find_element(By.ID, "fwd")
        ActionChains(phone).click_and_hold(fwd).perform()
        drove = wait_for(lambda: state(http_port)["values"]["speed"] > 0, 3)
        check("phone forward drives the chair", bool(drove), con.held())
        check("the display shows which phone drives", "driving" in text(hmi, "#phone-list"))
        t0 = time.monotonic()
        ActionChains(phone).release(fwd).perform()
        released = wait_for(lambda: "phone_forward" not in con.held(), 2, 0.005)
        print(f"figure phone_release_to_register_ms {(time.monotonic() - t0) * 1000:.0f}")
        check("release writes 0", bool(released))

        # refused while charging, with the reason
        con.cmd("charger on")
        wait_for(lambda: state(http_port)["values"]["charging"] == 1)
        reason = wait_for(lambda: "charging" in text(phone, "#reason") and text(phone, "#reason"), 3)
        check("phone shows why it cannot drive", bool(reason), text(phone, "#reason"))
        check("drive buttons disabled while charging", not phone.find_element(By.ID, "fwd").is_enabled())
        phone.save_screenshot(os.path.join(OUT, "phone-charging.png"))
        con.cmd("charger off")
        wait_for(lambda: phone.find_element(By.ID, "fwd").is_enabled(), 3)

        # a phone that stops renewing (socket still open: Wi-Fi gone quiet) is
        # released by the lease
        phone_token = phone.execute_script("return localStorage.getItem('rtukit-rehand6600-token')")
        SILENT_JS = """
const [url, done] = [arguments[0], arguments[arguments.length - 1]];
const ws = new WebSocket(url); window.__silent = ws;
ws.onmessage = (e) => { const m = JSON.parse(e.data); if (m.type === 'result') done(m); };
ws.onopen = () => ws.send(JSON.stringify({op: 'drive', dir: 'forward', id: 1}));
setTimeout(() => done({timeout: true}), 3000);
"""
        wait_for(lambda: state(http_port)["values"]["motion"] == 1 and state(http_port)["values"]["speed"] == 0, 5)
        first = hmi.execute_async_script(SILENT_JS, f"ws://127.0.0.1:{phone_port}/ws?role=phone&token={phone_token}")
        t0 = time.monotonic()
        check("one drive command accepted", first.get("ok") is True, json.dumps(first))
        gone = wait_for(lambda: "phone_forward" not in con.held(), 2, 0.005)
        dt = (time.monotonic() - t0) * 1000
        check("no renewal: released by the lease (socket still open)", bool(gone) and 150 < dt < 300 + 50 + 150,  # t0 is taken a Selenium round trip after the hold
              f"{dt:.0f} ms")
        check("the silent socket is still open", hmi.execute_script("return window.__silent.readyState") == 1)
        hmi.execute_script("window.__silent.close()")

        # a killed phone stops the chair within lease + poll
        fwd = phone.find_element(By.ID, "fwd")
        ActionChains(phone).click_and_hold(fwd).perform()
        wait_for(lambda: "phone_forward=1" in con.held(), 3)
        t0 = time.monotonic()
        subprocess.run(["pkill", "-9", "-f", phone.user_data_dir])  # the phone's browser dies
        stopped = wait_for(lambda: "phone_forward" not in con.held(), 3, 0.01)
        dt = (time.monotonic() - t0) * 1000
        check("killed phone: the drive command is 0 within lease + poll", bool(stopped) and dt < 350 + 200,
              f"{dt:.0f} ms")

        # pairing survives a restart of the daemon (stored atomically)
        token = json.load(open(os.path.join(work, "pairing.json")))["phones"][0]["token"]
        check("pairing file is private", (os.stat(os.path.join(work, "pairing.json")).st_mode & 0o077) == 0)
        host.send_signal(signal.SIGTERM)
        code = host.wait(10)
        check("the daemon ends cleanly on SIGTERM", code == 0, f"exit {code}")
        host = subprocess.Popen([RTUKIT, "rehand6600", "host", "--port", pty, "--http", f"127.0.0.1:{http_port}",
                                 "--phone", f"127.0.0.1:{phone_port}", "--pairing-file",
                                 os.path.join(work, "pairing.json")], stdout=subprocess.DEVNULL,
                                stderr=open(os.path.join(work, "host2.err"), "w"))
        procs.append(host)
        check("after a restart the paired phone is still paired",
              wait_for(lambda: _try(lambda: state(phone_port, token)["connected"]), 8))
        drivers.remove(phone)
        try:
            phone.quit()
        except Exception:
            pass

        # the controller unplugged: Master error 1010 covers the display
        hmi.refresh()
        wait_for(lambda: text(hmi, "#link") == "connected", 8)
        sim.send_signal(signal.SIGKILL)
        check("link lost: the 1010 overlay", wait_for(
            lambda: hmi.find_element(By.ID, "error-overlay").is_displayed()
            and text(hmi, "#error-text") == "1010 Master Error", 5), text(hmi, "#error-text"))
        hmi.save_screenshot(os.path.join(OUT, "hmi-1010.png"))
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
    return summary()


if __name__ == "__main__":
    sys.exit(main())
