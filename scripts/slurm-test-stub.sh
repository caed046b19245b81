#!/usr/bin/env bash
# A stand-in for the hyperslice binary with the shape of its distributed-render interface, so
# that scripts/slurm-test.sh --stub can prove the Slurm plumbing (job array, afterok merge,
# requeue and resume) before the real `--shard` and `merge` exist:
#
#   slurm-test-stub.sh render SCENE --shard K/N --films DIR [FLAGS...]   one shard's "film"
#   slurm-test-stub.sh render SCENE -o OUT [FLAGS...]                    the whole "image"
#   slurm-test-stub.sh merge DIR... -o OUT                               films -> "image"
#
# Like the real renderer it splits whole frames between shards when there are at least N of
# them (--frames, default 1) and every frame's samples otherwise, writes a film as it goes,
# saves it and exits 130 on SIGTERM, resumes a saved film when run again, and its merge checks
# that the shards are complete and consistent. The "image" is text: one line per frame, the
# same whether rendered at once or merged, so `cmp` can compare the two. FLAGS other than
# --frames and --threads are only recorded. STUB_SECONDS_PER_UNIT (default 0) makes every
# frame (or frame part) take that long, so that a test can interrupt a shard midway.
set -euo pipefail

die() {
  echo "slurm-test-stub: error: $*" >&2
  exit 2
}

# The lines every film and image start with: what was rendered, and how.
header() {
  local scene=$1 frames=$2 settings=$3
  echo "hyperslice-stub 1"
  echo "scene $(sha256sum <"$scene" | cut -d' ' -f1)"
  echo "frames $frames"
  echo "settings $settings"
}

image() {
  local scene=$1 frames=$2 settings=$3 f
  header "$scene" "$frames" "$settings"
  for ((f = 0; f < frames; f++)); do echo "frame $f"; done
}

