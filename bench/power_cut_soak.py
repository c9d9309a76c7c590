#!/usr/bin/python3
"""Power cut during saves: the Inverjet simulator killed with SIGKILL at
random moments while it saves its flash settings, restarted each time
(issue 13, section 4; figures in docs/reliability.md, "Fault soaks").

Each cycle starts `rtukit sim inverjet --state-file F` on a Modbus TCP port,
reads the four free/timer settings (0x0080..0x0083), checks they are the
settings before or after the previous cycle's write (never a mix, never a
warning or an error at start), then writes four new values in one FC10 and
kills the simulator 0..6 ms later: before the request arrived, between the
write and the save, during the save, or after it. A temporary file left
behind proves a kill landed inside the save; the next save removes it.

SIGKILL ends the process, not the machine: what reached the page cache
survives it. A real power cut also needs the data on the medium, which the
save asks for with fsync on the file and its directory (io/atomic_file.hpp)
but which only a machine that loses power can prove.

Usage: bench/power_cut_soak.py RTUKIT [--cycles N] [--seed S]
Prints a Markdown table; exit 0 when every restart loaded the old or the new
settings, 1 otherwise.
"""
import os
import random
import select
import signal
import socket
import struct
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests"))
from pyhelpers import free_port, temp_dir  # noqa: E402

RTUKIT = sys.argv[1]
CYCLES = int(sys.argv[sys.argv.index("--cycles") + 1]) if "--cycles" in sys.argv else 1000
SEED = int(sys.argv[sys.argv.index("--seed") + 1]) if "--seed" in sys.argv else 1
UNIT = 21
SETTINGS = 0x0080  # free_speed, free_time, timer_speed, timer_time
KILL_WINDOW_S = 0.006


started = []  # every simulator started, so none outlives the soak


def start(state, port):
    """Starts the simulator; returns (process, its start-up lines)."""
    p = subprocess.Popen([RTUKIT, "sim", "inverjet", "--listen", f"tcp://127.0.0.1:{port}", "--state-file", state,
                          "--no-console"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1)
    started.append(p)
    lines = []
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        line = p.stdout.readline()
        if not line:
            break
        lines.append(line.rstrip("\n"))
        if line.startswith("listening on"):
            return p, lines
    p.kill()
    p.wait()
    raise SystemExit("the simulator did not start:\n" + "\n".join(lines))


def connect(port):
    deadline = time.monotonic() + 5
    while True:
        try:
            s = socket.create_connection(("127.0.0.1", port), timeout=2)
            s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            return s
        except OSError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.005)


def mbap(tid, pdu):
    return struct.pack(">HHHB", tid, 0, len(pdu) + 1, UNIT) + pdu


def recv_adu(s):
    head = b""
    while len(head) < 7:
        chunk = s.recv(7 - len(head))
        if not chunk:
            raise OSError("closed")
        head += chunk
    length = struct.unpack(">H", head[4:6])[0] - 1
    body = b""
    while len(body) < length:
        chunk = s.recv(length - len(body))
        if not chunk:
            raise OSError("closed")
        body += chunk
    return body


def read_settings(s):
    s.sendall(mbap(1, struct.pack(">BHH", 3, SETTINGS, 4)))
    pdu = recv_adu(s)
    if pdu[0] != 3 or pdu[1] != 8:
        raise SystemExit(f"unexpected answer to the read: {pdu.hex()}")
    return tuple(struct.unpack(">4H", pdu[2:10]))


def write_request(values):
    return mbap(2, struct.pack(">BHHB4H", 0x10, SETTINGS, 4, 8, *values))


def temporaries(state):
    d, name = os.path.split(state)
    return [f for f in os.listdir(d) if f.startswith(name + ".tmp.")]


def main():
    # The folder goes at exit, on every path (temp_dir); the simulators first.
    try:
        return soak()
    finally:
        for p in started:
            if p.poll() is None:
                p.kill()
                p.wait()


def soak():
    rng = random.Random(SEED)
    work = temp_dir("rtukit-power-cut-")
    state = os.path.join(work, "inverjet.json")
    port = free_port()
    # First start: defaults, saved.
    p, _ = start(state, port)
    s = connect(port)
    old = read_settings(s)
    s.close()
    p.kill()
    p.wait()
    new = old
    counts = {"old": 0, "new": 0, "mixed": 0}
    warnings = answered = mid_save = most_temporaries = 0

    def loaded(got, cycle):
        kind = "new" if got == new else "old" if got == old else "mixed"
        counts[kind] += 1
        if kind == "mixed":
            print(f"cycle {cycle}: loaded {got}, expected {old} or {new}", file=sys.stderr)

    t0 = time.monotonic()
    for cycle in range(CYCLES):
        p, lines = start(state, port)
        bad = [line for line in lines if "warning" in line or "error" in line]
        if bad:
            warnings += 1
            print(f"cycle {cycle}: {bad}", file=sys.stderr)
        s = connect(port)
        got = read_settings(s)
        loaded(got, cycle)
        old = got
        new = (rng.randint(0, 100), rng.randint(0, 5999), rng.randint(0, 100), rng.randint(0, 5999))
        while new == old:
            new = (rng.randint(0, 100), rng.randint(0, 5999), rng.randint(0, 100), rng.randint(0, 5999))
        delay = rng.uniform(0, KILL_WINDOW_S)
        sent = time.monotonic()
        s.sendall(write_request(new))
        while time.monotonic() - sent < delay:
            pass
        p.send_signal(signal.SIGKILL)
        p.wait()
        if select.select([s], [], [], 0)[0]:
            answered += 1
        s.close()
        left = temporaries(state)
        most_temporaries = max(most_temporaries, len(left))
        mid_save += 1 if left else 0
    # One more start and a save that completes: the last kill's leftover goes.
    p, lines = start(state, port)
    s = connect(port)
    got = read_settings(s)
    loaded(got, CYCLES)
    s.sendall(write_request(old if got != old else new))
    recv_adu(s)
    s.close()
    time.sleep(0.2)
    p.send_signal(signal.SIGTERM)
    p.wait()
    left_at_end = len(temporaries(state))
    seconds = time.monotonic() - t0

    print("| kills | restarts: old settings | new settings | a mix | a warning or error | answered before the kill "
          "| killed inside the save (temporary file left) | most temporary files at once | left at the end | time |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    print(f"| {CYCLES} | {counts['old']} | {counts['new']} | {counts['mixed']} | {warnings} | {answered} | {mid_save} | "
          f"{most_temporaries} | {left_at_end} | {seconds:.0f} s |")
    ok = counts["mixed"] == 0 and warnings == 0 and left_at_end == 0 and most_temporaries <= 1
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
