#!/usr/bin/env bash
# The sanitizer routine: builds stillmap with AddressSanitizer and UndefinedBehaviorSanitizer
# (preset "sanitize", ./build-sanitize) and runs every test but the whole-sequence builds (label
# "slow"): the unit tests, the bad-input, eval and output-safety tests through the binary, and
# the hostile-input test. Any sanitizer report ends the test that caused it.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/setup.sh" sanitize
# Leaks are not checked: OpenCV's and TBB's thread pools hold memory until exit by design.
export ASAN_OPTIONS="${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=0}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-halt_on_error=1:abort_on_error=1:print_stacktrace=1}"
ctest --test-dir "$root/build-sanitize" --output-on-failure -j "${STILLMAP_JOBS:-2}" -LE slow
