#!/usr/bin/python3
"""The suite's verdict from ctest's JUnit file: "N passed, N failed, N
skipped" in one line, every skipped and failed test named, and a failure
when a test was skipped that tests/skips.allowed does not allow for this
stage (a skipped test proves nothing; CTest counts it as passed).

Usage: test-report.py JUNIT_XML STAGE [ALLOW_LIST]
Exit 0 when nothing failed and every skip is allowed, 1 otherwise."""
import os
import sys
import xml.etree.ElementTree as ET


def allowed_skips(path, stage):
    allowed = {}
    with open(path) as f:
        for line in f:
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            name, stages, reason = (part.strip() for part in line.split("|", 2))
            if stage in (s.strip() for s in stages.split(",")):
                allowed[name] = reason
    return allowed


def main():
    junit, stage = sys.argv[1], sys.argv[2]
    allow = sys.argv[3] if len(sys.argv) > 3 else os.path.join(os.path.dirname(__file__), "..", "tests", "skips.allowed")
    root = ET.parse(junit).getroot()
    passed, failed, skipped = [], [], []
    for case in root.iter("testcase"):
        name = case.get("name")
        if case.find("skipped") is not None or case.get("status") == "notrun":
            skipped.append(name)
        elif case.find("failure") is not None or case.get("status") == "fail":
            failed.append(name)
        else:
            passed.append(name)
    allowed = allowed_skips(allow, stage)
    print(f"{stage}: {len(passed)} passed, {len(failed)} failed, {len(skipped)} skipped")
    for name in failed:
        print(f"  FAILED  {name}")
    bad = []
    for name in skipped:
        if name in allowed:
            print(f"  skipped {name} (allowed here: {allowed[name]})")
        else:
            print(f"  SKIPPED {name}: not allowed in stage '{stage}' by tests/skips.allowed")
            bad.append(name)
    return 0 if not failed and not bad else 1


if __name__ == "__main__":
    sys.exit(main())
