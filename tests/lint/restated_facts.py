#!/usr/bin/env python3
"""Fails when a front-end restates a fact of a device's table (issues 27, 38).

A device's unit range, register addresses, codes, state and mode values,
scales, bounds and link settings live in its rows
(devices/<device>/.../registers.hpp) and reach the front-ends through the
device layer (unit_range, link_defaults, Handles, the views, the state
documents, the verbs). The front-ends are cli/ and programs/ (C++) and
web/assets/ (the pages' scripts). Outside comments this test refuses:

  C++ and the pages alike:
  - a literal unit range: 247 or 254 (Modbus's own 247 is core's kMaxSerialUnit);
  - a state or work mode compared with a number (state == 17, mode >= 1);
  - a row's bounds written out: for every row of every registered device
    (`rtukit <device> registers --json`: its range and its write range), the
    pair as "lo..hi", Range(lo, hi) or [lo, hi], unless the pair is trivial
    (a span under 10, a whole 16-bit word);
  C++:
  - a raw register address used as an index (s[0x15]);
  - address arithmetic on a register constant (reg::kActuatorState + n - 1:
    the device layer names each address);
  - a scale applied by hand (scaled(x, 10), lround(x * 100));
  - a profile's link field read directly (p.link.unit: use link_defaults());
  - a device's model or simulator header included (machine.hpp, chair.hpp,
    sim.hpp): a front-end reaches a device through its client, host, verbs
    and views, never its internals;
  the pages:
  - a code or address compared as a number (s.error === 0x1010);
  - the Inverjet's longest time (99:59, 5999 s): the page gets it from the
    panel's limits.
And for the build: no front-end target (cli/, programs/) links a device's
model target (rtukit::<device>_model) by name.

Each hit is printed as FILE:LINE: what: the line. This replaces the line
budget cli/ once had (3,650 lines), which stood for these rules: a
front-end's size says nothing, a restated fact does.

Usage: restated_facts.py [RTUKIT]   (without RTUKIT the row bounds are not checked)
"""
import json
import pathlib
import re
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
FRONT_ENDS = ("cli", "programs")
PAGES = "web/assets"

UNIT_RANGE = ("a unit range (use the device's unit_range() or kMaxSerialUnit)", re.compile(r"\b(?:247|254)\b"))
STATE_NUMBER = ("a state or mode value (use the device's Phase, Family or plan_of; on a page, the state's names)",
                re.compile(r"\b(?:state|mode)\s*(?:[=!]==?|[<>]=?)\s*\d+"))
CPP_RULES = [
    UNIT_RANGE,
    STATE_NUMBER,
    ("a raw register address (use the row's Handle)", re.compile(r"\[\s*0x[0-9A-Fa-f]+\s*\]")),
    ("address arithmetic on a register constant (the device layer names each address)",
     re.compile(r"\breg::k\w+\s*[-+]\s*[\w(]")),
    ("a scale by hand (use the row: RegisterMap::from_number / to_number)",
     re.compile(r"\bscaled\s*\(|\blround\s*\([^)]*[*/]\s*(?:10|100|1000)\b")),
    ("a profile's link field (use profile::link_defaults / unit_range)",
     re.compile(r"(?:\bp|profile\(\)|\bprofile|kProfile)\s*(?:\.|->)\s*link\.(?:unit|baud|unit_max)\b")),
    ("a device's internals (its model or simulator: use its client, host, verbs and views)",
     re.compile(r'#include\s+"rtukit/devices/\w+/(?:machine|chair|sim)\.hpp"')),
]
JS_RULES = [
    UNIT_RANGE,
    STATE_NUMBER,
    ("a code or address compared as a number (the state says what it means)",
     re.compile(r"[=!]==?\s*0x[0-9A-Fa-f]+\b")),
    ("the Inverjet's longest time (the panel's limits give it)", re.compile(r"\b99:59\b|\b5999\b")),
]
MODEL_LINK = re.compile(r"rtukit::\w+_model\b")


def code_of(line: str) -> str:
    """The line without its // comment. Strings count: a "1..254" in a help
    text restates the range too."""
    return line.split("//", 1)[0]


def row_bounds(rtukit):
    """Every non-trivial (lo, hi) of every registered device's rows."""
    devices = subprocess.run([rtukit, "devices", "--json"], capture_output=True, text=True, timeout=60)
    names = [d["name"] for d in json.loads(devices.stdout)["devices"]]
    bounds = set()
    for name in names:
        out = subprocess.run([rtukit, name, "registers", "--json"], capture_output=True, text=True, timeout=60)
        for row in json.loads(out.stdout)["registers"]:
            for key in ("range", "writable_range"):
                if row.get(key):
                    lo, hi = row[key]
                    if hi - lo >= 10 and (lo, hi) not in ((0, 65535), (-32768, 32767)):
                        bounds.add((lo, hi))
    return names, sorted(bounds)


def bound_rules(bounds):
    rules = []
    for lo, hi in bounds:
        pair = rf"(?<![\w.]){lo}\s*(?:\.\.|,)\s*{hi}(?![\w.])"
        rules.append((f"a row's bounds ({lo}..{hi}: take them from the row or the device's limits)",
                      re.compile(rf"(?<![\w.]){lo}\s*\.\.\s*{hi}(?![\w.])|Range\(\s*{pair}\s*\)|\[\s*{pair}\s*\]")))
    return rules


def scan(paths, rules, hits):
    for path in paths:
        for number, line in enumerate(path.read_text().splitlines(), 1):
            code = code_of(line)
            if code.lstrip().startswith(("*", "/*")):
                continue  # a block comment's line
            for what, rule in rules:
                if rule.search(code):
                    hits.append(f"{path.relative_to(ROOT)}:{number}: {what}: {line.strip()}")


def main() -> int:
    hits = []
    sources = [p for top in FRONT_ENDS for p in sorted((ROOT / top).rglob("*")) if p.suffix in (".cpp", ".hpp")]
    pages = sorted((ROOT / PAGES).rglob("*.js"))
    if len(sources) < 10 or len(pages) < 5:
        print(f"only {len(sources)} sources under {FRONT_ENDS} and {len(pages)} page scripts: is the tree there?")
        return 1
    extra = []
    if len(sys.argv) > 1:
        names, bounds = row_bounds(sys.argv[1])
        if not bounds:
            print(f"no row bounds read from {names}: is the binary right?")
            return 1
        extra = bound_rules(bounds)
        print(f"row bounds of {', '.join(names)}: {', '.join(f'{lo}..{hi}' for lo, hi in bounds)}")
    scan(sources, CPP_RULES + extra, hits)
    scan(pages, JS_RULES + extra, hits)
    for top in FRONT_ENDS:
        for path in sorted((ROOT / top).rglob("CMakeLists.txt")):
            for number, line in enumerate(path.read_text().splitlines(), 1):
                if MODEL_LINK.search(line.split("#", 1)[0]):
                    hits.append(f"{path.relative_to(ROOT)}:{number}: a device's model target linked by a front-end "
                                f"(link the device's library): {line.strip()}")
    for hit in hits:
        print(hit)
    print(f"{len(sources)} front-end sources, {len(pages)} page scripts: {len(hits)} restated facts")
    return 1 if hits else 0


if __name__ == "__main__":
    sys.exit(main())
