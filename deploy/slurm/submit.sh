#!/usr/bin/env bash
# Renders a scene on a Slurm cluster: a job array of N shards, then a merge that runs only if
# every shard succeeded.
#
#   deploy/slurm/submit.sh SCENE OUT N [RENDER_ARGS...]
#   deploy/slurm/submit.sh examples/tesseract.4ds renders/tesseract.gif 8 --size 320x240 --frames 48 --spp 256
#
# Task K of the array (render.sbatch) runs `hyperslice render SCENE --shard K/N --films FILMS
# RENDER_ARGS...`; the merge (merge.sbatch, --dependency=afterok on the array) runs
# `hyperslice merge FILMS -o OUT`. Prints `array_job=ID` and `merge_job=ID` on standard output.
# Submitting again with the same arguments resumes: finished shards are kept, interrupted ones
# carry on from their saved films. SCENE, OUT, FILMS and a binary given by path must be
# reachable at the same place from every node (a shared file system).
#
# Environment (all optional):
#   HYPERSLICE            the binary (default `hyperslice` on the nodes' PATH)
#   HYPERSLICE_FILMS      the films directory (default OUT without its extension + .films)
#   HYPERSLICE_LOGS       where the jobs' logs go (default OUT without its extension + .logs)
#   HYPERSLICE_PARTITION, HYPERSLICE_ACCOUNT, HYPERSLICE_QOS   sbatch --partition/--account/--qos
#   HYPERSLICE_TIME       time limit of each render task (sbatch --time, e.g. 2:00:00)
#   HYPERSLICE_CPUS       CPUs (render threads) per task (default: the cluster's default, 1)
#   HYPERSLICE_MEM        memory per task (sbatch --mem, e.g. 4G)
#   HYPERSLICE_ARRAY      which shards to submit (default 0-(N-1)), e.g. 3,7 to redo two
#   HYPERSLICE_ARRAY_LIMIT  most tasks running at once (the array's %LIMIT)
#   HYPERSLICE_SIGNAL_LEAD  seconds before the time limit to stop and requeue (default 120)
#   HYPERSLICE_MERGE_TIME, HYPERSLICE_MERGE_CPUS, HYPERSLICE_MERGE_MEM   the same for the merge
#   HYPERSLICE_MERGE_ARGS extra arguments of `hyperslice merge` (split on whitespace)
#   HYPERSLICE_JOB_NAME   job name prefix (default hs-NAME, NAME being OUT's file stem)
#   HYPERSLICE_SBATCH_ARGS  extra sbatch options for both jobs (split on whitespace)
# sbatch's own input variables (SBATCH_PARTITION, SBATCH_ACCOUNT, ...) work too.
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
usage() {
  echo "usage: $0 SCENE OUT N [RENDER_ARGS...]" >&2
  exit 2
}
die() {
  echo "submit.sh: error: $*" >&2
  exit 1
}

[[ $# -ge 3 ]] || usage
scene=$1
out=$2
n=$3
shift 3
[[ $n =~ ^[1-9][0-9]*$ ]] || die "N must be a positive whole number, not '$n'"
[[ -f $scene ]] || die "no scene file '$scene'"
case $out in
  *.gif | *.png | *.exr) ;;
  *) die "OUT must end in .gif, .png or .exr: '$out'" ;;
esac
for a in "$@"; do
  case $a in
    --shard | --shard=* | --films | --films=* | -o | --output | --output=*)
      die "$a is set by submit.sh; leave it out of RENDER_ARGS" ;;
  esac
done
command -v sbatch >/dev/null || die "sbatch is not on PATH (run this on a Slurm login node)"

