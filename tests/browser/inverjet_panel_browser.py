#!/usr/bin/python3
"""The Inverjet pool panel in a real browser (Debian's Chromium, headless,
through Selenium), against `rtukit inverjet panel` over TLS with a password
and the simulated machine on a pty. Starts what it needs and stops it by PID;
its temporary folder is removed at the end. Waits are for events under
generous deadlines (DEADLINE), never for a fixed time: the test holds on a
busy machine.

What a swimmer needs, checked in the page: the login; state, time and speed
readable from the water (time and speed at least 15 % of the screen's height
on a phone and a wall tablet, the state never cut off); durations in one
format (a bare "30" refused with an example, nothing sent); an empty speed
refused; speeds above 80 % and a start over a running run ask first (in-page
dialog); unsaved plan edits kept across tabs; touch targets of 48 px, 8 px
apart; a lost machine never looks live (controls off, "No contact since",
what to do) and the page recovers by itself; faults and refusals with advice
that clear themselves. Screenshots in OUTDIR.

Usage: inverjet_panel_browser.py RTUKIT OUTDIR
"""
import functools
import http.server
import json
import os
import re
import signal
import subprocess
import sys
import threading

from selenium.common.exceptions import WebDriverException
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import Select

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from browser_common import (Console, accessibility_violations, browser, check, free_port, layout, stop_processes, summary,  # noqa: E402
                            temp_dir, wait_for)
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from pyhelpers import START_DEADLINE, WebSocket, start  # noqa: E402

RTUKIT, OUT = sys.argv[1], sys.argv[2]
DEADLINE = 20  # s, for what the page, the panel or the simulator shows after an action
PASSWORD = "lane-four-fast"
os.makedirs(OUT, exist_ok=True)


def text(d, css):
    """The element's text; "" while a page is loading (no such element yet)."""
    try:
        return d.find_element(By.CSS_SELECTOR, css).text
    except WebDriverException:
        return ""


def fill(d, el, value):
    el.clear()
    el.send_keys(value)


def click(d, css):
    d.find_element(By.CSS_SELECTOR, css).click()


# Every command the page sends: not its pings, nor its checks of what was
# typed (the panel reads those by the device layer's rules and nothing runs:
# "nothing was sent" means no command). The checks are kept apart.
SPY = """
if (!window.__sent) {
  window.__sent = [];
  window.__checks = [];
  const send = WebSocket.prototype.send;
  WebSocket.prototype.send = function (data) {
    try {
      const m = JSON.parse(data);
      if (m.op === 'check') window.__checks.push(m); else if (m.op !== 'ping') window.__sent.push(m);
    } catch (e) {}
    return send.call(this, data);
  };
}"""


def sent(d):
    return d.execute_script("return window.__sent.map((m) => m.op)")


def clear_sent(d):
    d.execute_script("window.__sent.length = 0")


SIZES_JS = """
const h = innerHeight, r = (id) => document.getElementById(id).getBoundingClientRect();
const st = document.getElementById('state');
return {vh: h, time: r('time').height / h, speed: r('speed').height / h,
        state_fits: st.scrollWidth <= st.clientWidth && st.scrollHeight <= st.clientHeight + 1,
        state_ellipsis: getComputedStyle(st).textOverflow === 'ellipsis',
        page_fits: document.documentElement.scrollWidth <= innerWidth};
"""

# Touch targets: every visible button, input and select at least 48x48 px,
# and at least 8 px from every other one.
TARGETS_JS = """
const vis = (e) => { const r = e.getBoundingClientRect(); return r.width > 0 && r.height > 0 && !e.closest('.hidden'); };
const els = [...document.querySelectorAll('button, input, select')].filter(vis);
const name = (e) => e.id || e.getAttribute('aria-label') || e.textContent.trim();
const small = [], close = [];
for (const e of els) { const r = e.getBoundingClientRect(); if (r.width < 48 || r.height < 48) small.push(`${name(e)} ${Math.round(r.width)}x${Math.round(r.height)}`); }
for (let i = 0; i < els.length; ++i) for (let j = i + 1; j < els.length; ++j) {
  const a = els[i].getBoundingClientRect(), b = els[j].getBoundingClientRect();
  const gap = Math.max(b.left - a.right, a.left - b.right, b.top - a.bottom, a.top - b.bottom);
  if (gap < 7.5) close.push(`${name(els[i])} / ${name(els[j])} ${gap.toFixed(1)} px`);
}
return {count: els.length, small, close};
"""


