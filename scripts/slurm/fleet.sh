#!/usr/bin/env bash
# A fleet's recordings on an existing Slurm cluster: one `stillmap build` per recording as a job
# array, then one `stillmap merge` of all sessions that starts when every build has succeeded.
#
#   scripts/slurm/fleet.sh RECORDINGS.txt OUT_DIR [options]
#
# RECORDINGS.txt: one session per line, `NAME RECORDING [build options...]` (blank lines and
# lines starting with '#' are skipped). NAME names the session (OUT_DIR/sessions/NAME and the
# merge's trajectory_NAME.txt); RECORDING is a TUM folder or a bag; the options go to
# `stillmap build` as they are (--set sequence.first_frame=250, --topic color=/cam/rgb, ...).
# The first line's session sets the merged map's frame.
#
# Options:
#   --cpus N          CPUs per build task (default 2; the build's --threads)
#   --mem SIZE        memory per build task, as sbatch takes it (default 3G)
#   --merge-mem SIZE  memory of the merge job (default 6G)
#   --partition P     partition for both jobs (default: the cluster's default)
#   --stillmap PATH   the stillmap binary, on a file system every node sees (default: this
#                     clone's build/apps/stillmap)
#   --models DIR      detector models for the builds (default: as stillmap build finds them)
#   --wait            return only when the merge has finished (its exit status)
#
# Writes OUT_DIR/sessions/NAME/ (each build's outputs), OUT_DIR/merged/ (the merged map),
# OUT_DIR/logs/ (one log per task) and prints the two job ids. Needs sbatch on the PATH.
set -euo pipefail

usage() { sed -n '2,25p' "$0" | sed 's/^# \{0,1\}//'; exit 2; }
die() { echo "fleet.sh: $*" >&2; exit 2; }

[ $# -ge 2 ] || usage
recordings="$1"
out="$2"
shift 2
cpus=2 mem=3G merge_mem=6G partition="" wait=0 models=""
stillmap="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)/build/apps/stillmap"
while [ $# -gt 0 ]; do
  case "$1" in
    --cpus) cpus="$2"; shift 2 ;;
    --mem) mem="$2"; shift 2 ;;
    --merge-mem) merge_mem="$2"; shift 2 ;;
    --partition) partition="$2"; shift 2 ;;
    --stillmap) stillmap="$2"; shift 2 ;;
    --models) models="$2"; shift 2 ;;
    --wait) wait=1; shift ;;
    -h|--help) usage ;;
    *) die "unknown option '$1' (--help lists them)" ;;
  esac
done
[ -f "$recordings" ] || die "$recordings: no such file (one 'NAME RECORDING [options]' per line)"
[ -x "$stillmap" ] || die "$stillmap: not an executable (build stillmap first, or pass --stillmap)"
command -v sbatch >/dev/null || die "sbatch not found: this needs a Slurm cluster's client tools"
[[ "$cpus" =~ ^[1-9][0-9]*$ ]] || die "--cpus must be a whole number of CPUs, not '$cpus'"

# The sessions, checked before anything is submitted.
list="$(grep -v -E '^[[:space:]]*(#|$)' "$recordings" || true)"
[ -n "$list" ] || die "$recordings: no recording listed"
count=0
declare -A seen=()
absolute=""
while read -r name recording options; do
  count=$((count + 1))
  [[ "$name" =~ ^[A-Za-z0-9._-]+$ ]] || die "$recordings: session name '$name' (line $count of the list) may hold only letters, digits, '.', '_' and '-'"
  [ -z "${seen[$name]:-}" ] || die "$recordings: session '$name' is listed twice"
  seen[$name]=1
  [ -e "$recording" ] || die "$recordings: recording '$recording' of session '$name' not found"
  absolute+="$name $(realpath "$recording") $options"$'\n'
done <<< "$list"
list="${absolute%$'\n'}"
[ "$count" -ge 2 ] || die "$recordings: a merge needs at least two sessions"

mkdir -p "$out/logs" "$out/sessions"
out="$(cd "$out" && pwd)"
printf '%s\n' "$list" > "$out/recordings.txt"
common=(--parsable)
[ -n "$partition" ] && common+=(--partition "$partition")

# The builds: task i builds line i of recordings.txt.
build_job=$(sbatch "${common[@]}" --job-name=stillmap-build --array="0-$((count - 1))" \
  --cpus-per-task="$cpus" --mem="$mem" --output="$out/logs/build_%a.log" \
  --export=ALL,STILLMAP_BIN="$stillmap",STILLMAP_FLEET_OUT="$out",STILLMAP_FLEET_MODELS="$models" \
  "$(dirname "${BASH_SOURCE[0]}")/build_task.sh")
echo "builds: job array $build_job ($count tasks)"

# The merge, once every build has succeeded (afterok: a failed build holds the merge back).
sessions=()
while read -r name _; do sessions+=("$out/sessions/$name"); done <<< "$list"
merge_args=(--dependency="afterok:$build_job" --job-name=stillmap-merge --cpus-per-task="$cpus"
            --mem="$merge_mem" --output="$out/logs/merge.log")
[ "$wait" -eq 1 ] && merge_args+=(--wait)
set +e
merge_job=$(sbatch "${common[@]}" "${merge_args[@]}" \
  --wrap="exec '$stillmap' merge ${sessions[*]} -o '$out/merged' --threads $cpus --quiet")
status=$?
set -e
echo "merge: job ${merge_job%%;*} (after the builds)"
exit "$status"
