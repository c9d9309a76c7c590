#!/usr/bin/python3
"""The Inverjet MQTT bridge at fleet scale: N simulated machines (each on its
own pty) behind N bridges (`rtukit inverjet bridge`, one per machine, polling
at 2 Hz) on one local Mosquitto broker, for N = 1, 20, 100.

Measured per N:
  - change -> MQTT: a MOSFET temperature set on a simulator's console (45
    and 75 degC in turn) until a value/mosfet_c message within 2 degC of it
    reaches a subscriber (mosquitto_sub, a peer we did not write; the running
    model carries the temperature on, so the value published is near the one
    set); 10 machines sampled, 10 changes each, misses counted;
  - command -> register: a speed published on set/speed (by a long-running
    mosquitto_pub -l) until the simulator's speed register holds it (probed
    on its console, ~0.2 ms a probe);
  - messages per second through the broker while idle-running;
  - CPU (% of one core) and resident memory per bridge, from /proc;
  - missed polls: each bridge's own count of polls later than 1.5 periods
    (published on .../bridge), and the worst gap between two polls.
Targets: p99 below one poll period + 50 ms (550 ms); 100 machines without a
missed poll.

Usage: bench/inverjet_bridge_bench.py RTUKIT [--sizes 1,20,100]
Prints a Markdown table for bench/README.md.
"""
import json
import os
import random
import shutil
import statistics
import subprocess
import sys
import threading
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests"))
from pyhelpers import Console, connects, free_port, pct, stop_processes, temp_dir, wait_for  # noqa: E402

RTUKIT = sys.argv[1]
SIZES = [int(x) for x in sys.argv[sys.argv.index("--sizes") + 1].split(",")] if "--sizes" in sys.argv else [1, 20, 100]
HZ = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid):
    fields = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / HZ


def rss_mib(pid):
    for line in open(f"/proc/{pid}/status"):
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return 0


class Subscriber:
    """mosquitto_sub on rtukit/#, every line timestamped as it arrives."""

    def __init__(self, port):
        self.p = subprocess.Popen(["mosquitto_sub", "-p", str(port), "-v", "-t", "rtukit/#"], stdout=subprocess.PIPE,
                                  text=True, bufsize=1)
        self.lines = []
        self.lock = threading.Lock()
        threading.Thread(target=self.read, daemon=True).start()

    def read(self):
        for line in self.p.stdout:
            with self.lock:
                self.lines.append((time.monotonic(), line.rstrip("\n")))

    def find(self, since, topic, payload):
        with self.lock:
            for t, line in self.lines:
                if t >= since and line == f"{topic} {payload}":
                    return t
        return None

    def find_near(self, since, topic, value, within):
        """The first message on `topic` since `since` whose number is within `within` of `value`."""
        with self.lock:
            for t, line in self.lines:
                name, _, payload = line.partition(" ")
                if t >= since and name == topic:
                    try:
                        if abs(float(payload) - value) <= within:
                            return t
                    except ValueError:
                        pass
        return None

    def count(self, t0, t1):
        with self.lock:
            return sum(1 for t, _ in self.lines if t0 <= t <= t1)


