#!/usr/bin/env bash
# End-to-end test of the suite's Slurm scripts against a real (one-node, localhost) Slurm cluster:
#   1. starts the local cluster (local_cluster.sh start: installs slurm + munge if missing, as root);
#   2. submits experiments/suites/tiny.json as 4 shards with submit_suite.sh --wait (prepare job, a 4-task
#      array with afterok on it, merge + report job with afterany on the array); meanwhile preempts one
#      running array task in the middle of a cell (scontrol requeue): it must restart and resume the cell;
#   3. checks every job and array task ended COMPLETED with exit code 0 (scontrol show job; there is no sacct
#      without accounting), every shard log ends with exit 0, and the merge wrote suite.json and the report;
#   4. runs the same suite single-process (maps suite run --jobs 2) and checks that the merged sharded results
#      equal it number for number (experiments/cluster/compare_suites.py);
#   5. prints PASS/FAIL per check and the timings, and stops the daemons (unless --keep).
#
# usage: bash experiments/cluster/slurm/local_test.sh [--keep] [--no-requeue] [--work DIR] [--log FILE]
#                                                      [--config C.json] [--shards N]
#   --keep      leave the cluster running at the end (export SLURM_CONF=$MAPS_SLURM_DIR/etc/slurm.conf)
#   --no-requeue  do not preempt an array task during the run (see step 2)
#   --work DIR  the test's output folder (must not exist or be empty; default: a new /tmp/maps-slurm-test.XXXXXX)
#   --log FILE  also write the output to FILE (default: WORK/local_test.log)
# Needs root and build/bin/maps with the suite command (bash scripts/test.sh builds it). Exit 0 only if
# every check passed.
# shellcheck disable=SC2317  # summary and cleanup run from the EXIT trap
set -uo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
REPO="$(cd "$HERE/../../.." && pwd)"
cd "$REPO" || exit 2

keep=0 requeue=1 work="" log="" config="experiments/suites/tiny.json" shards=4
while (($#)); do
  case "$1" in
    --keep) keep=1; shift ;;
    --no-requeue) requeue=0; shift ;;
    --work) work="${2:?}"; shift 2 ;;
    --log) log="${2:?}"; shift 2 ;;
    --config) config="${2:?}"; shift 2 ;;
    --shards) shards="${2:?}"; shift 2 ;;
    -h | --help) awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "${BASH_SOURCE[0]}"; exit 0 ;;
    *) echo "unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
done

if [[ -z $work ]]; then
  work="$(mktemp -d /tmp/maps-slurm-test.XXXXXX)"
else
  mkdir -p "$work"
  [[ -z $(ls -A "$work") ]] || { echo "--work $work is not empty" >&2; exit 2; }
  work="$(realpath "$work")"
fi
chmod 755 "$work"
log="${log:-$work/local_test.log}"
mkdir -p "$(dirname "$log")"
exec > >(tee -a "$log") 2>&1
tee_pid=$!

export MAPS_BIN="${MAPS_BIN:-$REPO/build/bin/maps}"
CLUSTER="$HERE/local_cluster.sh"
t_total=$SECONDS
results=() # "PASS|FAIL name"
timings=()
failed=0
check() { # check NAME OK(0/1): records a result
  if (($2 == 0)); then results+=("PASS  $1"); else results+=("FAIL  $1"); failed=1; fi
}
banner() { echo; echo "==== $* ($(date -u +%T) UTC, +$((SECONDS - t_total)) s)"; }

summary() {
  echo
  echo "================ local Slurm test: summary ================"
  printf '%s\n' "${results[@]}"
  echo "---- timings"
  printf '%s\n' "${timings[@]}"
  echo "total: $((SECONDS - t_total)) s"
  if ((failed)); then echo "RESULT: FAIL"; else echo "RESULT: PASS"; fi
  echo "log: $log   work: $work"
}
cleanup() {
  local rc=$?
  if ((keep)); then
    echo "--keep: the cluster keeps running; stop it with: bash $CLUSTER stop"
  else
    banner "stopping the local cluster"
    bash "$CLUSTER" stop || true
  fi
  summary
  ((failed)) && rc=1
  exec 1>&- 2>&- # let tee write the log's last lines before the script ends
  wait "$tee_pid" 2>/dev/null
  exit "$rc"
}
trap cleanup EXIT
trap 'failed=1; results+=("FAIL  interrupted"); exit 130' INT TERM

banner "local Slurm test: $config, $shards shards, work $work"
echo "repo $REPO, commit $(git -C "$REPO" rev-parse --short HEAD 2>/dev/null || echo '?'), host $(hostname -s)," \
  "$(nproc) CPUs, $(awk '/^MemTotal:/ {printf "%.1f GiB", $2 / 1048576}' /proc/meminfo)"
echo "maps: $MAPS_BIN"

