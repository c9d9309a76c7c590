"""What the browser tests share: a headless Chromium (Debian's, through
chromedriver), checks that print one line each, polling with a deadline,
the simulators' console sockets, and the layout check (no control overlaps
another or leaves the screen, every text fits)."""
import os
import re
import sys
import socket

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from pyhelpers import connect_unix, free_port, start, stop_processes, temp_dir, wait_for  # noqa: E402,F401 (the browser tests take them from here)

from selenium import webdriver
from selenium.webdriver.chrome.service import Service

failures = []


def check(name, cond, detail=""):
    print(f"{'ok' if cond else 'FAIL'} {name} {detail}".rstrip(), flush=True)
    if not cond:
        failures.append(name)


class Console:
    """The simulator's console on its unix socket: the chair's physical side.
    Connects as soon as the simulator accepts (it may still be starting)."""

    def __init__(self, path):
        self.s = connect_unix(path)
        self.s.settimeout(10)

    def cmd(self, line):
        """Every answer the command gets: its first line is waited for (the
        command has been run then), with a generous deadline; lines that
        follow it closely (a multi-line answer) are taken too."""
        self.s.settimeout(10)
        self.s.sendall(line.encode() + b"\n")
        data = b""
        try:
            while not data.endswith(b"\n"):
                chunk = self.s.recv(65536)
                if not chunk:
                    return data.decode(errors="replace")
                data += chunk
            self.s.settimeout(0.2)
            while True:
                chunk = self.s.recv(65536)
                if not chunk:
                    break
                data += chunk
        except socket.timeout:
            pass
        return data.decode(errors="replace")

    def ask(self, line):
        """A one-line answer ("speed = 70 %")."""
        self.s.settimeout(10)
        self.s.sendall(line.encode() + b"\n")
        data = b""
        while not data.endswith(b"\n"):
            data += self.s.recv(4096)
        return data.decode(errors="replace").strip()

    def held(self):
        # Reads until the status's last line: a probe of a few ms, not a fixed wait.
        self.s.settimeout(10)
        self.s.sendall(b"status\n")
        data = b""
        while not re.search(rb"held commands:[^\n]*\n", data):
            chunk = self.s.recv(65536)
            if not chunk:
                break
            data += chunk
        m = re.search(r"held commands:(.*)", data.decode(errors="replace"))
        return m.group(1).strip() if m else "?"


def browser(width, height, extra=(), env=None):
    """A headless Chromium with a viewport of width x height; `extra`: more
    command-line flags (e.g. a pinned certificate's
    --ignore-certificate-errors-spki-list); `env`: its environment (a
    private system bus for Web Bluetooth: DBUS_SYSTEM_BUS_ADDRESS)."""
    o = webdriver.ChromeOptions()
    # Removed when the test ends, also by SIGTERM (after it quit the browser): no profile left in the temp folder.
    udd = temp_dir('rtukit-chromium-')
    for a in [*extra, "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
              "--disable-background-networking", "--disable-component-update", "--disable-sync",
              "--disable-dev-shm-usage", "--autoplay-policy=no-user-gesture-required",
              f"--user-data-dir={udd}"]:
        o.add_argument(a)
    o.binary_location = "/usr/bin/chromium"
    # The page's console (a WebSocket that failed to open says so there): read
    # by console_tail() into a failed check's detail.
    o.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    d = webdriver.Chrome(service=Service("/usr/bin/chromedriver", env=env), options=o)
    d.set_window_size(width, height)
    vw, vh = d.execute_script("return [innerWidth, innerHeight]")
    d.set_window_size(width + (width - vw), height + (height - vh))
    d.user_data_dir = udd
    return d


AXE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "node_modules", "axe-core", "axe.min.js")
WCAG_22_A_AA = ["wcag2a", "wcag2aa", "wcag21a", "wcag21aa", "wcag22aa"]


def accessibility_violations(d):
    """axe-core's violations of WCAG 2.2 A and AA in the page as it is now,
    one string each ("rule (impact): N element(s) first-target"). axe-core
    (npm, test tooling only) is installed by scripts/setup.sh; without it
    this raises, so the check fails rather than passing unchecked."""
    if not os.path.exists(AXE):
        raise RuntimeError(f"{AXE} missing: scripts/setup.sh installs it (npm ci in tests/browser)")
    with open(AXE) as f:
        d.execute_script(f.read())
    d.set_script_timeout(60)
    found = d.execute_async_script(
        "const done = arguments[arguments.length - 1];"
        "axe.run(document, {runOnly: {type: 'tag', values: arguments[0]}})"
        ".then((r) => done(r.violations.map((v) => `${v.id} (${v.impact}): ${v.nodes.length} element(s) `"
        " + v.nodes[0].target.join(' '))), (e) => done([`axe failed: ${e}`]));", WCAG_22_A_AA)
    return found


