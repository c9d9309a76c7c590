#!/usr/bin/python3
"""The Rehand 6600 host daemon under a link that dies and comes back, many
times (issue 13, section 4; figures in docs/reliability.md, "Fault soaks").

`rtukit bus` joins the daemon and the chair's simulator on a 115200-baud
line; SIGUSR1 to the bus cuts the line and connects it again. Each cycle:

  1. a display (WebSocket) holds "seat lift up", renewing it every 100 ms as
     a finger on the button does, and the chair's seat_lift register reads
     "up" (the simulator's console);
  2. the line is cut while the finger stays down (every other cycle: the
     finger lifted, the line cut, the button pressed while the line is dead,
     before the daemon noticed): the daemon must raise 1010 (error_raised)
     and the chair stop;
  3. the line comes back, the finger still down: the daemon must clear 1010
     (error_cleared), refuse the renewals ("release and press again", D-8)
     and the chair's seat_lift must stay "off" for a whole second: no held
     command survives the link loss;
  4. the finger is lifted and pressed again: the seat lifts (the link really
     is back), then released.

The daemon's threads, resident memory and open file descriptors are read
from /proc after the first cycle and after the last.

Usage: bench/rehand_link_soak.py RTUKIT [--cycles N]
Prints a Markdown table; exit 0 when every cycle held, 1 otherwise.
"""
import json
import os
import signal
import subprocess
import sys
import time
import urllib.request

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests"))
from pyhelpers import Console, WebSocket, child_problems, free_port, pct, start, stop_processes, temp_dir, wait_for  # noqa: E402

RTUKIT = sys.argv[1]
MASTER_ERROR = 0x1010  # "1010 Master Error": error codes are hex (table 3)
CYCLES = int(sys.argv[sys.argv.index("--cycles") + 1]) if "--cycles" in sys.argv else 100


def proc_figures(pid):
    status = open(f"/proc/{pid}/status").read()
    field = lambda name: int(next(l.split()[1] for l in status.splitlines() if l.startswith(name + ":")))
    return {"threads": field("Threads"), "rss_kib": field("VmRSS"), "fds": len(os.listdir(f"/proc/{pid}/fd"))}


class Display:
    """A display's WebSocket, with the finger on one button."""

    def __init__(self, port):
        self.ws = WebSocket(port, "/ws?role=display")
        self.id = 0
        self.events = []
        self.results = {}
        self.press = None  # the finger's press id while it is down
        self.presses = 0

    def send(self, msg):
        self.id += 1
        msg["id"] = self.id
        self.ws.send(json.dumps(msg))
        return self.id

    def pump(self, seconds):
        """Reads what the daemon sends for `seconds`."""
        until = time.monotonic() + seconds
        while True:
            left = until - time.monotonic()
            if left <= 0:
                return
            text = self.ws.recv(left)
            if text is None:
                return
            m = json.loads(text)
            if m.get("type") == "event":
                self.events.append((time.monotonic(), m))
            elif m.get("type") == "result":
                self.results[m["id"]] = m

    def hold_for(self, seconds, until=None):
        """Renews the hold every 100 ms for `seconds` (or until `until()`); returns the results of the renewals."""
        ids = []
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            if self.press is None:  # the finger comes down: a new press
                self.presses += 1
                self.press = self.presses
                ids.append(self.send({"op": "press", "command": "seat_lift", "value": "up", "press": self.press}))
            else:  # the finger stays down: the press is renewed (refused once it has ended)
                ids.append(self.send({"op": "renew", "press": self.press}))
            self.pump(0.1)
            if until and until():
                break
        self.pump(0.05)
        return [self.results.get(i) for i in ids]

    def release(self):
        """The finger lifts."""
        if self.press is not None:
            self.send({"op": "release", "press": self.press})
        self.press = None

    def switch_line(self, bus, event):
        """Cuts or connects the line (SIGUSR1 to the bus), the finger still
        down; returns the milliseconds until the daemon sent `event` for
        1010, or None when it did not within 5 s."""
        t = time.monotonic()
        bus.send_signal(signal.SIGUSR1)
        seen = lambda: next((at for at, m in self.events
                             if at >= t and m["event"] == event and m.get("code") == MASTER_ERROR), None)
        self.hold_for(5, until=lambda: seen() is not None)
        at = seen()
        return None if at is None else 1000 * (at - t)


