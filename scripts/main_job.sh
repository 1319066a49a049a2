#!/usr/bin/env bash
# The main job: install what is missing, build stillmap, and build a map of a sequence.
#   scripts/main_job.sh [SEQUENCE_DIR] [OUT_DIR] [extra stillmap build options...]
# Without arguments it maps ../shared/data/tum_fr3_teddy_200 from its ground-truth poses.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/setup.sh"

sequence="${1:-$root/../shared/data/tum_fr3_teddy_200}"
out="${2:-$root/out}"
shift $(( $# > 2 ? 2 : $# ))
if [ ! -d "$sequence" ]; then
  echo "main_job: sequence folder '$sequence' not found; name one: scripts/main_job.sh SEQUENCE_DIR OUT_DIR" >&2
  exit 2
fi
"$root/build/apps/stillmap" build "$sequence" -o "$out" --poses groundtruth "$@"
echo "main_job: outputs in $out"
