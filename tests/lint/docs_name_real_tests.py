#!/usr/bin/env python3
"""Fails when the docs name a test that does not exist (issue 36: a claim
backed by a test that was renamed or deleted is backed by nothing).

Reads every Markdown file under docs/, README.md and bench/README.md for
`Suite.Name` where Suite is a test suite of this build (ctest -N), and
`tests/...`, `bench/...`, `fuzz/...`, `scripts/...` paths in backticks.
A test name must be one ctest knows (or the start of some, as in
"ServerProtection.OutOfFileDescriptors" or "RehandFaults.*"); a path must
exist. Every test of this build runs in CI's first stage (the README's
suite runs them all; no label is left out there), so a test that exists is
a test CI runs. Each problem is printed as FILE: NAME.

Usage: docs_name_real_tests.py BUILD_DIR
"""
import pathlib
import re
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
NAME = re.compile(r"\b([A-Z][A-Za-z0-9]+)\.([A-Za-z][A-Za-z0-9_]*)(\*)?")
PATH = re.compile(r"`((?:tests|bench|fuzz|scripts)/[A-Za-z0-9_./*-]+)`")


def main() -> int:
    listing = subprocess.run(["ctest", "--test-dir", sys.argv[1], "-N"], capture_output=True, text=True,
                             check=True).stdout
    tests = set(re.findall(r"^\s*Test\s+#\d+: (\S+)", listing, re.M))
    if len(tests) < 100:
        print(f"only {len(tests)} tests listed in {sys.argv[1]}: not the suite's build")
        return 1
    suites = {t.split(".")[0] for t in tests if "." in t}
    docs = sorted((ROOT / "docs").glob("*.md")) + [ROOT / "README.md", ROOT / "bench" / "README.md"]
    problems, named = [], 0
    for doc in docs:
        text = doc.read_text()
        for m in NAME.finditer(text):
            suite, name, star = m.groups()
            if suite not in suites:
                continue
            named += 1
            full = f"{suite}.{name}"
            if full in tests or any(t.startswith(full) for t in tests):
                continue
            problems.append(f"{doc.relative_to(ROOT)}: no test {full}{star or ''}")
        for m in PATH.finditer(text):
            path = m.group(1).rstrip(".")
            if not list(ROOT.glob(path)) and not list(ROOT.glob(path + "*")):
                problems.append(f"{doc.relative_to(ROOT)}: no file {path}")
    for p in problems:
        print(p)
    print(f"docs name {named} tests of {len(tests)}; {len(problems)} problem(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
