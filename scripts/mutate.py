#!/usr/bin/python3
"""Mutation check of the safety rules (issue 36): does the suite notice when a
rule is changed a little?

One small mutation at a time is applied to a rule file: a comparison flipped
or loosened (`<` / `<=`, `==` / `!=`), a logical `&&` / `||` swapped, an
integer constant off by one, a condition negated, a call dropped. The file is
rebuilt with the tests that exercise it, those tests (and the simulation, for
a short budget) are run, and the mutant is:
  killed      a test failed (or timed out): the suite saw the change;
  survived    every test passed: a rule the suite does not pin down, or an
              equivalent change (docs/reliability.md, "Mutation check",
              says which);
  stillborn   it did not compile (not counted).
The file is restored after each mutant, and on any exit (Ctrl-C included).

Usage: scripts/mutate.py [--preset default] [--max N] [--seed S] [--from-line L] [--timeout S] [--list] [--only M]... [FILE...]
  FILE    a rule file (default: all four below); --list prints the mutants only
  --max   at most N mutants per file, spread evenly over the file (default: all)
  --from-line  only the mutants at line L or later (a run stopped part-way goes on
          where it stopped: each line printed names its mutant's line)
  --only  just the mutants named so (as a survivor line names one: "FILE:LINE: WHAT",
          e.g. "devices/rehand6600/src/session.cpp:43: '==' -> '!='"): a new test re-run
          against the mutant it was written to kill
Prints one line per mutant and a table of the score per file; exit 0.
"""
import argparse
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# Each rule file and the test programs (in BUILD/tests/) that exercise it:
# its unit tests, then the simulation (the slowest, last).
RULES = {
    "devices/rehand6600/src/session.cpp": ["rehand_session_tests", "rehand_host_logic_tests",
                                           "rehand_simulation_tests"],
    "devices/rehand6600/src/host.cpp": ["rehand_host_logic_tests", "rehand_session_tests", "rehand_simulation_tests"],
    "devices/rehand6600/src/chair.cpp": ["rehand_model_tests", "rehand_simulation_tests"],
    "devices/inverjet/src/machine.cpp": ["inverjet_model_tests", "inverjet_simulation_tests"],
}

# The part of a file that holds its rules, between two marker lines (the
# rest of host.cpp is the thread and lock around the logic, tested by the
# process and thread tests, not by these).
PARTS = {
    "devices/rehand6600/src/host.cpp": ("// ---------------------------------------------------------------- HostLogic",
                                        "// ---------------------------------------------------------------- Host: the core"),
    # The chair's interlocks: what a write may do, what drives, what stops (the
    # register reads above them are the table's, checked by the view tests).
    "devices/rehand6600/src/chair.cpp": ("bool Chair::phone_driving", None),
}

SWAPS = [(" <= ", " < "), (" < ", " <= "), (" >= ", " > "), (" > ", " >= "), (" == ", " != "),
         (" != ", " == "), (" && ", " || "), (" || ", " && ")]


def mutants(path, part=None):
    """(line number, description, new line) for every mutation of the file
    (of its rule part, when `part` names its first and last marker lines)."""
    out = []
    with open(path) as f:
        lines = f.read().split("\n")
    first, last = 0, len(lines)
    if part:
        first = next(i for i, line in enumerate(lines) if line.startswith(part[0]))
        if part[1]:
            last = next(i for i, line in enumerate(lines) if line.startswith(part[1]))
    for n, line in enumerate(lines):
        if not first <= n < last:
            continue
        # String and character literals blanked (same length): a number or an
        # operator inside a message is no rule.
        code = re.sub(r'"(?:[^"\\]|\\.)*"|\'(?:[^\'\\]|\\.)*\'', lambda m: " " * len(m.group(0)), line)
        code = code.split("//")[0]
        stripped = code.strip()
        if not stripped or stripped.startswith(("#", "*", "/*", "namespace", "using ", "static_assert")):
            continue
        for old, new in SWAPS:
            start = 0
            while (at := code.find(old, start)) >= 0:
                out.append((n, f"'{old.strip()}' -> '{new.strip()}'", line[:at] + new + line[at + len(old):]))
                start = at + len(old)
        for m in re.finditer(r"(?<![\w.\[x])(\d+)(?![\w.x'])", code):
            value = int(m.group(1))
            if value > 100000 or "[" in code[max(0, m.start() - 1):m.start()]:
                continue
            for v in (value + 1, value - 1) if value > 0 else (1,):
                out.append((n, f"{value} -> {v}", line[:m.start()] + str(v) + line[m.end():]))
        m = re.match(r"(\s*(?:if|while) \()(.*)(\) ?\{?\s*)$", code)
        if m and "(" not in m.group(2)[:1]:
            out.append((n, "condition negated", m.group(1) + "!(" + m.group(2) + ")" + m.group(3)))
        if re.match(r"\s*[a-z_][\w.>-]*\(.*\);\s*$", code) and not re.match(r"\s*(return|if|case)\b", code):
            out.append((n, f"call dropped ({line.strip()})", re.match(r"(\s*)", line).group(1) + ";"))
    return lines, out


