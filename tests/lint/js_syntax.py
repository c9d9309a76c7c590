#!/usr/bin/env python3
"""Fails when a page's script does not parse (node --check, as an ES module).

The pages' scripts are built into the binary as they are (no build step), so
a syntax error would only show as a blank page in the browser tests, minutes
later and far from its cause. This check names the file and line at once.
Node is test tooling here, needed by the browser tests' npm tooling too
(scripts/setup.sh); without it the test fails and says so.
"""
import pathlib
import shutil
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]


def main() -> int:
    node = shutil.which("node") or shutil.which("nodejs")
    if not node:
        print("node is not installed: run scripts/setup.sh")
        return 1
    bad = 0
    files = sorted((ROOT / "web" / "assets").rglob("*.js"))
    for path in files:
        with path.open("rb") as source:
            run = subprocess.run([node, "--input-type=module", "--check"], stdin=source,
                                 capture_output=True, text=True)
        if run.returncode != 0:
            bad += 1
            print(f"{path.relative_to(ROOT)}: does not parse\n{run.stderr.strip()}")
    print(f"{len(files) - bad} of {len(files)} scripts parse")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
