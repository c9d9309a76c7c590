#!/usr/bin/env python3
"""Every command the README's demo (scripts/demo.sh) runs, and every
`rtukit ...` line an example file tells its reader to try (examples/**: the
"# Try it:" comments), is a command the rtukit binary has: a command renamed
or moved (as `rtukit watch` became `rtukit map watch`) would otherwise leave
the demo printing "unknown command" while still exiting 0, and an example
telling users to run a command that no longer exists (energy-meter.yaml did).

Usage: demo_commands.py RTUKIT   (exit 1 naming each line that fails)
"""
import pathlib
import re
import shlex
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
DEMO = ROOT / "scripts" / "demo.sh"
EXAMPLES = ROOT / "examples"


def command_words(args):
    """The leading words that name the (sub)command: up to the first option,
    quoted shell value or number."""
    words = []
    for word in args:
        if word.startswith(("-", "$", '"')) or word[:1].isdigit():
            break
        words.append(word)
    return words


def check_command(rtukit, words, where, failures):
    """`rtukit WORDS --help` must succeed: the command exists as written."""
    done = subprocess.run([rtukit, *words, "--help"], capture_output=True, text=True, timeout=60)
    if done.returncode != 0:
        failures.append(f"{where}: rtukit {' '.join(words)}: {(done.stderr or done.stdout).strip().splitlines()[:1]}")


def main():
    rtukit = sys.argv[1]
    failures, checked = [], 0
    for number, line in enumerate(DEMO.read_text().splitlines(), 1):
        match = re.match(r'\s*(?:run|"\$rtukit")\s+(.*)', line)
        if not match or line.lstrip().startswith("run()"):
            continue
        code = match.group(1).split("#", 1)[0]
        words = command_words(shlex.split(code, posix=False))
        if not words:
            continue
        checked += 1
        check_command(rtukit, words, f"scripts/demo.sh:{number}", failures)
    if checked < 20:
        failures.append(f"only {checked} demo commands found in {DEMO}: did the demo's `run` helper change?")
    examples = 0
    for path in sorted(p for p in EXAMPLES.rglob("*") if p.is_file()):
        for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
            match = re.match(r'\s*(?:#|//)\s{2,}rtukit\s+(.*)', line)  # an indented command, not prose
            if not match:
                continue
            words = command_words(shlex.split(match.group(1).split(" #", 1)[0], posix=False))
            if not words:
                continue
            examples += 1
            check_command(rtukit, words, f"{path.relative_to(ROOT)}:{number}", failures)
    if examples < 3:
        failures.append(f"only {examples} commands found in the examples' comments: did their form change?")
    for failure in failures:
        print(failure)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
