#!/usr/bin/env bash
# One task of scripts/slurm/fleet.sh's job array: builds line $SLURM_ARRAY_TASK_ID (from 0) of
# $STILLMAP_FLEET_OUT/recordings.txt into $STILLMAP_FLEET_OUT/sessions/NAME with the task's CPUs.
set -euo pipefail
line=$(sed -n "$((SLURM_ARRAY_TASK_ID + 1))p" "$STILLMAP_FLEET_OUT/recordings.txt")
read -r -a fields <<< "$line"
name="${fields[0]}"
recording="${fields[1]}"
options=("${fields[@]:2}")
[ -n "${STILLMAP_FLEET_MODELS:-}" ] && options+=(--models "$STILLMAP_FLEET_MODELS")
echo "stillmap-build task $SLURM_ARRAY_TASK_ID on $(hostname): session $name from $recording"
exec "$STILLMAP_BIN" build "$recording" -o "$STILLMAP_FLEET_OUT/sessions/$name" \
  --threads "${SLURM_CPUS_PER_TASK:-2}" --quiet "${options[@]}"
