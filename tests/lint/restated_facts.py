#!/usr/bin/env python3
"""Fails when a front-end restates a fact of a device's table (issue 27).

A device's unit range, register addresses, state and mode values, scales
and link settings live in its rows (devices/<device>/.../registers.hpp) and
reach the front-ends through the device layer (unit_range, link_defaults,
Handles, the status view, the verbs). In cli/ and programs/ this test
refuses, outside comments:
  - a literal unit range: 247 or 254 (Modbus's own 247 is core's kMaxSerialUnit);
  - a raw register address used as an index (s[0x15]), or a state or work
    mode compared with a number (state == 17, mode >= 1);
  - a scale applied by hand (scaled(x, 10), lround(x * 100));
  - a profile's link field read directly (p.link.unit: use link_defaults()).
Each hit is printed as FILE:LINE: what: the line.

It also keeps the CLI a front-end: cli/ (every file) stays within
CLI_BUDGET lines. A device's verb, view or rule that would push it over
belongs below it, in the device layer, where every front-end gets it.
"""
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
# 3,500 at issue 27's end; `rtukit relay` (a new command: option wiring and
# printing, its logic in driver/fault_relay.hpp) added about 100. Issue 38
# replaces this count with the checks it stands for.
CLI_BUDGET = 3650
RULES = [
    ("a unit range (use the device's unit_range() or kMaxSerialUnit)", re.compile(r"\b(?:247|254)\b")),
    ("a raw register address (use the row's Handle)", re.compile(r"\[\s*0x[0-9A-Fa-f]+\s*\]")),
    ("a state or mode value (use the device's Phase, Family or plan_of)",
     re.compile(r"\b(?:state|mode)\s*(?:[=!]=|[<>]=?)\s*\d+")),
    ("a scale by hand (use the row: RegisterMap::from_number / to_number)",
     re.compile(r"\bscaled\s*\(|\blround\s*\([^)]*[*/]\s*(?:10|100|1000)\b")),
    ("a profile's link field (use profile::link_defaults / unit_range)",
     re.compile(r"(?:\bp|profile\(\)|\bprofile|kProfile)\s*(?:\.|->)\s*link\.(?:unit|baud|unit_max)\b")),
]


def code_of(line: str) -> str:
    """The line without its // comment. Strings count: a "1..254" in a help
    text restates the range too."""
    return line.split("//", 1)[0]


def main() -> int:
    hits = []
    files = 0
    for top in ("cli", "programs"):
        for path in sorted((ROOT / top).rglob("*")):
            if path.suffix not in (".cpp", ".hpp"):
                continue
            files += 1
            for number, line in enumerate(path.read_text().splitlines(), 1):
                code = code_of(line)
                for what, rule in RULES:
                    if rule.search(code):
                        hits.append(f"{path.relative_to(ROOT)}:{number}: {what}: {line.strip()}")
    for hit in hits:
        print(hit)
    if files < 10:
        print(f"only {files} files found under cli/ and programs/: is the tree there?")
        return 1
    cli_lines = sum(len(p.read_text().splitlines()) for p in (ROOT / "cli").iterdir() if p.is_file())
    print(f"{files} files, {len(hits)} restated facts; cli/ {cli_lines} lines (at most {CLI_BUDGET})")
    if cli_lines > CLI_BUDGET:
        print(f"cli/ has {cli_lines} lines, more than {CLI_BUDGET}: move device logic into devices/")
    return 1 if hits or cli_lines > CLI_BUDGET else 0


if __name__ == "__main__":
    sys.exit(main())
