#!/usr/bin/python3
"""End-to-end latency of the Rehand 6600 host daemon (issue: the RK3588 host).

  1. change -> page: the simulator's joystick moved on its console, until the
     motion shown on the HMI page changes (a MutationObserver timestamps it in
     the page), with 1 and 10 HMI pages connected. Side by side, in the same
     run: the same change seen by a client polling GET /api/state every 2 ms
     (no browser, no WebSocket), and the floor, the host's poll period (50 ms).
  2. pointer-up -> register 0: on the phone page, pointer up on "Forward"
     until the controller's phone_forward register reads 0 (probed on the
     simulator's console, ~0.2 ms a probe), with 1 and 10 HMI pages connected.

Usage: bench/rehand_host_latency.py RTUKIT [--cycles N]
Prints a Markdown table for bench/README.md. Not a test: figures, no verdict.
"""
import base64
import hashlib
import json
import os
import statistics
import subprocess
import sys
import time
import urllib.request

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests"))
from pyhelpers import Console, display_request, free_port, pct, stop_processes, temp_dir, wait_for  # noqa: E402

from selenium import webdriver
from selenium.webdriver.chrome.service import Service

RTUKIT = sys.argv[1]
CYCLES = int(sys.argv[sys.argv.index("--cycles") + 1]) if "--cycles" in sys.argv else 40


def now_ms():
    return time.time() * 1000.0


OBSERVE_JS = """
window.__log = [];
const el = document.querySelector('#motion');
new MutationObserver(() => window.__log.push([Date.now(), el.textContent])).observe(el, {childList: true, characterData: true, subtree: true});
"""


def run(pages):
    work = temp_dir("rtukit-bench-host-")  # removed at exit, on every path
    pty, con_path = os.path.join(work, "chair"), os.path.join(work, "console.sock")
    pairing = os.path.join(work, "pairing.json")
    http, phone = free_port(), free_port()
    procs = [subprocess.Popen([RTUKIT, "sim", "rehand6600", "--listen", f"pty:{pty}", "--no-state", "--no-console",
                               "--console", f"unix:{con_path}"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    wait_for(lambda: os.path.exists(con_path) and os.path.exists(pty))
    procs.append(subprocess.Popen([RTUKIT, "rehand6600", "host", "--port", pty, "--http", f"127.0.0.1:{http}",
                                   "--phone", f"127.0.0.1:{phone}", "--pairing-file", pairing],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
    con = Console(con_path)
    state = lambda: json.load(urllib.request.urlopen(f"http://127.0.0.1:{http}/api/state", timeout=2))
    def started():
        try:
            return state()["connected"]
        except OSError:
            return False
    wait_for(started, 10)
    # The phone listener speaks TLS with the certificate the daemon made at
    # its first start: pinned by its SPKI hash, as the browser tests do.
    cert = os.path.join(work, "rehand6600-phone.crt")
    der = subprocess.run(["openssl", "x509", "-in", cert, "-pubkey", "-noout"], capture_output=True, check=True).stdout
    der = subprocess.run(["openssl", "pkey", "-pubin", "-outform", "der"], input=der, capture_output=True,
                         check=True).stdout
    pin = base64.b64encode(hashlib.sha256(der).digest()).decode()
    o = webdriver.ChromeOptions()
    for a in [f"--ignore-certificate-errors-spki-list={pin}", "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
              "--disable-background-networking", "--disable-component-update", "--disable-sync",
              "--disable-dev-shm-usage", "--disable-renderer-backgrounding",
              "--disable-background-timer-throttling", "--disable-backgrounding-occluded-windows",
              f"--user-data-dir={temp_dir('rtukit-chromium-')}"]:
        o.add_argument(a)
    o.binary_location = "/usr/bin/chromium"
    d = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=o)
    d.set_window_size(1280, 800)
    try:
        tabs = []
        for i in range(pages):
            if i:
                d.switch_to.new_window("tab")
            d.get(f"http://127.0.0.1:{http}/")
            wait_for(lambda: d.execute_script("return document.querySelector('#link').textContent") == "connected")
            d.execute_script(OBSERVE_JS)
            tabs.append(d.current_window_handle)

        # 1. change -> page, and the same change seen by an HTTP poller
        starts, polled = [], []
        for _ in range(CYCLES):
            t0 = now_ms()
            con.ask("joystick 0 100")
            starts.append(t0)
            seen = wait_for(lambda: state()["values"]["motion"] != 1, 3, 0.002)
            polled.append(now_ms() - t0 if seen else float("nan"))
            time.sleep(0.25)
            con.ask("joystick 0 0")
            wait_for(lambda: state()["values"]["motion"] == 1, 5, 0.02)
            time.sleep(0.1)
        page = []
        for h in tabs:
            d.switch_to.window(h)
            log = d.execute_script("return window.__log")
            for t0 in starts:
                hits = [ts for ts, text in log if ts >= t0 and text == "forward"]
                if hits:
                    page.append(hits[0] - t0)

        # 2. pointer-up on the phone -> phone_forward reads 0
        d.switch_to.new_window("tab")
        # The page pairs as a user does (its key is the browser's: nothing to
        # write into a file for it), and the display allows it to drive.
        d.get(f"https://127.0.0.1:{phone}/")
        display_request(http, {"op": "pair_start"})
        d.find_element("id", "pair-code").send_keys(state()["pairing_code"])
        d.find_element("id", "pair-go").click()
        wait_for(lambda: d.execute_script("return document.querySelector('#remote').checkVisibility()"), 5)
        display_request(http, {"op": "confirm", "phone": state()["phones"][0]["phone"]})
        release = []
        down_js = ("const b = document.querySelector('#fwd');"
                   "b.dispatchEvent(new PointerEvent('pointerdown', {pointerId: 1, bubbles: true}));")
        up_js = ("const b = document.querySelector('#fwd'); const t = Date.now();"
                 "b.dispatchEvent(new PointerEvent('pointerup', {pointerId: 1, bubbles: true})); return t;")
        for _ in range(CYCLES):
            wait_for(lambda: state()["values"]["motion"] == 1 and state()["values"]["speed"] == 0, 5, 0.02)
            d.execute_script(down_js)
            if not wait_for(lambda: "on" in con.ask("get phone_forward"), 2, 0.005):
                continue
            time.sleep(0.2)
            t0 = d.execute_script(up_js)
            wait_for(lambda: "off" in con.ask("get phone_forward"), 2, 0.0)
            release.append(now_ms() - t0)
            time.sleep(0.3)
        return page, polled, release
    finally:
        d.quit()
        stop_processes(procs)


def main():
    rows = []
    for pages in (1, 10):
        page, polled, release = run(pages)
        rows.append((pages, page, polled, release))
    print(f"cycles per run: {CYCLES}; host poll period 50 ms (20 Hz); pty link at 115200 baud")
    print()
    print("| HMI pages | change -> page p50 / p99 | change -> GET /api/state (2-ms poller, no browser) p50 / p99 |"
          " pointer-up -> register 0 p50 / p99 | samples |")
    print("|---|---|---|---|---|")
    for pages, page, polled, release in rows:
        print(f"| {pages} | {statistics.median(page):.0f} / {pct(page, 99):.0f} ms | "
              f"{statistics.median(polled):.0f} / {pct(polled, 99):.0f} ms | "
              f"{statistics.median(release):.1f} / {pct(release, 99):.1f} ms | {len(page)}, {len(polled)}, {len(release)} |")


if __name__ == "__main__":
    main()
