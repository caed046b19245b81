#!/usr/bin/env bash
# End-to-end test of the Slurm deployment (deploy/slurm/) on a throwaway one-node Slurm cluster
# on this machine. Needs root and Debian/Ubuntu (apt-get); takes a minute or two.
#
#   bash scripts/slurm-test.sh           # the real renderer (cargo build --release)
#   bash scripts/slurm-test.sh --stub    # scripts/slurm-test-stub.sh in its place
#
# It builds the renderer (cargo build --release; it must have `render --shard` and `merge`),
# installs slurm-wlm and munge if sbatch is missing, writes /etc/slurm/slurm.conf for this
# host (keeping any earlier one aside and putting it back), starts munged, slurmctld and
# slurmd, waits for the node to be idle, and then, through deploy/slurm/submit.sh, checks:
#   1. frame shards: examples/tesseract.4ds as 3 shards of 3 frames, merged after the array
#      (afterok), is byte for byte the single-machine render with the same flags;
#   2. sample shards: 1 frame split into 2 shards (each renders half of every pixel's samples),
#      merged; a byte difference from the single-machine render is reported, not failed;
#   3. a failed task stops the merge: with shard 1 made to fail, the merge never runs and OUT
#      is not written; then submitting the same command again resumes and completes it;
#   4. interrupted tasks resume: one task gets the time-limit warning (SIGUSR1 to the batch
#      script: it stops the renderer and requeues itself), another is requeued as on
#      preemption (`scontrol requeue`: SIGTERM); both carry on from their films, and the merge
#      is again the single-machine render;
#   5. only with --time-limit (5 more minutes): a shard of about 80 s under a 1-minute time limit
#      stops before the limit, requeues itself and resumes until it is done.
# It prints `ok`/`FAIL` per check and a last PASS or FAIL line (exit status 0 or 1), then stops
# the daemons it started and removes what it wrote (but not the packages it installed, unless
# SLURM_TEST_REMOVE_PACKAGES=1).
#
# Options and environment:
#   --stub (or SLURM_TEST_STUB=1)  test the plumbing with the stub instead of the renderer
#   --keep (or SLURM_TEST_KEEP=1)  keep the work directory (films, logs, outputs)
#   --time-limit (or SLURM_TEST_TIME_LIMIT=1)  add check 5
#   HYPERSLICE=PATH                the renderer to test instead of target/release/hyperslice
#   SLURM_TEST_TIMEOUT=SECONDS     the longest wait for one check's jobs (default 600)
#   SLURM_TEST_INTERRUPT_AFTER=S   how long check 4 lets its tasks run before interrupting (2)
#   SLURM_TEST_FORCE=1             run even though another /etc/slurm/slurm.conf is there (it is
#                                  set aside and put back; a running slurmctld is never touched)
#   SLURM_TEST_REMOVE_PACKAGES=1   purge slurm-wlm and munge at the end if this run installed them
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."
root=$(pwd)
scene=$root/examples/tesseract.4ds
submit=$root/deploy/slurm/submit.sh
marker="# written by hyperslice scripts/slurm-test.sh"
conf=/etc/slurm/slurm.conf

stub=${SLURM_TEST_STUB:-${SLURM_TEST_DRY:-0}}
keep=${SLURM_TEST_KEEP:-0}
time_limit=${SLURM_TEST_TIME_LIMIT:-0}
for arg in "$@"; do
  case $arg in
    --stub | --dry) stub=1 ;;
    --keep) keep=1 ;;
    --time-limit) time_limit=1 ;;
    -h | --help)
      sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'
      exit 0
      ;;
    *)
      echo "usage: $0 [--stub] [--keep] [--time-limit]" >&2
      exit 2
      ;;
  esac
done
[[ $stub == 1 ]] && mode=stub || mode=real
timeout=${SLURM_TEST_TIMEOUT:-600}

log() { echo "slurm-test: $*" >&2; }
reported=0
die() {
  echo "slurm-test: error: $*" >&2
  echo "FAIL: scripts/slurm-test.sh ($mode): $*"
  reported=1
  exit 1
}

