#!/usr/bin/env bash
# Regenerates the generated sections of every registered device's doc
# (docs/inverjet.md, docs/rehand6600.md: register references, error codes,
# stopping distances) from the device tables, through the device registry
# (`rtukit devices --write-docs`). The test Docs.GeneratedSectionsAreCurrent
# fails when one is stale.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/build.sh default >/dev/null
build/default/cli/rtukit devices --write-docs .
