#!/usr/bin/env bash
# ThreadSanitizer run (preset "tsan", ./build-tsan) of the tests that exercise threads: tracking
# (background bundle adjustment), pipeline and the fast integration tests through the binary.
# Reports in libraries stillmap does not build are suppressed by scripts/tsan.supp. OpenCV's
# parallel_for_ runs on TBB, which is not instrumented: TSan would see no happens-before between
# a loop body on TBB's workers and its caller, so in a TSan build OpenCV runs single-threaded
# (RunBuild, and every test program: tests/common/tsan_opencv_threads.cpp). Everything stillmap
# threads itself (read-ahead, background bundle adjustment, background fusion, output writers)
# is checked.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export TSAN_OPTIONS="${TSAN_OPTIONS:-halt_on_error=1 suppressions=$root/scripts/tsan.supp}"
"$root/scripts/setup.sh" tsan
ctest --test-dir "$root/build-tsan" --output-on-failure -j "${STILLMAP_JOBS:-2}" \
  -L "unit|integration" -LE "slow|hostile|data"
