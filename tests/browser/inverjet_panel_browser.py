#!/usr/bin/python3
"""The Inverjet pool panel in a real browser (Debian's Chromium, headless,
through Selenium), against `rtukit inverjet panel` and the simulated machine
on a pty. Starts what it needs and stops it by PID; its temporary folder is
removed at the end. Waits are for events under generous deadlines (DEADLINE),
never for a fixed time: the test holds on a busy machine.

Usage: inverjet_panel_browser.py RTUKIT OUTDIR
"""
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile

from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import Select

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from browser_common import Console, browser, check, free_port, layout, stop_processes, summary, wait_for  # noqa: E402

RTUKIT, OUT = sys.argv[1], sys.argv[2]
DEADLINE = 20  # s, for what the page, the panel or the simulator shows after an action
os.makedirs(OUT, exist_ok=True)


def text(d, css):
    return d.find_element(By.CSS_SELECTOR, css).text


def fill(d, el, value):
    el.clear()
    el.send_keys(value)


def main():
    work = tempfile.mkdtemp(prefix="rtukit-panel-")
    pty, con_path = os.path.join(work, "jet"), os.path.join(work, "console.sock")
    port = free_port()
    procs, drivers = [], []
    try:
        procs.append(subprocess.Popen([RTUKIT, "sim", "inverjet", "--listen", f"pty:{pty}", "--no-state", "--no-console",
                                       "--console", f"unix:{con_path}"], stdout=subprocess.DEVNULL,
                                      stderr=subprocess.DEVNULL))
        wait_for(lambda: os.path.exists(pty), DEADLINE)
        con = Console(con_path)  # retried until the simulator accepts
        err = open(os.path.join(work, "panel.err"), "w")
        panel = subprocess.Popen([RTUKIT, "inverjet", "panel", "--port", pty, "--http", f"127.0.0.1:{port}"],
                                 stdout=subprocess.PIPE, stderr=err, text=True)
        procs.append(panel)
        check("panel prints its URL", f"http://127.0.0.1:{port}" in panel.stdout.readline())
        d = browser(390, 844)
        drivers.append(d)
        d.get(f"http://127.0.0.1:{port}/")
        check("state as the display shows it", wait_for(lambda: text(d, "#state") == "off"), text(d, "#state"))
        check("plans read from the machine", wait_for(lambda: len(d.find_elements(By.CSS_SELECTOR, "#segments tbody tr")) == 1))
        layout(d, "panel-phone-390x844", OUT, scrolls=True)

        # a timer run started from the page runs on the simulator
        fill(d, d.find_element(By.ID, "speed-in"), "70")
        fill(d, d.find_element(By.ID, "timer-in"), "10:00")
        Select(d.find_element(By.ID, "start-mode")).select_by_value("timer")
        d.find_element(By.ID, "start").click()
        check("the simulator runs the timer run", wait_for(lambda: "timer" in con.ask("get state")
                                                           and "70" in con.ask("get speed"), DEADLINE),
              con.ask("get state"))
        check("the page shows it", wait_for(lambda: text(d, "#state").startswith("timer") and text(d, "#speed") == "70 %",
                                            DEADLINE), text(d, "#state"))
        check("the time counts down", wait_for(lambda: text(d, "#time") not in ("10:00", "00:00"), DEADLINE),
              text(d, "#time"))
        check("live charts draw the run", wait_for(lambda: d.execute_script(
            "const p = document.querySelector('#chart-speed polyline'); return p && p.points.length >= 3"), DEADLINE))
        d.find_element(By.ID, "pause").click()
        check("pause from the page", wait_for(lambda: "paused" in con.ask("get state"), DEADLINE), con.ask("get state"))
        d.find_element(By.ID, "stop").click()
        check("stop from the page", wait_for(lambda: con.ask("get state").startswith("state = off"), DEADLINE),
              con.ask("get state"))

        # edit plan 2: two segments, saved
        d.find_element(By.CSS_SELECTOR, '#plan-tabs [data-plan="2"]').click()
        rows = d.find_elements(By.CSS_SELECTOR, "#segments tbody tr")
        speed, end = rows[0].find_elements(By.TAG_NAME, "input")
        fill(d, speed, "40")
        fill(d, end, "05:00")
        d.find_element(By.ID, "seg-add").click()
        speed, end = d.find_elements(By.CSS_SELECTOR, "#segments tbody tr")[1].find_elements(By.TAG_NAME, "input")
        fill(d, speed, "70")
        fill(d, end, "10:00")
        d.find_element(By.ID, "plan-save").click()
        check("plan 2 saved", wait_for(lambda: "plan 2 saved" in text(d, "#plan-reason"), DEADLINE),
              text(d, "#plan-reason"))
        check("the step chart shows it", d.execute_script(
            "return document.querySelector('#plan-chart polyline').points.length") == 4)

        # an invalid plan is refused on the page with the reason, nothing sent
        d.find_element(By.CSS_SELECTOR, '#plan-tabs [data-plan="3"]').click()
        d.find_element(By.ID, "seg-add").click()
        speed, end = d.find_elements(By.CSS_SELECTOR, "#segments tbody tr")[1].find_elements(By.TAG_NAME, "input")
        fill(d, end, "00:30")
        d.find_element(By.ID, "plan-save").click()
        check("an invalid plan is refused with the reason",
              wait_for(lambda: "not saved: segment 2: end 00:30 is not after 01:00" in text(d, "#plan-reason"),
                       DEADLINE),
              text(d, "#plan-reason"))
        d.save_screenshot(os.path.join(OUT, "panel-invalid-plan.png"))
        # ...and the server refuses one too, even when a page skips the check
        r = d.execute_async_script("""
const done = arguments[arguments.length - 1]; const ws = new WebSocket(`ws://${location.host}/ws`);
ws.onopen = () => ws.send(JSON.stringify({op: 'plan', id: 1, plan: 3, segments: [{speed: 120, end: 60}]}));
ws.onmessage = (e) => { const m = JSON.parse(e.data); if (m.type === 'result') { ws.close(); done(m); } };
setTimeout(() => done(null), 20000);""")
        check("the server refuses a plan the page did not check", r and not r["ok"] and "120" in r["error"], json.dumps(r))

        # a fault injected on the simulator shows, with what to do
        con.ask("fault motor-drive")
        check("the fault shows by name with advice", wait_for(
            lambda: "motor drive" in text(d, "#fault-list") and "motor cable" in text(d, "#fault-list"), DEADLINE),
            text(d, "#fault-list"))
        d.save_screenshot(os.path.join(OUT, "panel-fault.png"))
        con.ask("fault clear")

        tablet = browser(1024, 768)
        drivers.append(tablet)
        tablet.get(f"http://127.0.0.1:{port}/")
        wait_for(lambda: text(tablet, "#state") != "--", DEADLINE)
        layout(tablet, "panel-tablet-1024x768", OUT, scrolls=True)

        # read back with the CLI once the panel let go of the port
        panel.send_signal(signal.SIGTERM)
        check("the panel ends cleanly", panel.wait(DEADLINE) == 0)
        shown = subprocess.run([RTUKIT, "inverjet", "plan", "show", "2", "--port", pty, "--json"], capture_output=True,
                               text=True)
        segments = json.loads(shown.stdout).get("segments") if shown.returncode == 0 else None
        check("the CLI reads plan 2 back", segments is not None and [(x["speed"], x["end"]) for x in segments]
              == [(40, 300), (70, 600)], shown.stdout[:400] + shown.stderr)
        report = open(os.path.join(work, "panel.err")).read()
        check("no sanitizer report from the panel", "Sanitizer" not in report, report[:2000])
    finally:
        for d in drivers:
            try:
                d.quit()
            except Exception:
                pass
        stop_processes(procs)
        shutil.rmtree(work, ignore_errors=True)
    return summary()


if __name__ == "__main__":
    # Stopped by the test runner (its deadline): end through the finally
    # blocks, which stop what was started and remove the temporary folder.
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    sys.exit(main())