# -------------------------------------------------------------------------------------------------
if [[ $(id -u) -ne 0 ]]; then check "running as root (the local cluster's daemons run as root)" 1; exit 1; fi
if [[ ! -x $MAPS_BIN ]] || ! "$MAPS_BIN" suite --help >/dev/null 2>&1; then
  check "maps binary with the suite command ($MAPS_BIN; build it with bash scripts/test.sh)" 1
  exit 1
fi
[[ -f $config ]] || { check "suite config $config exists" 1; exit 1; }

banner "1. start the local cluster"
t=$SECONDS
bash "$CLUSTER" start
rc=$?
timings+=("cluster start (incl. any install): $((SECONDS - t)) s")
check "local cluster started, node idle" $rc
((rc == 0)) || exit 1
eval "$(bash "$CLUSTER" env)"
echo "SLURM_CONF=$SLURM_CONF"
sinfo -V

# -------------------------------------------------------------------------------------------------
banner "2. sharded run on Slurm: submit_suite.sh $config $work/sharded --shards $shards --wait"
# submit_suite.sh --wait runs in the background while this script preempts one array task in the middle of
# a cell (scontrol requeue, as a preempting scheduler does): the task must restart, resume the cell from
# its checkpoint and still give the single-process numbers.
t=$SECONDS
bash "$HERE/submit_suite.sh" "$config" "$work/sharded" --shards "$shards" --time 00:20:00 \
  --prepare-time 00:20:00 --merge-time 00:10:00 --wait --poll 3 &
submit_pid=$!

requeued_task="" requeued_cell=""
if ((requeue)); then
  array=""
  deadline=$((SECONDS + 60))
  while [[ -z $array ]] && ((SECONDS < deadline)) && kill -0 "$submit_pid" 2>/dev/null; do
    array="$(grep -o 'array=[0-9]*' "$work/sharded/logs/submissions.txt" 2>/dev/null | cut -d= -f2 || true)"
    sleep 0.2
  done
  # The first cell in the middle of its training: a checkpoint (last.ckpt) written, its train.log's last
  # "step N/M" line with N < M, in a shard that is running.
  deadline=$((SECONDS + 240))
  while [[ -n $array && -z $requeued_task ]] && ((SECONDS < deadline)) && kill -0 "$submit_pid" 2>/dev/null; do
    for ckpt in "$work"/sharded/shard-*/cells/*/*/last.ckpt; do
      [[ -f $ckpt ]] || continue
      cell_dir="$(dirname "$ckpt")"
      [[ -f $cell_dir/result.json ]] && continue
      progress="$(grep -o '^step [0-9]*/[0-9]*' "$cell_dir/train.log" 2>/dev/null | tail -n 1 | cut -d' ' -f2)"
      [[ -n $progress && ${progress%/*} -lt ${progress#*/} ]] || continue
      shard_dir="${cell_dir%/cells/*}"
      task="${shard_dir##*/shard-}"
      [[ $(squeue -h -j "${array}_$task" -o '%T' 2>/dev/null) == RUNNING ]] || continue
      echo ">>> preempting array task ${array}_$task (scontrol requeue) while cell ${cell_dir#"$shard_dir"/cells/}" \
        "is at training step $progress (checkpointed)"
      if scontrol requeue "${array}_$task"; then
        requeued_task=$task
        requeued_cell="$cell_dir"
      fi
      break
    done
    sleep 0.2
  done
  if [[ -n $requeued_task ]]; then
    # Slurm holds a requeued job for 120 s (BeginTime); let it start again now.
    deadline=$((SECONDS + 30))
    until [[ $(squeue -h -j "${array}_$requeued_task" -o '%T' 2>/dev/null) == PENDING ]] || ((SECONDS >= deadline)); do
      sleep 0.3
    done
    scontrol update JobId="${array}_$requeued_task" StartTime=now &&
      echo ">>> array task ${array}_$requeued_task requeued; StartTime set to now"
  fi
fi
wait "$submit_pid"
rc=$?
t_sharded=$((SECONDS - t))
timings+=("sharded run on Slurm (submit to merge + report done): $t_sharded s")
check "submit_suite.sh --wait: every job COMPLETED with exit 0 (its own check)" $rc
if ((requeue)); then
  if [[ -z $requeued_task ]]; then
    check "preempted (requeued) one array task in the middle of a cell's training" 1
  else
    restarts="$(scontrol show job -o "${array}_$requeued_task" 2>/dev/null | grep -o 'Restarts=[0-9]*' | cut -d= -f2)"
    check "requeued array task ${array}_$requeued_task restarted (Restarts=${restarts:-?})" \
      "$([[ ${restarts:-0} -ge 1 ]] && echo 0 || echo 1)"
    resumed="$(grep -m1 '^resumed from' "$requeued_cell/train.log" 2>/dev/null || true)"
    echo "${requeued_cell#"$work"/}/train.log: ${resumed:-no 'resumed from' line}"
    check "the preempted cell resumed from its checkpoint (train.log: 'resumed from ... at step N')" \
      "$([[ -n $resumed ]] && echo 0 || echo 1)"
  fi
fi