# The jobs may start in another directory or on another node: pass absolute paths.
scene=$(realpath -- "$scene")
out=$(realpath -m -- "$out")
stem=${out%.*}
films=$(realpath -m -- "${HYPERSLICE_FILMS:-$stem.films}")
logs=$(realpath -m -- "${HYPERSLICE_LOGS:-$stem.logs}")
bin=${HYPERSLICE:-hyperslice}
if [[ $bin == */* ]]; then
  bin=$(realpath -m -- "$bin")
  [[ -x $bin ]] || die "HYPERSLICE=$bin is not an executable file"
elif ! command -v "$bin" >/dev/null; then
  echo "submit.sh: warning: '$bin' is not on PATH here; the nodes must have it" >&2
fi
export HYPERSLICE=$bin
mkdir -p "$films" "$logs" "$(dirname "$out")"

name=${HYPERSLICE_JOB_NAME:-hs-$(basename "$stem")}
common=()
[[ -z ${HYPERSLICE_PARTITION:-} ]] || common+=(--partition "$HYPERSLICE_PARTITION")
[[ -z ${HYPERSLICE_ACCOUNT:-} ]] || common+=(--account "$HYPERSLICE_ACCOUNT")
[[ -z ${HYPERSLICE_QOS:-} ]] || common+=(--qos "$HYPERSLICE_QOS")
if [[ -n ${HYPERSLICE_SBATCH_ARGS:-} ]]; then
  read -r -a extra <<<"$HYPERSLICE_SBATCH_ARGS"
  common+=("${extra[@]}")
fi

array=${HYPERSLICE_ARRAY:-0-$((n - 1))}
lead=${HYPERSLICE_SIGNAL_LEAD:-120}
[[ $lead =~ ^[0-9]+$ ]] || die "HYPERSLICE_SIGNAL_LEAD must be a number of seconds, not '$lead'"
render_opts=(
  --array "$array${HYPERSLICE_ARRAY_LIMIT:+%$HYPERSLICE_ARRAY_LIMIT}"
  --job-name "$name-render"
  --output "$logs/render-%A_%a.out"
  --open-mode append
  --requeue
  --signal "B:USR1@$lead"
  --export "ALL,HYPERSLICE_SHARDS=$n,HYPERSLICE_SIGNAL_LEAD=$lead"
)
[[ -z ${HYPERSLICE_TIME:-} ]] || render_opts+=(--time "$HYPERSLICE_TIME")
[[ -z ${HYPERSLICE_CPUS:-} ]] || render_opts+=(--cpus-per-task "$HYPERSLICE_CPUS")
[[ -z ${HYPERSLICE_MEM:-} ]] || render_opts+=(--mem "$HYPERSLICE_MEM")

array_id=$(sbatch --parsable "${common[@]}" "${render_opts[@]}" \
  "$here/render.sbatch" "$scene" "$films" "$@")
array_id=${array_id%%;*} # --parsable prints ID or ID;CLUSTER
[[ $array_id =~ ^[0-9]+$ ]] || die "sbatch answered '$array_id' instead of a job id"

merge_opts=(
  --dependency "afterok:$array_id"
  --kill-on-invalid-dep=yes
  --job-name "$name-merge"
  --output "$logs/merge-%j.out"
  --open-mode append
)
[[ -z ${HYPERSLICE_MERGE_TIME:-} ]] || merge_opts+=(--time "$HYPERSLICE_MERGE_TIME")
[[ -z ${HYPERSLICE_MERGE_CPUS:-} ]] || merge_opts+=(--cpus-per-task "$HYPERSLICE_MERGE_CPUS")
[[ -z ${HYPERSLICE_MERGE_MEM:-} ]] || merge_opts+=(--mem "$HYPERSLICE_MERGE_MEM")
merge_args=()
[[ -z ${HYPERSLICE_MERGE_ARGS:-} ]] || read -r -a merge_args <<<"$HYPERSLICE_MERGE_ARGS"

if ! merge_id=$(sbatch --parsable "${common[@]}" "${merge_opts[@]}" \
  "$here/merge.sbatch" "$films" "$out" "${merge_args[@]}"); then
  die "the render array $array_id is queued but the merge was not; once it has finished run:
  sbatch --dependency=afterok:$array_id $here/merge.sbatch $films $out"
fi
merge_id=${merge_id%%;*}

echo "submit.sh: render array $array_id: tasks $array of $n, films in $films" >&2
echo "submit.sh: merge $merge_id after every task of $array_id succeeds: $out" >&2
echo "submit.sh: logs in $logs; watch with: squeue -j $array_id,$merge_id" >&2
echo "array_job=$array_id"
echo "merge_job=$merge_id"