def console_tail(d, lines=8):
    """The last `lines` messages of the page's console, one string (for a
    failed check's detail)."""
    try:
        return " | ".join(e.get("message", "") for e in d.get_log("browser")[-lines:])
    except Exception as e:  # a browser that is gone: say so rather than hide the check's own failure
        return f"(no console: {e})"


LAYOUT_JS = """
const vis = (e) => { const r = e.getBoundingClientRect(); const s = getComputedStyle(e);
  return r.width > 0 && r.height > 0 && s.visibility !== 'hidden' && !e.closest('.hidden'); };
const controls = [...document.querySelectorAll('button, input')].filter(vis);
const problems = [];
for (let i = 0; i < controls.length; ++i) {
  const a = controls[i].getBoundingClientRect();
  const vertical = arguments[0];  // false: a page that scrolls down; only its width must fit
  if (a.right > innerWidth + 0.5 || a.left < -0.5 || (vertical && (a.bottom > innerHeight + 0.5 || a.top < -0.5)))
    problems.push('off screen: ' + (controls[i].id || controls[i].textContent.trim()));
  for (let j = i + 1; j < controls.length; ++j) {
    const b = controls[j].getBoundingClientRect();
    if (a.left < b.right - 0.5 && b.left < a.right - 0.5 && a.top < b.bottom - 0.5 && b.top < a.bottom - 0.5)
      problems.push('overlap: ' + controls[i].textContent.trim() + ' / ' + controls[j].textContent.trim());
  }
}
for (const e of [...document.querySelectorAll('button, .value, .label, h1, h2, .banner, #code')].filter(vis)) {
  if (e.scrollWidth > e.clientWidth + 1 || e.scrollHeight > e.clientHeight + 1)
    problems.push('text does not fit: ' + (e.id || e.textContent.trim().slice(0, 30)));
}
return problems;
"""


SMALL_TEXT_JS = """
const least = arguments[0], found = [];
const walker = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT);
for (let n = walker.nextNode(); n; n = walker.nextNode()) {
  const e = n.parentElement;
  if (!n.textContent.trim() || !e || ['SCRIPT', 'STYLE', 'TEMPLATE', 'NOSCRIPT'].includes(e.tagName)) continue;
  let px = parseFloat(getComputedStyle(e).fontSize);
  if (e instanceof SVGElement) {  // in the drawing's units: as large as it is drawn
    const m = e.getScreenCTM();
    if (!m) continue;  // not drawn now: its size on screen is not known
    px *= Math.hypot(m.a, m.b);
  }
  if (px < least - 0.01) {
    const cls = e.getAttribute('class');
    found.push(`${e.id ? '#' + e.id : e.tagName.toLowerCase() + (cls ? '.' + cls.split(' ')[0] : '')} ${px.toFixed(1)} px`);
  }
}
return [...new Set(found)];
"""


def small_text(d, least=16):
    """Every element whose own text is set smaller than `least` px, shown or
    not (a panel that opens later is checked too: its size is computed the
    same; a drawing's text as large as it is drawn, when it is), one string
    each ("#fingerprint 10.0 px")."""
    return d.execute_script(SMALL_TEXT_JS, least)


def layout(d, name, out, scrolls=False):
    """`scrolls`: the page may scroll down (a phone panel), so only its width
    must fit the screen; a kiosk display must fit whole."""
    problems = d.execute_script(LAYOUT_JS, not scrolls)
    problems += [] if not scrolls else (
        ["page scrolls sideways"] if d.execute_script("return document.documentElement.scrollWidth > innerWidth") else [])
    d.save_screenshot(os.path.join(out, f"{name}.png"))
    check(f"layout {name}", not problems, "; ".join(problems[:5]))




def summary():
    """The verdict: every failed check, and every child that ended badly
    (pyhelpers.child_problems: a sanitizer report, a crash, an unclean end)."""
    import pyhelpers
    bad = failures + [f"child process: {p}" for p in pyhelpers.child_problems]
    print("PASS" if not bad else f"FAILED: {', '.join(bad)}")
    return 0 if not bad else 1
