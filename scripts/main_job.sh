#!/usr/bin/env bash
# The main job: install what is missing, build stillmap, and build the maps of a sequence.
#   scripts/main_job.sh                      the bundled sample: 10 s of people walking past a
#                                            moving camera, rendered by `stillmap synth` into
#                                            data/sample/ (once), mapped into out/
#   scripts/main_job.sh SEQUENCE_DIR OUT_DIR [more stillmap build options...]
# The camera is tracked (stillmap build's default); pass --poses groundtruth to map from the
# sequence's ground-truth poses instead.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/setup.sh"
stillmap="$root/build/apps/stillmap"

if [ $# -ge 1 ]; then
  sequence="$1"
  out="${2:-$root/out}"
  shift $(( $# > 2 ? 2 : $# ))
else
  sequence="$root/data/sample"
  out="$root/out"
  if [ ! -f "$sequence/synth.json" ]; then
    "$stillmap" synth "$sequence" --scenario walking_xyz --frames 300 --seed 1
  fi
fi
if [ ! -d "$sequence" ]; then
  echo "main_job: sequence folder '$sequence' not found; name one: scripts/main_job.sh SEQUENCE_DIR OUT_DIR" >&2
  exit 2
fi
"$stillmap" build "$sequence" -o "$out" "$@"
echo "main_job: outputs in $out"
