#!/usr/bin/env python3
"""Fails when library code reads the time itself (issue 27, "one clock").

Every scheduler and timer below a program's main() reads the time through
the DriverClock it is given (base/include/rtukit/base/clock.hpp), so a test can
pass a ManualClock and run a 30-day expiry or a 5-second back-off in no
time. This test refuses, outside comments, in core/, driver/, devices/,
web/, programs/ and cli/:
  - std::chrono::steady_clock / system_clock / high_resolution_clock ::now(),
    Clock::now(), WallClock::now(), SteadyClock::instance().now() (the real
    clock fetched and read on the spot: the BLE token bucket once did);
  - time(nullptr), std::time(NULL), gettimeofday, clock_gettime.
Allowed: the clock's own file, and io/ (the OS layer: it stamps received
characters and waits on sockets in the OS's time).
Each hit is printed as FILE:LINE: the line.
"""
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
FOLDERS = ["core", "term", "driver", "devices", "tool", "web", "programs", "cli"]
READ = re.compile(
    r"\b(?:steady_clock|system_clock|high_resolution_clock|Clock|WallClock)\s*::\s*now\s*\("
    r"|\bSteadyClock\s*::\s*instance\s*\(\s*\)\s*\.\s*(?:now|wall)\s*\("
    r"|\btime\s*\(\s*(?:nullptr|NULL|0)\s*\)|\bgettimeofday\s*\(|\bclock_gettime\s*\(")


def main() -> int:
    hits = []
    for folder in FOLDERS:
        for path in sorted((ROOT / folder).rglob("*")):
            if path.suffix not in (".cpp", ".hpp", ".h", ".cc") or not path.is_file():
                continue
            for n, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
                code = line.split("//", 1)[0]
                if READ.search(code):
                    hits.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()}")
    for h in hits:
        print(h)
    if hits:
        print(f"{len(hits)} read(s) of the time outside the clock: take a DriverClock (base/clock.hpp)")
        return 1
    print("one clock: no read of the time outside io/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
