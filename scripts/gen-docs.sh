#!/usr/bin/env bash
# Regenerates the register references in docs/ from the device tables
# (`rtukit inverjet registers`, `rtukit rehand6600 registers|errors`). A test fails when the docs are stale.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/build.sh default >/dev/null
rtukit=build/default/cli/rtukit
replace() {  # file, marker name, command...
  local file=$1 name=$2
  shift 2
  local begin="<!-- BEGIN GENERATED: $name -->" end="<!-- END GENERATED: $name -->"
  local body
  body=$("$rtukit" "$@")
  /usr/bin/python3 - "$file" "$begin" "$end" "$body" <<'PY'
import sys
path, begin, end, body = sys.argv[1:5]
text = open(path).read()
a = text.index(begin) + len(begin)
b = text.index(end)
open(path, "w").write(text[:a] + "\n" + body + "\n" + text[b:])
PY
}
replace docs/inverjet.md "rtukit inverjet registers" inverjet registers
replace docs/rehand6600.md "rtukit rehand6600 registers" rehand6600 registers
replace docs/rehand6600.md "rtukit rehand6600 errors" rehand6600 errors
replace docs/rehand6600.md "rtukit rehand6600 stopping" rehand6600 stopping
echo "docs regenerated"
