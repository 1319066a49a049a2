#!/usr/bin/env bash
# Installs what is missing, builds stillmap and runs every test (CTest). Tests that need the real
# sequences of ../shared/data (or $STILLMAP_DATA) skip with a message when they are absent.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/setup.sh"
ctest --test-dir "$root/build" --output-on-failure -j "${STILLMAP_JOBS:-2}"