t0=$(date +%s)
[[ $(id -u) -eq 0 ]] || die "run as root: it installs packages, writes $conf and starts daemons"
[[ -f $scene ]] || die "no $scene"
command -v apt-get >/dev/null || command -v sbatch >/dev/null ||
  die "sbatch is missing and there is no apt-get to install slurm-wlm with"

work=$(mktemp -d "${TMPDIR:-/tmp}/slurm-test.XXXXXX")
chmod 755 "$work"
mkdir -p "$work/log"

# What this run changed, for cleanup.
installed=0
conf_backup=
conf_written=0
made_dirs=()
started_munged=0
started_slurm=0
munge_key_made=0
job_ids=()
failed=0

stop_pidfile() {
  # $1: a pid file; TERM the daemon in it, wait for it to go, KILL it if it does not.
  local pid i
  [[ -f $1 ]] || return 0
  pid=$(cat "$1" 2>/dev/null || true)
  [[ $pid =~ ^[0-9]+$ ]] || return 0
  kill -TERM "$pid" 2>/dev/null || return 0
  for ((i = 0; i < 50; i++)); do
    kill -0 "$pid" 2>/dev/null || return 0
    sleep 0.2
  done
  kill -KILL "$pid" 2>/dev/null || true
}

cleanup() {
  local rc=$? id i
  set +e
  trap - INT TERM
  if ((rc != 0 && !reported)); then
    echo "FAIL: scripts/slurm-test.sh ($mode): stopped with status $rc"
  fi
  if ((${#job_ids[@]} > 0)) && [[ -f /run/slurmctld.pid ]]; then
    for id in "${job_ids[@]}"; do scancel "$id" 2>/dev/null; done
    for ((i = 0; i < 30; i++)); do
      [[ -z $(squeue -h 2>/dev/null) ]] && break
      sleep 1
    done
  fi
  if ((rc != 0 || failed)); then
    for f in "$work"/log/slurmctld.log "$work"/log/slurmd.log; do
      [[ -f $f ]] && {
        echo "---- last lines of $f" >&2
        tail -n 15 "$f" >&2
      }
    done
  fi
  if ((started_slurm)); then
    stop_pidfile /run/slurmd.pid
    stop_pidfile /run/slurmctld.pid
    rm -f /run/slurmd.pid /run/slurmctld.pid
  fi
  ((started_munged)) && stop_pidfile /run/munge/munged.pid
  if ((conf_written)); then
    if [[ -n $conf_backup ]]; then cp -p "$conf_backup" "$conf"; else rm -f "$conf"; fi
  fi
  for ((i = ${#made_dirs[@]} - 1; i >= 0; i--)); do rm -rf "${made_dirs[i]}"; done
  ((munge_key_made)) && rm -f /etc/munge/munge.key
  if ((installed)) && [[ ${SLURM_TEST_REMOVE_PACKAGES:-0} == 1 ]]; then
    log "removing slurm-wlm and munge again"
    DEBIAN_FRONTEND=noninteractive apt-get purge -y -qq slurm-wlm slurmctld slurmd slurm-client munge >/dev/null
  fi
  if [[ $keep == 1 ]] || { ((rc != 0 || failed)) && [[ -n $(find "$work" -type f -print -quit) ]]; }; then
    log "kept the work directory $work"
  else
    rm -rf "$work"
  fi
  log "took $(($(date +%s) - t0)) s in all"
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

mkdir_tracked() {
  local d
  for d in "$@"; do
    if [[ ! -e $d ]]; then
      mkdir -p "$d"
      made_dirs+=("$d")
    fi
  done
}

# (d) The renderer, or its stand-in: first, so that a binary without --shard fails early.
if [[ $mode == stub ]]; then
  bin=$root/scripts/slurm-test-stub.sh
elif [[ -n ${HYPERSLICE:-} ]]; then
  bin=$(realpath -- "$HYPERSLICE")
else
  bin=$root/target/release/hyperslice
  [[ -x $HOME/.cargo/bin/cargo ]] && PATH=$HOME/.cargo/bin:$PATH
  if command -v cargo >/dev/null; then
    log "cargo build --release"
    cargo build --release --quiet
  elif [[ -x $bin ]]; then
    log "no cargo here: testing the $bin already built"
  else
    die "no cargo to build target/release/hyperslice with; build it first or set HYPERSLICE"
  fi
fi
[[ -x $bin ]] || die "$bin is not executable"
help=$("$bin" render --help 2>&1 || true)
if [[ $help != *--shard* ]] || ! "$bin" merge --help >/dev/null 2>&1; then
  die "$bin has no \`render --shard\` or \`merge\` yet; \`bash scripts/slurm-test.sh --stub\` tests the Slurm side alone"
fi
unset HYPERSLICE

# (a) Slurm and munge.
if ! command -v sbatch >/dev/null || ! command -v slurmctld >/dev/null ||
  ! command -v slurmd >/dev/null || ! command -v munged >/dev/null; then
  log "installing slurm-wlm and munge with apt-get"
  t_install=$(date +%s)
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq >/dev/null
  apt-get install -y -qq --no-install-recommends slurm-wlm munge >/dev/null
  installed=1
  log "installed in $(($(date +%s) - t_install)) s"
fi
slurm_version=$(slurmctld -V 2>/dev/null | awk '{print $NF}' || true)

# Nothing of an existing Slurm installation is touched.
for d in slurmctld slurmd; do
  if [[ -f /run/$d.pid ]] && kill -0 "$(cat "/run/$d.pid")" 2>/dev/null; then
    die "$d is already running here (/run/$d.pid); stop it first, this test runs its own"
  fi
done
if [[ -f $conf ]] && ! head -n 1 "$conf" | grep -qF "$marker"; then
  [[ ${SLURM_TEST_FORCE:-0} == 1 ]] ||
    die "$conf exists and was not written by this test; set SLURM_TEST_FORCE=1 to set it aside while the test runs"
  conf_backup=$work/slurm.conf.orig
  cp -p "$conf" "$conf_backup"
  log "set $conf aside as $conf_backup; it is put back at the end"
fi

# (b) A one-node cluster on this host.
host=$(hostname -s)
cpus=$(nproc)
mem=$(free -m | awk '/^Mem:/ {print int($2 * 0.9)}')
mkdir_tracked /etc/slurm /var/spool/slurmctld /var/spool/slurmd
conf_written=1
cat >"$conf" <<EOF
$marker (removed again when it ends)
ClusterName=local
SlurmctldHost=$host
AuthType=auth/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
SlurmctldPidFile=/run/slurmctld.pid
SlurmdPidFile=/run/slurmd.pid
SlurmdSpoolDir=/var/spool/slurmd
StateSaveLocation=/var/spool/slurmctld
SlurmctldLogFile=$work/log/slurmctld.log
SlurmdLogFile=$work/log/slurmd.log
SlurmUser=root
ReturnToService=2
MinJobAge=3600
# A requeued job waits cred_expire seconds (default 120) before it may start again.
AuthInfo=cred_expire=10
NodeName=$host CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF

# (c) The daemons.
if [[ -f /run/munge/munged.pid ]] && kill -0 "$(cat /run/munge/munged.pid)" 2>/dev/null; then
  log "munged is already running; using it"
else
  mkdir_tracked /run/munge
  chown munge:munge /run/munge
  if [[ ! -f /etc/munge/munge.key ]]; then
    mungekey --create --keyfile=/etc/munge/munge.key
    chown munge:munge /etc/munge/munge.key
    chmod 400 /etc/munge/munge.key
    munge_key_made=1
  fi
  su -s /bin/sh munge -c munged
  started_munged=1
fi
munge -n | unmunge >/dev/null || die "munge does not work"
started_slurm=1
slurmctld -c
slurmd
log "slurm $slurm_version: slurmctld and slurmd started on $host ($cpus CPUs, ${mem} MB)"
state=
for ((i = 0; i < 60; i++)); do
  state=$(sinfo -h -n "$host" -o %T 2>/dev/null || true)
  [[ $state == idle ]] && break
  sleep 1
done
[[ $state == idle ]] || die "node $host is '${state:-not there}' instead of idle after 60 s: $(sinfo -R 2>&1)"
log "node $host is idle"
t_ready=$(date +%s)


# Checks and job bookkeeping.
results=()
pass() {
  results+=("ok   - $*")
  echo "ok   - $*"
}
fail() {
  failed=1
  results+=("FAIL - $*")
  echo "FAIL - $*"
}

field() { # field LINE NAME: the value of NAME= in one line of `scontrol -o show job`
  local v
  v=$(grep -o "\(^\| \)$2=[^ ]*" <<<"$1" | head -n 1) || true
  echo "${v#*=}"
}
job_lines() { scontrol -o show job "$1" 2>/dev/null || true; }
terminal() { # terminal LINE: has this job (or array task) ended for good?
  local s
  s=$(field "$1" JobState)
  case $s in
    COMPLETED | FAILED | CANCELLED | TIMEOUT | NODE_FAIL | PREEMPTED | OUT_OF_MEMORY | BOOT_FAIL | DEADLINE) return 0 ;;
    PENDING) [[ $(field "$1" Reason) == DependencyNeverSatisfied ]] ;;
    *) return 1 ;;
  esac
}
wait_jobs() { # wait_jobs ID...: until every job and array task has ended; 1 on timeout
  local start id line all
  start=$(date +%s)
  while :; do
    all=1
    for id in "$@"; do
      while IFS= read -r line; do
        [[ -z $line ]] || terminal "$line" || all=0
      done <<<"$(job_lines "$id")"
    done
    ((all)) && return 0
    (($(date +%s) - start < timeout)) || return 1
    sleep 1
  done
}
states() { # states ID: "task=STATE(exit,restarts) ..." of a job or array
  local line out=() t
  while IFS= read -r line; do
    [[ -n $line ]] || continue
    t=$(field "$line" ArrayTaskId)
    out+=("${t:-job}=$(field "$line" JobState)($(field "$line" ExitCode),restarts $(field "$line" Restarts))")
  done <<<"$(job_lines "$1")"
  echo "${out[*]}"
}
task_state() { field "$(job_lines "${1}_$2")" JobState; }

# submit_case DIR N ARGS...: deploy/slurm/submit.sh into DIR/out.gif; sets array and merge.
submit_case() {
  local dir=$1 n=$2 ids
  shift 2
  mkdir -p "$dir"
  ids=$(cd "$work" && "$submit" "$scene" "$dir/out.gif" "$n" "$@" 2>>"$work/log/submit.log") ||
    die "submit.sh failed: $(tail -n 3 "$work/log/submit.log")"
  array=$(sed -n 's/^array_job=//p' <<<"$ids")
  merge=$(sed -n 's/^merge_job=//p' <<<"$ids")
  [[ $array =~ ^[0-9]+$ && $merge =~ ^[0-9]+$ ]] || die "submit.sh printed no job ids: $ids"
  job_ids+=("$array" "$merge")
  log "submitted array $array ($n tasks) and merge $merge: $*"
}
# single DIR ARGS...: the single-machine render of the same scene and flags, DIR/single.gif.
single() {
  local dir=$1
  shift
  "$bin" render "$scene" -o "$dir/single.gif" "$@" 2>>"$dir/single.log"
}
# compare NAME DIR [loose]: the merged output against the single-machine one. Frame shards
# must give the same bytes; with `loose` (sample shards, whose sums may round differently) a
# difference is reported but does not fail.
compare() {
  local name=$1 dir=$2 loose=${3:-} jobs
  jobs="array $array [$(states "$array")], merge $merge [$(states "$merge")]"
  if [[ ! -f $dir/out.gif ]]; then
    fail "$name: $jobs: the merge wrote no output"
  elif [[ $(field "$(job_lines "$merge")" JobState) != COMPLETED ]]; then
    fail "$name: $jobs: the merge did not complete"
  elif cmp -s "$dir/out.gif" "$dir/single.gif"; then
    pass "$name: $jobs: merged output equals the single-machine render ($(wc -c <"$dir/out.gif") bytes, cmp)"
  elif [[ -n $loose ]]; then
    pass "$name: $jobs: merged ($(wc -c <"$dir/out.gif") bytes), NOT byte-identical to the single-machine render ($(cmp "$dir/out.gif" "$dir/single.gif" 2>&1 | sed 's/.*: //')); only frame shards promise that"
  else
    fail "$name: $jobs: merged $dir/out.gif differs from the single-machine $dir/single.gif: $(cmp "$dir/out.gif" "$dir/single.gif" 2>&1)"
  fi
}
# run_case NAME N LOOSE ARGS...: submit, wait, render on one machine, compare.
run_case() {
  local name=$1 n=$2 loose=$3 dir
  shift 3
  dir=$work/$(tr ' /' '__' <<<"$name")
  submit_case "$dir" "$n" "$@"
  wait_jobs "$array" "$merge" || fail "$name: jobs $array and $merge still not done after $timeout s"
  single "$dir" "$@" || fail "$name: the single-machine render failed: $(tail -n 3 "$dir/single.log")"
  compare "$name" "$dir" "$loose"
}

cd "$work"
export HYPERSLICE=$bin

# 1 and 2.
run_case "frame shards" 3 "" --size 48x36 --frames 3 --spp 2 --seed 1 --denoise none
run_case "sample shards" 2 loose --size 48x36 --frames 1 --spp 4 --seed 2 --denoise none

# 3. Shard 1 fails: the merge must not run; submitting again resumes and completes.
name="failed task stops merge"
dir=$work/failed_task
mkdir -p "$dir"
failing=$work/failing-hyperslice
{
  echo '#!/usr/bin/env bash'
  echo 'case " $* " in *" --shard 1/"*) echo "slurm-test: shard 1 fails on purpose" >&2; exit 3 ;; esac'
  printf 'exec %q "$@"\n' "$bin"
} >"$failing"
chmod +x "$failing"
args=(--size 48x36 --frames 3 --spp 2 --seed 3 --denoise none)
HYPERSLICE=$failing
submit_case "$dir" 3 "${args[@]}"
HYPERSLICE=$bin
if ! wait_jobs "$array" "$merge"; then
  fail "$name: jobs $array and $merge still not done after $timeout s"
else
  mstate=$(field "$(job_lines "$merge")" JobState)
  mreason=$(field "$(job_lines "$merge")" Reason)
  if [[ $(task_state "$array" 1) == FAILED && $mstate != COMPLETED && $mstate != RUNNING &&
    $mreason == DependencyNeverSatisfied && ! -e $dir/out.gif ]]; then
    pass "$name: array $array [$(states "$array")] -> merge $merge $mstate ($mreason), no output written"
  else
    fail "$name: array $array [$(states "$array")], merge $merge [$(states "$merge")] reason $mreason, output $([[ -e $dir/out.gif ]] && echo written || echo absent)"
  fi
fi
first_array=$array
submit_case "$dir" 3 "${args[@]}"
wait_jobs "$array" "$merge" || fail "$name: the resubmitted jobs $array and $merge are not done after $timeout s"
single "$dir" "${args[@]}" || fail "$name: the single-machine render failed"
compare "resubmitted after the failure of $first_array" "$dir"
if [[ $mode == stub ]]; then
  if grep -q 'already complete' "$dir/out.logs/render-${array}_0.out" &&
    grep -q 'already complete' "$dir/out.logs/render-${array}_2.out"; then
    pass "$name: the resubmission kept shards 0 and 2 of $first_array (already complete) and rendered shard 1"
  else
    fail "$name: the resubmission did not find shards 0 and 2 of $first_array complete"
  fi
fi

# 4. Interrupt two running tasks: time-limit warning (USR1) and preemption (requeue).
name="interrupted tasks resume"
dir=$work/interrupted
# Each task takes some seconds: 4 frames of 96x72 at 128 spp on one thread; the stub waits 1 s
# a frame.
[[ $mode == stub ]] && export STUB_SECONDS_PER_UNIT=1
args=(--size 96x72 --frames 8 --spp 128 --seed 4 --denoise none)
submit_case "$dir" 2 "${args[@]}"
# Once both tasks' batch scripts have started the renderer, give it a moment to get going.
for k in 0 1; do
  for ((i = 0; i < 240; i++)); do
    grep -q '^hyperslice-render: job .* restart 0:' "$dir/out.logs/render-${array}_$k.out" 2>/dev/null && break
    sleep 0.25
  done
done
sleep "${SLURM_TEST_INTERRUPT_AFTER:-2}"
interrupted=()
for k in 0 1; do
  if [[ $(task_state "$array" "$k") != RUNNING ]]; then
    fail "$name: task ${array}_$k is $(task_state "$array" "$k"), not running, when it was to be interrupted (SLURM_TEST_INTERRUPT_AFTER=${SLURM_TEST_INTERRUPT_AFTER:-2} s is too long?)"
  elif ((k == 0)); then
    log "task ${array}_0: the time-limit warning (scancel --batch --signal=USR1)"
    scancel --batch --signal=USR1 "${array}_0"
    interrupted+=(0)
  else
    log "task ${array}_1: requeued as on preemption (scontrol requeue)"
    scontrol requeue "${array}_1"
    interrupted+=(1)
  fi
done
wait_jobs "$array" "$merge" || fail "$name: jobs $array and $merge still not done after $timeout s"
unset STUB_SECONDS_PER_UNIT
for k in "${interrupted[@]}"; do
  restarts=$(field "$(job_lines "${array}_$k")" Restarts)
  tlog=$dir/out.logs/render-${array}_$k.out
  what=$([[ $k == 0 ]] && echo "time-limit warning" || echo "preemption requeue")
  if [[ ${restarts:-0} -ge 1 ]] && { [[ $mode != stub ]] || grep -q 'resuming at unit [1-9]' "$tlog"; }; then
    pass "$name: task ${array}_$k after a $what: restarted $restarts time(s) and finished$([[ $mode == stub ]] && echo ", resuming at unit $(grep -o 'resuming at unit [0-9]*' "$tlog" | grep -o '[0-9]*$' | head -n 1)")"
  else
    fail "$name: task ${array}_$k after a $what: restarts ${restarts:-?}; log $tlog: $(tail -n 4 "$tlog" 2>/dev/null | tr '\n' '|')"
  fi
done
single "$dir" "${args[@]}" || fail "$name: the single-machine render failed"
compare "$name" "$dir"

# 5. (--time-limit) A shard longer than its time limit: it stops before the limit, requeues
# itself and resumes, as often as needed, without a signal from outside.
if [[ $time_limit == 1 ]]; then
  name="time limit"
  dir=$work/time_limit
  # About 80 s of work for one task with a 1-minute limit (the least Slurm has), stopping 30 s
  # before the end (so it takes about three runs, several minutes with the requeue delays).
  if [[ $mode == stub ]]; then
    export STUB_SECONDS_PER_UNIT=4
    args=(--frames 20 --seed 5)
  else
    args=(--size 96x72 --frames 2 --spp 2048 --seed 5 --denoise none)
  fi
  HYPERSLICE_TIME=1 HYPERSLICE_SIGNAL_LEAD=30 submit_case "$dir" 1 "${args[@]}"
  unset STUB_SECONDS_PER_UNIT
  timeout=$((timeout > 900 ? timeout : 900))
  wait_jobs "$array" "$merge" || fail "$name: jobs $array and $merge still not done after $timeout s"
  restarts=$(field "$(job_lines "${array}_0")" Restarts)
  tlog=$dir/out.logs/render-${array}_0.out
  if [[ ${restarts:-0} -ge 1 && $(task_state "$array" 0) == COMPLETED ]]; then
    pass "$name: task ${array}_0 with --time=1 stopped and requeued itself $restarts time(s) ($(grep -c 'requeueing' "$tlog") before the limit) and finished"
  else
    fail "$name: task ${array}_0 [$(states "$array")]; log $tlog: $(tail -n 4 "$tlog" 2>/dev/null | tr '\n' '|')"
  fi
  single "$dir" "${args[@]}" || fail "$name: the single-machine render failed"
  compare "$name" "$dir"
fi

t_end=$(date +%s)
summary="${#results[@]} checks on Slurm $slurm_version, $mode renderer; cluster up in $((t_ready - t0)) s, checks took $((t_end - t_ready)) s"
reported=1
if ((failed)); then
  echo "FAIL: scripts/slurm-test.sh ($mode): $summary"
  exit 1
fi
echo "PASS: scripts/slurm-test.sh ($mode): $summary"