def readable(d, where):
    s = d.execute_script(SIZES_JS)
    check(f"{where}: time takes >= 15 % of the height", s["time"] >= 0.15, f"{s['time']:.3f}")
    check(f"{where}: speed takes >= 15 % of the height", s["speed"] >= 0.15, f"{s['speed']:.3f}")
    check(f"{where}: the state is not cut off", s["state_fits"] and not s["state_ellipsis"], text(d, "#state"))
    check(f"{where}: nothing scrolls sideways", s["page_fits"])


def targets(d, where):
    t = d.execute_script(TARGETS_JS)
    check(f"{where}: every touch target >= 48x48 px ({t['count']})", not t["small"], "; ".join(t["small"][:6]))
    check(f"{where}: touch targets >= 8 px apart", not t["close"], "; ".join(t["close"][:6]))


def log_in(d, url):
    d.get(url + "/")
    check("without a session the page sends to the login", wait_for(lambda: d.current_url.endswith("/login"), DEADLINE),
          d.current_url)
    return d


# A page of another origin, in the same browser, that tries what a web page on
# the pool's network would: open the panel's WebSocket and start the machine.
FOREIGN_PAGE = """<!doctype html><title>waiting</title><script>
const ws = new WebSocket("wss://127.0.0.1:%d/ws");
ws.onopen = () => { document.title = "open";
  ws.send(JSON.stringify({op: "start", id: 1, mode: "free", speed: 35})); };
ws.onclose = () => { if (document.title !== "open") document.title = "refused"; };
</script>"""


def serve_foreign_page(folder, panel_port):
    """Serves FOREIGN_PAGE on a port of its own (another origin); its URL."""
    with open(os.path.join(folder, "evil.html"), "w") as f:
        f.write(FOREIGN_PAGE % panel_port)
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=folder)
    handler.log_message = lambda *a: None
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return f"http://127.0.0.1:{server.server_address[1]}/evil.html"