render() {
  local scene='' shard='' films='' out='' frames=1 settings=()
  while [[ $# -gt 0 ]]; do
    case $1 in
      --help | -h)
        echo "usage: slurm-test-stub.sh render SCENE (--shard K/N --films DIR | -o OUT) [--frames N] [FLAGS]"
        return 0
        ;;
      --shard) shard=${2:?--shard needs K/N}; shift 2 ;;
      --films) films=${2:?--films needs a directory}; shift 2 ;;
      -o | --output) out=${2:?-o needs a file}; shift 2 ;;
      --frames) frames=${2:?--frames needs a number}; settings+=("$1" "$2"); shift 2 ;;
      --threads) shift 2 ;; # must not change the image
      -*) settings+=("$1"); shift ;;
      *)
        if [[ -z $scene ]]; then scene=$1; else settings+=("$1"); fi
        shift
        ;;
    esac
  done
  [[ -n $scene && -f $scene ]] || die "no scene file: '$scene'"
  [[ $frames =~ ^[1-9][0-9]*$ ]] || die "bad --frames '$frames'"
  local sig="${settings[*]-}"

  if [[ -z $shard ]]; then
    [[ -n $out ]] || die "render needs -o OUT, or --shard K/N --films DIR"
    image "$scene" "$frames" "$sig" >"$out"
    echo "slurm-test-stub: wrote $out" >&2
    return 0
  fi
  [[ -n $films ]] || die "--shard needs --films DIR"
  [[ $shard =~ ^([0-9]+)/([1-9][0-9]*)$ ]] || die "bad --shard '$shard' (want K/N)"
  local k=${BASH_REMATCH[1]} n=${BASH_REMATCH[2]}
  ((k < n)) || die "shard $k is not below $n"

  # This shard's units of work: whole frames, or this shard's part of every frame.
  local units=() f
  if ((frames >= n)); then
    for ((f = k; f < frames; f += n)); do units+=("frame $f"); done
  else
    for ((f = 0; f < frames; f++)); do units+=("frame $f part $k/$n"); done
  fi

  mkdir -p "$films"
  local film="$films/shard-$k-of-$n.film" partial="$films/shard-$k-of-$n.film.partial"
  local head
  head="$(header "$scene" "$frames" "$sig")"$'\n'"shard $k/$n"
  if [[ -f $film ]]; then
    [[ $(head -n 5 "$film") == "$head" ]] || die "$film belongs to another render"
    echo "slurm-test-stub: shard $k/$n: already complete" >&2
    return 0
  fi
  local done_units=0
  if [[ -f $partial ]]; then
    [[ $(head -n 5 "$partial") == "$head" ]] || die "$partial belongs to another render"
    done_units=$(($(wc -l <"$partial") - 5))
    echo "slurm-test-stub: shard $k/$n: resuming at unit $done_units of ${#units[@]}" >&2
  else
    echo "$head" >"$partial"
    echo "slurm-test-stub: shard $k/$n: starting, ${#units[@]} units" >&2
  fi

  local stop=
  trap 'stop=1' TERM INT
  local i
  for ((i = done_units; i < ${#units[@]}; i++)); do
    sleep "${STUB_SECONDS_PER_UNIT:-0}" || true
    if [[ -n $stop ]]; then break; fi
    echo "${units[i]}" >>"$partial"
  done
  if [[ -n $stop ]]; then
    echo "slurm-test-stub: shard $k/$n: interrupted, saved $i of ${#units[@]} units" >&2
    exit 130
  fi
  mv "$partial" "$film"
  echo "slurm-test-stub: shard $k/$n: done" >&2
}

merge() {
  local dirs=() out=
  while [[ $# -gt 0 ]]; do
    case $1 in
      --help | -h)
        echo "usage: slurm-test-stub.sh merge DIR... -o OUT"
        return 0
        ;;
      -o | --output) out=${2:?-o needs a file}; shift 2 ;;
      -*) shift ;;
      *) dirs+=("$1"); shift ;;
    esac
  done
  [[ -n $out && ${#dirs[@]} -gt 0 ]] || die "usage: merge DIR... -o OUT"
  local d films=() partials=()
  for d in "${dirs[@]}"; do
    [[ -d $d ]] || die "no films directory '$d'"
    for f in "$d"/*.film; do [[ -e $f ]] && films+=("$f"); done
    for f in "$d"/*.film.partial; do [[ -e $f ]] && partials+=("$f"); done
  done
  ((${#partials[@]} == 0)) || die "unfinished shards: ${partials[*]}"
  ((${#films[@]} > 0)) || die "no films in ${dirs[*]}"

  local first n='' seen=() f shard k
  first=$(head -n 4 "${films[0]}")
  for f in "${films[@]}"; do
    [[ $(head -n 4 "$f") == "$first" ]] || die "$f is from another render than ${films[0]}"
    shard=$(sed -n '5s/^shard //p' "$f")
    [[ $shard =~ ^([0-9]+)/([0-9]+)$ ]] || die "$f has no shard line"
    k=${BASH_REMATCH[1]}
    [[ -z $n || $n == "${BASH_REMATCH[2]}" ]] || die "$f is one of ${BASH_REMATCH[2]} shards, not $n"
    n=${BASH_REMATCH[2]}
    [[ -z ${seen[k]-} ]] || die "shard $k/$n is there twice"
    seen[k]=1
  done
  local missing=()
  for ((k = 0; k < n; k++)); do [[ -n ${seen[k]-} ]] || missing+=("$k"); done
  ((${#missing[@]} == 0)) || die "missing shards of $n: ${missing[*]}"

  # Every frame must be there exactly once, or in all n parts.
  local frames expected got
  frames=$(sed -n '3s/^frames //p' "${films[0]}")
  if ((frames >= n)); then
    expected=$(for ((f = 0; f < frames; f++)); do echo "frame $f"; done)
  else
    expected=$(for ((f = 0; f < frames; f++)); do
      for ((k = 0; k < n; k++)); do echo "frame $f part $k/$n"; done
    done)
  fi
  got=$(for f in "${films[@]}"; do tail -n +6 "$f"; done | sort -V)
  [[ $got == "$(sort -V <<<"$expected")" ]] || die "the films do not cover every frame once"
  {
    echo "$first"
    for ((f = 0; f < frames; f++)); do echo "frame $f"; done
  } >"$out"
  echo "slurm-test-stub: merged ${#films[@]} shards into $out" >&2
}

case ${1:-} in
  render) shift; render "$@" ;;
  merge) shift; merge "$@" ;;
  *) die "usage: slurm-test-stub.sh render|merge ..." ;;
esac