def main():
    work = temp_dir("rtukit-link-soak-")  # removed at exit, on every path
    host_pty, chair_pty = os.path.join(work, "host"), os.path.join(work, "chair")
    con_path = os.path.join(work, "console.sock")
    http, phone = free_port(), free_port()
    procs = []
    try:
        # Each child's stderr kept and checked when stopped (pyhelpers.check_child).
        bus = start([RTUKIT, "bus", "--ports", "2", "--links", f"{host_pty},{chair_pty}", "--baud", "115200"], work)
        procs.append(bus)
        wait_for(lambda: os.path.exists(chair_pty) and os.path.exists(host_pty))
        procs.append(start([RTUKIT, "sim", "rehand6600", "--listen", chair_pty, "--no-state", "--no-console",
                            "--console", f"unix:{con_path}"], work))
        wait_for(lambda: os.path.exists(con_path))
        daemon = start([RTUKIT, "rehand6600", "host", "--port", host_pty, "--http", f"127.0.0.1:{http}",
                        "--phone", f"127.0.0.1:{phone}", "--pairing-file", os.path.join(work, "pairing.json")], work)
        procs.append(daemon)
        con = Console(con_path)

        def connected():
            try:
                doc = json.load(urllib.request.urlopen(f"http://127.0.0.1:{http}/api/state", timeout=2))
                return doc["connected"] and not doc["error"]
            except OSError:
                return False

        if not wait_for(connected, 15):
            raise SystemExit("the daemon never connected")
        # "seat_lift = up (1)": the register's raw value in brackets
        lifting = lambda: not con.ask("get seat_lift").endswith("(0)")

        d = Display(http)
        d.pump(0.3)
        raised_ms, cleared_ms, failures, refused_renewals = [], [], [], 0
        first = last = None
        t0 = time.monotonic()
        for cycle in range(CYCLES):
            # 1. the finger down: the seat lifts
            d.hold_for(3, until=lifting)
            if not lifting():
                failures.append(f"cycle {cycle}: the hold did not reach the chair")
            # 2. the cable out, the finger still down; every other cycle the
            #    finger is lifted first and pressed while the line is dead,
            #    before the daemon noticed (its press fails on the bus)
            if cycle % 2:
                d.release()
                d.pump(0.15)
            raised = d.switch_line(bus, "error_raised")
            if raised is None:
                failures.append(f"cycle {cycle}: no 1010 after the cut")
            else:
                raised_ms.append(raised)
            d.hold_for(0.3)
            if lifting():
                failures.append(f"cycle {cycle}: the chair kept lifting with the line cut")
            # 3. the cable back, the finger still down: 1010 cleared, nothing moves
            cleared = d.switch_line(bus, "error_cleared")
            if cleared is None:
                failures.append(f"cycle {cycle}: 1010 not cleared after the line came back")
            else:
                cleared_ms.append(cleared)
            moved = False
            end = time.monotonic() + 1.0
            while time.monotonic() < end:
                results = d.hold_for(0.1)
                refused_renewals += sum(1 for r in results if r and not r["ok"])
                moved = moved or lifting()
            if moved:
                failures.append(f"cycle {cycle}: a held command survived the link loss (seat_lift moved)")
            # 4. finger up, pressed again: the seat lifts again; then released
            d.release()
            d.pump(0.15)
            d.hold_for(3, until=lifting)
            if not lifting():
                failures.append(f"cycle {cycle}: pressing again did not lift the seat")
            d.release()
            d.pump(0.3)
            if lifting():
                failures.append(f"cycle {cycle}: the release did not stop the seat")
            if cycle == 0:
                first = proc_figures(daemon.pid)
            if daemon.poll() is not None:
                failures.append(f"cycle {cycle}: the daemon ended ({daemon.returncode})")
                break
        last = proc_figures(daemon.pid)
        seconds = time.monotonic() - t0
        d.ws.close()
    finally:
        stop_processes(procs)
        failures.extend(f"child process: {c}" for c in child_problems)

    for f in failures[:20]:
        print(f, file=sys.stderr)
    print("| link losses | 1010 raised | 1010 cleared | cut -> 1010 p50 / max | back -> cleared p50 / max | renewals refused "
          "after the link came back | held commands that survived | daemon threads first / last | RSS KiB first / last "
          "| fds first / last | failures | time |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    survived = sum(1 for f in failures if "survived" in f)
    print(f"| {CYCLES} | {len(raised_ms)} | {len(cleared_ms)} | {pct(raised_ms, 50):.0f} / {max(raised_ms, default=0):.0f} ms | "
          f"{pct(cleared_ms, 50):.0f} / {max(cleared_ms, default=0):.0f} ms | {refused_renewals} | {survived} | "
          f"{first['threads']} / {last['threads']} | {first['rss_kib']} / {last['rss_kib']} | {first['fds']} / {last['fds']} | "
          f"{len(failures)} | {seconds:.0f} s |")
    grew = last["threads"] > first["threads"] or last["fds"] > first["fds"]
    return 0 if not failures and not grew else 1


if __name__ == "__main__":
    sys.exit(main())