def main():
    work = temp_dir("rtukit-panel-")  # removed at exit, on every path
    pty, con_path = os.path.join(work, "jet"), os.path.join(work, "console.sock")
    pw, cert, key = (os.path.join(work, n) for n in ("panel.pw", "panel.crt", "panel.key"))
    port = free_port()
    url = f"https://127.0.0.1:{port}"
    procs, drivers = [], []
    try:
        sim = start([RTUKIT, "sim", "inverjet", "--listen", f"pty:{pty}", "--no-state", "--no-console",
                     "--console", f"unix:{con_path}"], work)
        procs.append(sim)
        wait_for(lambda: os.path.exists(pty), START_DEADLINE)
        con = Console(con_path)  # retried until the simulator accepts
        made = subprocess.run([RTUKIT, "inverjet", "panel-password", pw], input=PASSWORD + "\n", text=True,
                              capture_output=True)
        check("panel-password makes the password file", made.returncode == 0, made.stderr)
        subprocess.run(["openssl", "req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:P-256", "-nodes",
                        "-keyout", key, "-out", cert, "-days", "2", "-subj", "/CN=127.0.0.1", "-addext",
                        "subjectAltName=IP:127.0.0.1"], check=True, capture_output=True)
        err = open(os.path.join(work, "panel.err"), "w")
        panel = start([RTUKIT, "inverjet", "panel", "--port", pty, "--http", f"127.0.0.1:{port}",
                       "--password-file", pw, "--tls-cert", cert, "--tls-key", key], work,
                      stdout=subprocess.PIPE, stderr=err, text=True)
        procs.append(panel)
        check("panel prints its https URL", url in panel.stdout.readline())

        # A forged Origin is refused, and the machine does not start.
        try:
            WebSocket(port, "/ws", tls=True, headers={"Origin": "https://evil.example"})
            refused = ""
        except OSError as e:
            refused = str(e)
        check("a WebSocket from a foreign origin is refused", "403" in refused, refused)
        try:
            WebSocket(port, "/ws", tls=True, headers={"Origin": url})
            refused = ""
        except OSError as e:
            refused = str(e)
        check("...and from our origin without a session", "401" in refused, refused)
        check("the machine did not start", con.ask("get state").startswith("state = off"), con.ask("get state"))

        ignore = ["--ignore-certificate-errors"]
        d = log_in(browser(390, 844, ignore), url)
        drivers.append(d)
        d.save_screenshot(os.path.join(OUT, "panel-login-390x844.png"))
        fill(d, d.find_element(By.ID, "password"), "not-the-password")
        click(d, "#login")
        check("a wrong password is refused on the login page",
              wait_for(lambda: "Wrong password" in text(d, "#why"), DEADLINE), text(d, "#why"))
        fill(d, d.find_element(By.ID, "password"), PASSWORD)
        click(d, "#login")
        check("the right password opens the panel", wait_for(lambda: d.current_url == url + "/", DEADLINE), d.current_url)
        check("the session cookie is not readable by scripts (HttpOnly)",
              "rtukit_panel" not in d.execute_script("return document.cookie"))
        # The attack in the browser itself, logged in: a page of another
        # origin opens the panel's WebSocket (the old panel started the
        # machine at 35 % this way). Refused before any handler (Origin).
        evil_dir = os.path.join(work, "evil")
        os.mkdir(evil_dir)
        d.get(serve_foreign_page(evil_dir, port))
        check("Chromium: a page of another origin cannot open the panel's WebSocket",
              wait_for(lambda: d.title in ("refused", "open"), DEADLINE) and d.title == "refused", d.title)
        check("...and the machine did not start", con.ask("get state").startswith("state = off"), con.ask("get state"))
        d.get(url + "/")
        d.execute_script(SPY)
        check("state as the display shows it", wait_for(lambda: text(d, "#state") == "off", DEADLINE), text(d, "#state"))
        check("...with no mode while nothing runs (it read \"mode: free\")", text(d, "#mode") == "", text(d, "#mode"))
        check("...and the plans the machine has, from its limits", d.execute_script(
            "return [...document.querySelectorAll('#plan-tabs button')].map((b) => b.textContent).join()")
              == "Plan 1,Plan 2,Plan 3,Plan 4" and d.execute_script(
            "return [...document.querySelectorAll('#start-mode option')].filter((o) => o.value.startsWith('plan')).length")
              == 4)
        check("Start sits below the fields it uses", d.execute_script(
            "return document.getElementById('start').getBoundingClientRect().top > "
            "document.getElementById('speed-in').getBoundingClientRect().bottom"))
        check("plans read from the machine",
              wait_for(lambda: len(d.find_elements(By.CSS_SELECTOR, "#segments .seg")) == 1, DEADLINE))
        check("the log out button shows with a password", d.find_element(By.CSS_SELECTOR, "#logout button").is_displayed())
        readable(d, "phone 390x844")
        targets(d, "phone 390x844")
        layout(d, "panel-phone-390x844", OUT, scrolls=True)

        # Durations in one format: a bare number is refused with an example, nothing sent.
        Select(d.find_element(By.ID, "start-mode")).select_by_value("timer")
        fill(d, d.find_element(By.ID, "speed-in"), "60")
        fill(d, d.find_element(By.ID, "timer-in"), "30")
        clear_sent(d)
        click(d, "#start")
        check("a bare 30 is refused with an example", wait_for(lambda: "write 30:00, 30m or 90s" in text(d, "#reason"),
                                                               DEADLINE), text(d, "#reason"))
        check("...and nothing is sent", sent(d) == [], json.dumps(sent(d)))
        check("...read by the panel (the device layer's parser: the page parses no time)",
              d.execute_script("return window.__checks.some((m) => m.start && m.start.duration === '30')"),
              json.dumps(d.execute_script("return window.__checks.slice(-3)")))
        # "30M": the page's own parser took it, the CLI and the panel's commands did not.
        fill(d, d.find_element(By.ID, "timer-in"), "30M")
        click(d, "#start")
        check("a time the CLI refuses is refused here too", wait_for(lambda: "\"30M\" is not a time" in text(d, "#reason"),
                                                                     DEADLINE), text(d, "#reason"))
        check("...and nothing is sent", sent(d) == [], json.dumps(sent(d)))
        fill(d, d.find_element(By.ID, "timer-in"), "30m")
        check("the refusal goes away when the time is right", wait_for(lambda: text(d, "#reason") == "", DEADLINE),
              text(d, "#reason"))
        fill(d, d.find_element(By.ID, "speed-in"), "")
        click(d, "#start")
        check("an empty speed is refused with the reason", wait_for(lambda: "Speed is empty" in text(d, "#reason"),
                                                                    DEADLINE), text(d, "#reason"))
        check("...and nothing is sent (never 0 %)", sent(d) == [], json.dumps(sent(d)))
        d.save_screenshot(os.path.join(OUT, "panel-phone-refused.png"))
        # A speed above 80 % asks first; Cancel sends nothing.
        fill(d, d.find_element(By.ID, "speed-in"), "90")
        click(d, "#start")
        check("90 % asks for confirmation", wait_for(lambda: d.find_element(By.ID, "confirm").is_displayed()
                                                     and "90 %" in text(d, "#confirm-text"), DEADLINE))
        d.save_screenshot(os.path.join(OUT, "panel-phone-confirm.png"))
        targets(d, "the confirmation")
        click(d, "#confirm-no")
        check("...Cancel sends nothing", not d.find_element(By.ID, "confirm").is_displayed() and sent(d) == [],
              json.dumps(sent(d)))
        check("the machine is still off", con.ask("get state").startswith("state = off"), con.ask("get state"))

        # A timer run started from the page runs on the simulator.
        fill(d, d.find_element(By.ID, "speed-in"), "70")
        fill(d, d.find_element(By.ID, "timer-in"), "10:00")
        click(d, "#start")
        check("a 70 % start asks nothing", not d.find_element(By.ID, "confirm").is_displayed())
        check("the duration is sent as mm:ss", wait_for(lambda: d.execute_script(
            "return window.__sent.some((m) => m.op === 'start' && m.mode === 'timer' && m.duration === '10:00' "
            "&& m.speed === 70)"), DEADLINE), json.dumps(d.execute_script("return window.__sent")))
        check("the simulator runs the timer run", wait_for(lambda: "timer" in con.ask("get state")
                                                           and "70" in con.ask("get speed"), DEADLINE),
              con.ask("get state"))
        check("the page shows it", wait_for(lambda: text(d, "#state").startswith("timer") and text(d, "#speed") == "70 %",
                                            DEADLINE), text(d, "#state"))
        check("the time counts down", wait_for(lambda: text(d, "#time") not in ("10:00", "00:00"), DEADLINE),
              text(d, "#time"))
        check("live charts draw the run", wait_for(lambda: d.execute_script(
            "const p = document.querySelector('#chart-speed polyline'); return p && p.points.length >= 3"), DEADLINE))
        wait_for(lambda: text(d, "#state") == "timer running", DEADLINE)
        readable(d, "phone, running")
        d.execute_script("window.scrollTo(0, 0)")
        d.save_screenshot(os.path.join(OUT, "panel-phone-running.png"))

        # Starting over a running run asks first; Yes starts.
        clear_sent(d)
        fill(d, d.find_element(By.ID, "speed-in"), "50")
        click(d, "#start")
        check("a start over a running run asks", wait_for(lambda: d.find_element(By.ID, "confirm").is_displayed()
                                                          and "A run is going" in text(d, "#confirm-text"), DEADLINE),
              text(d, "#confirm-text"))
        check("...and sends nothing before the answer", sent(d) == [], json.dumps(sent(d)))
        click(d, "#confirm-yes")
        check("...Yes starts it again", wait_for(lambda: "50" in con.ask("get speed"), DEADLINE), con.ask("get speed"))

        # The wall tablet.
        t = log_in(browser(1280, 800, ignore), url)
        drivers.append(t)
        fill(t, t.find_element(By.ID, "password"), PASSWORD)
        click(t, "#login")
        check("tablet: logged in", wait_for(lambda: t.current_url == url + "/", DEADLINE), t.current_url)
        check("tablet: shows the run", wait_for(lambda: text(t, "#state") == "timer running", DEADLINE),
              text(t, "#state"))
        readable(t, "tablet 1280x800")
        targets(t, "tablet 1280x800")
        layout(t, "panel-tablet-1280x800", OUT, scrolls=True)
        v = accessibility_violations(t)
        check("the pool panel: no WCAG 2.2 A/AA violation (axe-core)", not v, "; ".join(v))

        # The machine stops answering: nothing looks live, controls off, what to do.
        sim.send_signal(signal.SIGSTOP)
        for who, b in (("phone", d), ("tablet", t)):
            check(f"{who}: no contact shows", wait_for(lambda: "No contact since" in text(b, "#lost-title"),
                                                      DEADLINE + 10), text(b, "#lost"))
            check(f"{who}: says what to do", "press Stop on the machine itself" in text(b, "#lost"), text(b, "#lost"))
            check(f"{who}: every run control is disabled", b.execute_script(
                "return [...document.querySelectorAll('#run button, #run input, #run select, #plan-save')]"
                ".every((e) => e.disabled)"))
            check(f"{who}: the values are greyed", b.execute_script(
                "return getComputedStyle(document.getElementById('time')).color") != "rgb(255, 255, 255)")
            check(f"{who}: Start and Stop lose their colours (nothing looks usable)", b.execute_script(
                "return ['start', 'stop'].map((id) => getComputedStyle(document.getElementById(id)).backgroundColor)")
                  == ["rgb(21, 65, 95)"] * 2)
        readable(d, "phone, lost")
        d.execute_script("window.scrollTo(0, 0)")
        d.save_screenshot(os.path.join(OUT, "panel-phone-lost.png"))
        t.save_screenshot(os.path.join(OUT, "panel-tablet-lost.png"))
        sim.send_signal(signal.SIGCONT)
        for who, b in (("phone", d), ("tablet", t)):
            check(f"{who}: recovers by itself", wait_for(lambda: not b.find_element(By.ID, "lost").is_displayed()
                                                         and b.find_element(By.ID, "stop").is_enabled(), DEADLINE + 10),
                  text(b, "#lost"))

        d.find_element(By.ID, "stop").click()
        check("stop from the page", wait_for(lambda: con.ask("get state").startswith("state = off"), DEADLINE),
              con.ask("get state"))
        # The wall tablet at rest ("normal"): the machine off, the last run's charts kept.
        check("tablet: shows the machine off", wait_for(lambda: text(t, "#state") == "off"
                                                        and not t.find_element(By.ID, "lost").is_displayed(), DEADLINE),
              text(t, "#state"))
        readable(t, "tablet 1280x800, idle")
        t.execute_script("window.scrollTo(0, 0)")
        layout(t, "panel-tablet-idle-1280x800", OUT, scrolls=True)

        # Plans: unsaved edits survive a change of tab.
        click(d, '#plan-tabs [data-plan="2"]')
        speed, end = d.find_elements(By.CSS_SELECTOR, "#segments .seg")[0].find_elements(By.TAG_NAME, "input")
        fill(d, speed, "40")
        fill(d, end, "05:00")
        click(d, '#plan-tabs [data-plan="3"]')
        click(d, '#plan-tabs [data-plan="2"]')
        speed, end = d.find_elements(By.CSS_SELECTOR, "#segments .seg")[0].find_elements(By.TAG_NAME, "input")
        check("unsaved plan edits are kept across tabs", speed.get_attribute("value") == "40"
              and end.get_attribute("value") == "05:00", f"{speed.get_attribute('value')} {end.get_attribute('value')}")
        check("...and the tab says it has unsaved edits", "dirty" in
              d.find_element(By.CSS_SELECTOR, '#plan-tabs [data-plan="2"]').get_attribute("class"))
        click(d, "#seg-add")
        speed, end = d.find_elements(By.CSS_SELECTOR, "#segments .seg")[1].find_elements(By.TAG_NAME, "input")
        fill(d, speed, "70")
        fill(d, end, "10:00")
        targets(d, "the plan editor")
        click(d, "#plan-save")
        check("plan 2 saved", wait_for(lambda: "plan 2 saved" in text(d, "#plan-reason"), DEADLINE),
              text(d, "#plan-reason"))
        check("the plan's ends are sent as mm:ss", d.execute_script(
            "return window.__sent.some((m) => m.op === 'plan' && m.segments[1].end === '10:00')"))
        check("the step chart shows it", d.execute_script(
            "return document.querySelector('#plan-chart polyline').points.length") == 4)
        check("...on axes: 0 to 100 % up, 00:00 to the plan's end across", text(d, "#plans .chart-box .y-top") == "100 %"
              and text(d, "#plans .chart-box .x-end") == "10:00",
              f"{text(d, '#plans .chart-box .y-top')!r} {text(d, '#plans .chart-box .x-end')!r}")

        # An invalid plan is refused on the page with the reason, nothing sent...
        click(d, '#plan-tabs [data-plan="3"]')
        click(d, "#seg-add")
        speed, end = d.find_elements(By.CSS_SELECTOR, "#segments .seg")[1].find_elements(By.TAG_NAME, "input")
        fill(d, end, "00:30")
        clear_sent(d)
        click(d, "#plan-save")
        check("an invalid plan is refused with the reason",
              wait_for(lambda: "not saved: segment 2: end 00:30 is not after 01:00" in text(d, "#plan-reason"),
                       DEADLINE), text(d, "#plan-reason"))
        check("...nothing sent", sent(d) == [], json.dumps(sent(d)))
        rows = d.find_elements(By.CSS_SELECTOR, "#segments .seg")
        check("...and the row at fault is marked (its end field)", "bad" in rows[1].get_attribute("class")
              and end.get_attribute("aria-invalid") == "true" and "bad" not in rows[0].get_attribute("class"),
              f"{rows[1].get_attribute('class')!r} aria-invalid {end.get_attribute('aria-invalid')!r}")
        fill(d, end, "30")
        check("a bare number as an end is refused with the example",
              wait_for(lambda: "write 30:00, 30m or 90s" in text(d, "#plan-reason"), DEADLINE), text(d, "#plan-reason"))
        d.execute_script("document.getElementById('plan-reason').scrollIntoView({block: 'end'})")
        d.save_screenshot(os.path.join(OUT, "panel-invalid-plan.png"))
        fill(d, end, "02:00")
        check("...and the refusal goes away when it is right", wait_for(lambda: text(d, "#plan-reason") == "", DEADLINE),
              text(d, "#plan-reason"))
        check("...and so does the mark", "bad" not in rows[1].get_attribute("class")
              and end.get_attribute("aria-invalid") == "false", rows[1].get_attribute("class"))
        # ...and the server refuses one too, even when a page skips the check.
        r = d.execute_async_script("""
const done = arguments[arguments.length - 1]; const ws = new WebSocket(`wss://${location.host}/ws`);
ws.onopen = () => ws.send(JSON.stringify({op: 'plan', id: 1, plan: 3, segments: [{speed: 120, end: '01:00'}]}));
ws.onmessage = (e) => { const m = JSON.parse(e.data); if (m.type === 'result') { ws.close(); done(m); } };
setTimeout(() => done(null), 20000);""")
        check("the server refuses a plan the page did not check", r and not r["ok"] and "120" in r["error"], json.dumps(r))
        check("...saying what kind of refusal it is (a code, not text to parse)", r and r.get("code") == "invalid"
              and r.get("advice"), json.dumps(r))

        # A fault injected on the simulator shows, with what to do; a refused start says what to do; both clear.
        # A run first: the fault comes while the jet moves.
        Select(d.find_element(By.ID, "start-mode")).select_by_value("free")
        fill(d, d.find_element(By.ID, "speed-in"), "40")
        click(d, "#start")
        check("a free run at 40 % before the fault", wait_for(lambda: text(d, "#speed") == "40 %", DEADLINE),
              text(d, "#speed"))
        con.ask("fault motor-drive")
        check("the fault shows by name with advice", wait_for(
            lambda: "motor drive" in text(d, "#fault-list") and "motor cable" in text(d, "#fault-list"), DEADLINE),
            text(d, "#fault-list"))
        # The fault screen's motor stands: the big figure is 0 %, the set speed
        # beside it (it showed the set speed as if the jet ran).
        set_speed = int(re.search(r"speed = (\d+)", con.ask("get speed")).group(1))
        check(f"a stopped jet shows 0 %, the set speed ({set_speed} %) marked as such",
              set_speed > 0 and wait_for(lambda: text(d, "#speed") == "0 %"
                                         and text(d, "#speed-set") == f"set {set_speed} %", DEADLINE),
              f"{text(d, '#speed')!r} {text(d, '#speed-set')!r}")
        # The machine takes no start in the fault screen: Start is off (not
        # green) and the page says why; Stop stays.
        check("Start is off during a fault, and the page says why",
              d.find_element(By.ID, "start").get_attribute("disabled") is not None
              and "fault" in text(d, "#start-why") and d.find_element(By.ID, "stop").is_enabled(),
              f"start disabled {d.find_element(By.ID, 'start').get_attribute('disabled')}, {text(d, '#start-why')!r}")
        check("...and looks off", d.execute_script(
            "return getComputedStyle(document.getElementById('start')).backgroundColor") != "rgb(25, 195, 125)",
            d.execute_script("return getComputedStyle(document.getElementById('start')).backgroundColor"))
        # A start sent anyway (another page, an automation) is refused by the
        # machine, with the kind and what to do from the device layer.
        r = d.execute_async_script("""
const done = arguments[arguments.length - 1]; const ws = new WebSocket(`wss://${location.host}/ws`);
ws.onopen = () => ws.send(JSON.stringify({op: 'start', id: 1, mode: 'free', speed: 40}));
ws.onmessage = (e) => { const m = JSON.parse(e.data); if (m.type === 'result') { ws.close(); done(m); } };
setTimeout(() => done(null), 20000);""")
        check("a start refused in the fault screen says it is the fault, and what to do",
              r and not r["ok"] and r.get("code") == "fault" and "fault box" in r.get("advice", ""), json.dumps(r))
        d.execute_script("document.getElementById('faults').scrollIntoView({block: 'start'})")  # the box and the refusal
        d.save_screenshot(os.path.join(OUT, "panel-fault.png"))
        wait_for(lambda: "motor drive" in text(t, "#fault-list"), DEADLINE)
        t.save_screenshot(os.path.join(OUT, "panel-tablet-fault.png"))
        con.ask("fault clear")
        check("the fault box goes when the fault clears",
              wait_for(lambda: not d.find_element(By.ID, "faults").is_displayed(), DEADLINE))
        check("...and Start is back", wait_for(lambda: d.find_element(By.ID, "start").is_enabled()
                                              and text(d, "#start-why") == "", DEADLINE), text(d, "#start-why"))

        # Log out: back to the login page; the old session opens nothing.
        t.find_element(By.CSS_SELECTOR, "#logout button").click()
        check("log out leads to the login page", wait_for(lambda: t.current_url.endswith("/login"), DEADLINE),
              t.current_url)

        # The panel itself goes away: the page says so, with what to do.
        panel.send_signal(signal.SIGTERM)
        check("the panel ends cleanly", panel.wait(DEADLINE) == 0)
        check("the page says the link to the panel is lost", wait_for(
            lambda: "No contact since" in text(d, "#lost-title") and "lost the panel" in text(d, "#lost"), DEADLINE),
            text(d, "#lost"))
        check("...and every control is off", d.execute_script(
            "return [...document.querySelectorAll('#run button')].every((e) => e.disabled)"))

        # Read back with the CLI once the panel let go of the port.
        shown = subprocess.run([RTUKIT, "inverjet", "plan", "show", "2", "--port", pty, "--json"], capture_output=True,
                               text=True)
        segments = json.loads(shown.stdout).get("segments") if shown.returncode == 0 else None
        check("the CLI reads plan 2 back", segments is not None and [(x["speed"], x.get("end_s", x["end"]))
                                                                     for x in segments] == [(40, 300), (70, 600)],
              shown.stdout[:400] + shown.stderr)
        report = open(os.path.join(work, "panel.err")).read()
        check("no sanitizer report from the panel", "Sanitizer" not in report, report[:2000])
        check("the panel logged the logins, one line each", report.count("login from") >= 2, report[:2000])
    finally:
        for d in drivers:
            try:
                d.quit()
            except Exception:
                pass
        for p in procs:  # a stopped simulator would not hear SIGTERM
            if p.poll() is None:
                p.send_signal(signal.SIGCONT)
        stop_processes(procs)
    return summary()


if __name__ == "__main__":
    # Stopped by the test runner (its deadline): end through the finally
    # blocks, which stop what was started and remove the temporary folder.
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    sys.exit(main())