# -------------------------------------------------------------------------------------------------
banner "3. check the jobs (scontrol show job), the shard logs and the merged folder"
ids="$(tail -n 1 "$work/sharded/logs/submissions.txt" 2>/dev/null || true)"
echo "submission: $ids"
prep="$(grep -o 'prepare=[0-9]*' <<< "$ids" | cut -d= -f2)"
array="$(grep -o 'array=[0-9]*' <<< "$ids" | cut -d= -f2)"
merge="$(grep -o 'merge=[0-9]*' <<< "$ids" | cut -d= -f2)"
if [[ -z $prep || -z $array || -z $merge ]]; then
  check "job ids recorded in $work/sharded/logs/submissions.txt" 1
else
  # Array tasks: one line each from scontrol show job -o ARRAY_ID.
  lines="$(scontrol show job -o "$array" 2>&1)"
  field() { grep -o "$1=[^ ]*" <<< "$2" | head -n1 | cut -d= -f2; }
  spans=()
  while read -r l; do
    [[ $l == *ArrayTaskId=* ]] || continue
    printf '   task %-3s job %-5s %-10s exit %-5s start %s end %s\n' "$(field ArrayTaskId "$l")" \
      "$(field JobId "$l")" "$(field JobState "$l")" "$(field ' ExitCode' "$l")" "$(field StartTime "$l")" \
      "$(field EndTime "$l")"
    spans+=("$(date -d "$(field StartTime "$l")" +%s 2>/dev/null || echo 0) $(date -d "$(field EndTime "$l")" +%s 2>/dev/null || echo 0)")
  done < <(sort -t= -k4,4n <<< "$lines")
  n_tasks="$(grep -c 'ArrayTaskId=' <<< "$lines" || true)"
  n_ok="$(grep 'ArrayTaskId=' <<< "$lines" | grep 'JobState=COMPLETED' | grep -c ' ExitCode=0:0' || true)"
  check "array $array: $n_ok of $n_tasks tasks COMPLETED with exit code 0:0 (want $shards of $shards)" \
    "$([[ $n_tasks == "$shards" && $n_ok == "$shards" ]] && echo 0 || echo 1)"
  # How many array tasks ran at the same time (from their start and end times).
  peak=0
  for a in "${spans[@]}"; do
    read -r s _ <<< "$a"
    n=0
    for b in "${spans[@]}"; do
      read -r s2 e2 <<< "$b"
      ((s2 <= s && s < e2)) && n=$((n + 1))
    done
    ((n > peak)) && peak=$n
  done
  echo "array tasks running at the same time (from StartTime/EndTime): at most $peak (the node has $(nproc) CPUs)"
  for id in "$prep" "$merge"; do
    line="$(scontrol show job -o "$id" 2>&1)"
    name="$(grep -o 'JobName=[^ ]*' <<< "$line" | cut -d= -f2)"
    state="$(grep -o 'JobState=[A-Z]*' <<< "$line" | cut -d= -f2)"
    code="$(grep -o ' ExitCode=[0-9:]*' <<< "$line" | cut -d= -f2)"
    check "job $id ($name): $state, exit code $code" "$([[ $state == COMPLETED && $code == 0:0 ]] && echo 0 || echo 1)"
  done
fi
ok=0
for ((i = 0; i < shards; i++)); do
  f="$work/sharded/logs/shard-$i.out"
  if ! grep -q "^== maps suite shard $i/$shards: exit 0 " "$f" 2>/dev/null; then
    echo "shard $i's log $f does not end with exit 0; its last lines:"
    tail -n 15 "$f" 2>/dev/null
    ok=1
  fi
done
check "all $shards shard logs (logs/shard-<i>.out) end with 'exit 0'" $ok
check "merged folder has suite.json and cells/" \
  "$([[ -f $work/sharded/merged/suite.json && -d $work/sharded/merged/cells ]] && echo 0 || echo 1)"
report_files="$(ls "$work/sharded/merged/report" 2>/dev/null | tr '\n' ' ')"
check "the merge job wrote the report (merged/report: ${report_files:-nothing})" \
  "$([[ -f $work/sharded/merged/report/report.md && -f $work/sharded/merged/report/results.csv ]] && echo 0 || echo 1)"
echo "---- maps suite status $work/sharded/merged"
"$MAPS_BIN" suite status "$work/sharded/merged" || true

# -------------------------------------------------------------------------------------------------
banner "4. the same suite single-process: maps suite run $config --out $work/single --jobs 2"
t=$SECONDS
"$MAPS_BIN" suite run "$config" --out "$work/single" --jobs 2
rc=$?
t_single=$((SECONDS - t))
timings+=("single-process run (--jobs 2, demos already collected): $t_single s")
check "single-process maps suite run: exit $rc" $rc

banner "5. compare: merged sharded results vs single-process results"
/usr/bin/python3 "$REPO/experiments/cluster/compare_suites.py" "$work/sharded/merged" "$work/single"
rc=$?
check "merged sharded run == single-process run (compare_suites.py, exact)" $rc
exit 0