def run(cmd, timeout, env=None):
    try:
        return subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=timeout, env=env).returncode
    except subprocess.TimeoutExpired:
        return "timeout"


def tests_pass(build, targets, env, timeout):
    """Runs each test program in turn; False at the first that fails."""
    # A mutant that loops forever is killed by the time-out (it counts as killed).
    return all(run([os.path.join(build, "tests", t)], timeout, env) == 0 for t in targets)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("files", nargs="*")
    ap.add_argument("--preset", default="default")
    ap.add_argument("--max", type=int, default=0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--list", action="store_true")
    ap.add_argument("--sim-seconds", default="10")
    ap.add_argument("--only", action="append", default=[])
    ap.add_argument("--from-line", type=int, default=1)
    # Seconds a test program may run before its mutant counts as killed (a
    # loop that never ends). The programs take under 5 s unmutated (the
    # simulation its --sim-seconds); a mutant that hangs one would otherwise
    # cost minutes each.
    ap.add_argument("--timeout", type=int, default=30)
    a = ap.parse_args()
    files = a.files or sorted({o.split(":")[0] for o in a.only}) or list(RULES)
    build = os.path.join(ROOT, "build", a.preset)
    env = dict(os.environ, RTUKIT_SIM_SECONDS=a.sim_seconds)
    table = []
    for rel in files:
        path = os.path.join(ROOT, rel)
        targets = RULES[rel]
        lines, found = mutants(path, PARTS.get(rel))
        if a.only:
            found = [m for m in found if any(f"{rel}:{m[0] + 1}: {m[1]}".startswith(o) for o in a.only)]
            if not found:
                continue
        found = [m for m in found if m[0] + 1 >= a.from_line]
        if a.max and len(found) > a.max:
            rng = random.Random(a.seed)
            found = sorted(rng.sample(found, a.max), key=lambda m: m[0])
        if a.list:
            for n, what, new in found:
                print(f"{rel}:{n + 1}: {what}: {new.strip()}")
            continue
        original = "\n".join(lines)
        backup = path + ".mutate-backup"
        shutil.copyfile(path, backup)

        def interrupted(*_):
            raise SystemExit(130)  # the finally below puts the file back
        signal.signal(signal.SIGINT, interrupted)
        signal.signal(signal.SIGTERM, interrupted)
        killed = survived = stillborn = 0
        survivors = []
        try:
            # The unmutated file must pass, or every mutant would look killed.
            if run(["cmake", "--build", build, "--target", *targets], 1200) != 0 or not tests_pass(build, targets, env, a.timeout):
                print(f"{rel}: the tests fail without any mutation: nothing to measure")
                continue
            for n, what, new in found:
                mutated = lines[:]
                mutated[n] = new
                with open(path, "w") as f:
                    f.write("\n".join(mutated))
                t0 = time.monotonic()
                if run(["cmake", "--build", build, "--target", *targets], 1200) != 0:
                    stillborn += 1
                    verdict = "stillborn"
                else:
                    if tests_pass(build, targets, env, a.timeout):
                        survived += 1
                        verdict = "SURVIVED"
                        survivors.append(f"{rel}:{n + 1}: {what}: {new.strip()}")
                    else:
                        killed += 1
                        verdict = "killed"
                print(f"{verdict:9} {rel}:{n + 1}: {what} ({time.monotonic() - t0:.0f} s)", flush=True)
        finally:
            with open(path, "w") as f:
                f.write(original)
            os.remove(backup)
            run(["cmake", "--build", build, "--target", *targets], 1200)
        counted = killed + survived
        table.append((rel, killed, survived, stillborn, 100.0 * killed / counted if counted else 0.0))
        for s in survivors:
            print(f"  survivor {s}")
    if table:
        print("| file | killed | survived | stillborn | score |")
        print("|---|---|---|---|---|")
        for rel, k, s, b, score in table:
            print(f"| `{rel}` | {k} | {s} | {b} | {score:.0f} % |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