def run(n):
    work = temp_dir(f"rtukit-fleet-{n}-")  # removed at exit, on every path (a stopped bench too)
    port = free_port()
    conf = os.path.join(work, "m.conf")
    with open(conf, "w") as f:
        f.write(f"listener {port} 127.0.0.1\npersistence false\nallow_anonymous true\nmax_queued_messages 10000\n")
    procs = [subprocess.Popen(["mosquitto", "-c", conf], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    bridges, consoles = [], []
    try:
        wait_for(lambda: connects(port), 10)
        for i in range(n):
            pty, con = os.path.join(work, f"jet{i}"), os.path.join(work, f"jet{i}.sock")
            procs.append(subprocess.Popen([RTUKIT, "sim", "inverjet", "--listen", f"pty:{pty}", "--no-state",
                                           "--no-console", "--console", f"unix:{con}"],
                                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
            wait_for(lambda: os.path.exists(con) and os.path.exists(pty))
            consoles.append(Console(con))
            b = subprocess.Popen([RTUKIT, "inverjet", "bridge", "--port", pty, "--mqtt", f"mqtt://127.0.0.1:{port}",
                                  "--id", f"jet{i:03d}", "--no-discovery"], stdout=subprocess.DEVNULL,
                                 stderr=subprocess.DEVNULL)
            procs.append(b)
            bridges.append(b)
        sub = Subscriber(port)
        procs.append(sub.p)
        ok = wait_for(lambda: all(sub.find(0, f"rtukit/inverjet/jet{i:03d}/availability", "online") for i in range(n)), 60, 0.2)
        if not ok:
            raise RuntimeError("not every bridge came online")
        time.sleep(2)
        cpu0 = {b.pid: cpu_seconds(b.pid) for b in bridges}
        t_start = time.monotonic()
        sample = random.Random(1).sample(range(n), min(10, n))
        change, command = [], []
        pubs = {i: subprocess.Popen(["mosquitto_pub", "-p", str(port), "-q", "1", "-l", "-t",
                                     f"rtukit/inverjet/jet{i:03d}/set/speed"], stdin=subprocess.PIPE, text=True)
                for i in sample}
        procs.extend(pubs.values())
        for i in sample:  # running, so a speed applies at once
            subprocess.run(["mosquitto_pub", "-p", str(port), "-q", "1", "-t", f"rtukit/inverjet/jet{i:03d}/set/start",
                            "-m", json.dumps({"mode": "timer", "speed": 20, "duration": "30:00", "ts": int(time.time())})])
        wait_for(lambda: all("timer running" in consoles[i].ask("get state") for i in sample), 15, 0.2)
        jitter = random.Random(2)
        for rep in range(10):
            for i in sample:
                time.sleep(jitter.uniform(0, 0.5))  # any phase of the poll cycle
                # change -> MQTT. The running model carries the temperature on
                # from the value set (a few tenths of a degree per second), so
                # the value published is near it, not equal: the set values
                # jump by 30 degrees, and a message within 2 degrees is the change.
                value = (45 if rep % 2 == 0 else 75) + i % 3
                t0 = time.monotonic()
                consoles[i].ask(f"temp mosfet {value}")
                t1 = wait_for(lambda: sub.find_near(t0, f"rtukit/inverjet/jet{i:03d}/value/mosfet_c", value, 2.0), 3,
                              0.002)
                if t1:
                    change.append((t1 - t0) * 1000)
                # command -> register (speed accepted in any state)
                speed = 20 + rep + (i % 5)
                t0 = time.monotonic()
                pubs[i].stdin.write(json.dumps({"speed": speed, "ts": int(time.time())}) + "\n")
                pubs[i].stdin.flush()
                if wait_for(lambda: f"speed = {speed} %" in consoles[i].ask("get speed"), 3, 0.0):
                    command.append((time.monotonic() - t0) * 1000)
                if os.environ.get("BENCH_DEBUG"):
                    print(f"jet{i:03d} rep {rep}: change {change[-1] if t1 else None} command {command[-1]}",
                          file=sys.stderr)
        t_end = time.monotonic()
        time.sleep(10.5)  # every bridge publishes its poll health every 10 s
        msgs_per_s = sub.count(t_start, t_end) / (t_end - t_start)
        cpu = [100 * (cpu_seconds(b.pid) - cpu0[b.pid]) / (time.monotonic() - t_start) for b in bridges]
        rss = [rss_mib(b.pid) for b in bridges]
        health = {}
        with sub.lock:
            for _, line in sub.lines:
                topic, _, payload = line.partition(" ")
                if topic.endswith("/bridge"):
                    health[topic] = json.loads(payload)
        late = sum(h["late_polls"] for h in health.values())
        worst_gap = max((h["max_poll_gap_ms"] for h in health.values()), default=0)
        polls = sum(h["polls"] for h in health.values())
        return dict(n=n, samples=len(sample) * 10, change=change, command=command, msgs=msgs_per_s, cpu=statistics.mean(cpu),
                    rss=statistics.mean(rss), late=late, gap=worst_gap, polls=polls, reporting=len(health))
    finally:
        stop_processes(procs)
        shutil.rmtree(work, ignore_errors=True)


def main():
    rows = [run(n) for n in SIZES]
    print("| machines | change -> MQTT p50 / p99 (samples) | command -> register p50 / p99 (samples) | messages/s | "
          "CPU per bridge | RSS per bridge | late polls / polls (worst gap) |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['n']} | {statistics.median(r['change']):.0f} / {pct(r['change'], 99):.0f} ms "
              f"({len(r['change'])} of {r['samples']}) | {statistics.median(r['command']):.0f} / "
              f"{pct(r['command'], 99):.0f} ms ({len(r['command'])} of {r['samples']}) | {r['msgs']:.0f} | "
              f"{r['cpu']:.1f} % | {r['rss']:.1f} MiB | {r['late']} / {r['polls']} ({r['gap']} ms; "
              f"{r['reporting']} bridges) |")


if __name__ == "__main__":
    main()
