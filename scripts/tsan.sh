#!/usr/bin/env bash
# ThreadSanitizer run (preset "tsan", ./build-tsan) of the tests that exercise threads: tracking
# (background bundle adjustment), pipeline and the fast integration tests through the binary.
# Reports in libraries stillmap does not build are suppressed by scripts/tsan.supp. Known limit:
# OpenCV's parallel_for_ runs on TBB, which is not instrumented, so work handed to TBB's workers
# and back (the map cleaning and grid reading the OctoMap) is reported as racing with what the
# caller does afterwards; the tracking tests (background bundle adjustment) are clean.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export TSAN_OPTIONS="${TSAN_OPTIONS:-halt_on_error=1 suppressions=$root/scripts/tsan.supp}"
"$root/scripts/setup.sh" tsan
ctest --test-dir "$root/build-tsan" --output-on-failure -j "${STILLMAP_JOBS:-2}" \
  -L "unit|integration" -LE "slow|hostile|data"
