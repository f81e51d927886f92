#!/usr/bin/env bash
# Submits a comparison suite to Slurm as three jobs:
#   1. prepare  maps suite prepare CONFIG                     (collects missing demonstration files once)
#   2. array    N tasks, task i: maps suite run CONFIG --out OUT/shard-i --shard i/N --jobs 1 --threads T
#               (--dependency=afterok on prepare)
#   3. merge    maps suite merge --out OUT/merged OUT/shard-*; maps report OUT/merged; maps suite status
#               (--dependency=afterany on the array: it also runs when some shards failed)
#
# usage: experiments/cluster/slurm/submit_suite.sh CONFIG OUT [options]
#   --shards N            array tasks (shards), default 8; keep the same N when resubmitting
#   --cpus-per-task T     CPUs per array task, passed to maps as --threads T (default 1); the numbers
#                         depend on T, so keep it when resubmitting
#   --time HH:MM:SS       time limit of each array task (default: suite_array.sbatch's 12:00:00)
#   --mem M               memory of each array task (default: suite_array.sbatch's 4G)
#   --partition P         partition for all three jobs (default: the cluster's default)
#   --account A           account for all three jobs
#   --max-running K       at most K array tasks at once (--array=0-(N-1)%K)
#   --array-tasks LIST    submit only these shards, e.g. 3,17 or 8-15 (default 0-(N-1)); they still split
#                         the suite into N shards
#   --prepare-time T      time limit of the prepare job (default 02:00:00)
#   --merge-time T        time limit of the merge job (default 01:00:00)
#   --sbatch-arg ARG      one more sbatch option for all three jobs (repeatable), e.g. --sbatch-arg=--qos=long
#   --wait                wait until the three jobs have ended, print every task's state and exit code,
#                         exit 0 only if all COMPLETED with exit code 0
#   --poll S              seconds between checks with --wait (default 10)
#
# Paths: CONFIG and OUT may be relative to the current directory (they are made absolute). The jobs run in
# the repository root (sbatch --chdir), which suite configs' demo paths are relative to. The maps binary:
# $MAPS_BIN, default build/bin/maps of this repository. Logs: OUT/logs/prepare-<job>.out,
# OUT/logs/shard-<i>.out (appended to by every resubmission), OUT/logs/merge-<job>.out; the job ids of each
# submission are appended to OUT/logs/submissions.txt.
#
# Resuming: run the same command again. Finished cells are skipped, unfinished cells resume from their
# checkpoints, the merge adds the new results to OUT/merged.
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
REPO="$(cd "$HERE/../../.." && pwd)"

usage() { awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "${BASH_SOURCE[0]}"; }
die() { echo "submit_suite: ERROR: $*" >&2; exit 1; }

shards=8 array_tasks="" cpus=1 time_limit="" mem="" partition="" account="" max_running=""
prepare_time="02:00:00" merge_time="01:00:00" wait=0 poll=10
extra=()
positional=()
while (($#)); do
  case "$1" in
    --shards) shards="${2:?}"; shift 2 ;;
    --shards=*) shards="${1#*=}"; shift ;;
    --cpus-per-task) cpus="${2:?}"; shift 2 ;;
    --cpus-per-task=*) cpus="${1#*=}"; shift ;;
    --time) time_limit="${2:?}"; shift 2 ;;
    --time=*) time_limit="${1#*=}"; shift ;;
    --mem) mem="${2:?}"; shift 2 ;;
    --mem=*) mem="${1#*=}"; shift ;;
    --partition) partition="${2:?}"; shift 2 ;;
    --partition=*) partition="${1#*=}"; shift ;;
    --account) account="${2:?}"; shift 2 ;;
    --account=*) account="${1#*=}"; shift ;;
    --array-tasks) array_tasks="${2:?}"; shift 2 ;;
    --array-tasks=*) array_tasks="${1#*=}"; shift ;;
    --max-running) max_running="${2:?}"; shift 2 ;;
    --max-running=*) max_running="${1#*=}"; shift ;;
    --prepare-time) prepare_time="${2:?}"; shift 2 ;;
    --prepare-time=*) prepare_time="${1#*=}"; shift ;;
    --merge-time) merge_time="${2:?}"; shift 2 ;;
    --merge-time=*) merge_time="${1#*=}"; shift ;;
    --sbatch-arg) extra+=("${2:?}"); shift 2 ;;
    --sbatch-arg=*) extra+=("${1#*=}"); shift ;;
    --wait) wait=1; shift ;;
    --poll) poll="${2:?}"; shift 2 ;;
    --poll=*) poll="${1#*=}"; shift ;;
    -h | --help) usage; exit 0 ;;
    -*) die "unknown option $1 (see --help)" ;;
    *) positional+=("$1"); shift ;;
  esac
done
((${#positional[@]} == 2)) || { usage >&2; exit 2; }
[[ $shards =~ ^[1-9][0-9]*$ ]] || die "--shards must be a positive integer, got '$shards'"
[[ $cpus =~ ^[1-9][0-9]*$ ]] || die "--cpus-per-task must be a positive integer, got '$cpus'"
[[ -z $max_running || $max_running =~ ^[1-9][0-9]*$ ]] || die "--max-running must be a positive integer"
[[ -z $array_tasks || $array_tasks =~ ^[0-9]+(-[0-9]+)?(,[0-9]+(-[0-9]+)?)*$ ]] ||
  die "--array-tasks must look like 3,17 or 8-15, got '$array_tasks'"
for n in $(tr ',-' '  ' <<< "$array_tasks"); do
  ((n < shards)) || die "--array-tasks: shard $n is not below --shards $shards"
done
command -v sbatch >/dev/null || die "sbatch not found: is this a Slurm login node?"

config="$(realpath -e -- "${positional[0]}" 2>/dev/null)" || die "config not found: ${positional[0]}"
out="$(realpath -m -- "${positional[1]}")"
MAPS_BIN="${MAPS_BIN:-$REPO/build/bin/maps}"
MAPS_BIN="$(realpath -m -- "$MAPS_BIN")"
[[ -x $MAPS_BIN ]] || die "maps binary not found: $MAPS_BIN (build it: bash scripts/test.sh, or set MAPS_BIN)"
"$MAPS_BIN" suite --help >/dev/null 2>&1 || die "$MAPS_BIN has no 'suite' command (rebuild it)"

mkdir -p "$out/logs"
# A suite is split into N shards by cell index % N (a transfer cell by its source's); resubmitting with another N would give shard folders
# whose cells overlap. And a cell's numbers depend on its thread count (--threads = --cpus-per-task): a cell
# resumed with another count matches neither run. Keep the first N and T of an OUT.
keep_same() { # keep_same FILE VALUE OPTION
  if [[ -f $1 ]]; then
    [[ $(cat "$1") == "$2" ]] ||
      die "$out was submitted with $3 $(cat "$1"); resubmit with $3 $(cat "$1") (or use a new OUT)"
  else
    echo "$2" > "$1"
  fi
}
keep_same "$out/logs/shards" "$shards" --shards
keep_same "$out/logs/cpus-per-task" "$cpus" --cpus-per-task

# What the suite holds: cells, estimated CPU time, the largest shard's estimate against the time limit
# (from maps suite plan --json, run from the repository root like the jobs). Informational: a config that
# does not parse fails the prepare job, which cancels the array.
(cd "$REPO" && "$MAPS_BIN" suite plan "$config") > "$out/logs/plan.txt" 2>&1 || true
if (cd "$REPO" && "$MAPS_BIN" suite plan "$config" --json) > "$out/logs/plan.json" 2> "$out/logs/plan.err" &&
  command -v python3 >/dev/null; then
  python3 - "$out/logs/plan.json" "$shards" "${time_limit:-12:00:00}" <<'PY' || true
import json, sys
plan, shards, limit = json.load(open(sys.argv[1])), int(sys.argv[2]), sys.argv[3]
def seconds(t):  # Slurm time limits: MM, MM:SS, HH:MM:SS, D-HH, D-HH:MM, D-HH:MM:SS
    days = 0
    if "-" in t:
        d, t = t.split("-", 1)
        days = int(d)
        parts = [int(x) for x in t.split(":")]
        parts += [0] * (3 - len(parts))
    else:
        parts = [int(x) for x in t.split(":")]
        parts = {1: [0, parts[0], 0], 2: [0] + parts, 3: parts}[len(parts)]
    h, m, s = parts
    return days * 86400 + h * 3600 + m * 60 + s
def hm(s):
    return f"{int(s // 3600)}h{int(s % 3600 // 60):02d}m" if s >= 3600 else f"{int(s // 60)}m{int(s % 60):02d}s"
cells = plan["cells"]
known = [c for c in cells if isinstance(c.get("estimated_seconds"), (int, float))]
per = [0.0] * shards
for c in known:
    per[c.get("shard_key", c["index"]) % shards] += c["estimated_seconds"]
counts = [sum(1 for c in cells if c.get("shard_key", c["index"]) % shards == i) for i in range(shards)]
print(f"== suite: {len(cells)} cells, estimated {plan['cpu_seconds'] / 3600:.1f} CPU-hours at one thread per cell"
      f" (costs: {plan.get('costs')}); {shards} shards of {min(counts)}-{max(counts)} cells,"
      f" estimated {hm(min(per))} to {hm(max(per))} each at one thread")
if len(known) < len(cells):
    print(f"   ({len(cells) - len(known)} cells have no estimate)")
if plan.get("collect_seconds"):
    print(f"   demonstrations to collect first (prepare job): about {hm(plan['collect_seconds'])}")
if max(per) > seconds(limit):
    print(f"== NOTE: the largest shard's estimate ({hm(max(per))}) is over the array's time limit {limit}: shards"
          " that hit it stop there and continue when you resubmit (or use more --shards or a longer --time).")
PY
else
  echo "== WARNING: maps suite plan $config failed (submitting anyway):"
  tail -n 4 "$out/logs/plan.err" | sed 's/^/   /'
fi

common=(--parsable --chdir="$REPO" --export="ALL,MAPS_BIN=$MAPS_BIN")
[[ -n $partition ]] && common+=(--partition="$partition")
[[ -n $account ]] && common+=(--account="$account")
common+=(${extra[@]+"${extra[@]}"}) # (this form: bash < 4.4 calls an empty array unbound)

job_id() { cut -d';' -f1 <<< "$1"; } # --parsable prints "id" or "id;cluster"

prep_out="$(sbatch "${common[@]}" --job-name=maps-prepare --time="$prepare_time" \
  --output="$out/logs/prepare-%j.out" "$HERE/suite_prepare.sbatch" "$config")" || die "sbatch (prepare) failed"
prep="$(job_id "$prep_out")"

array_spec="${array_tasks:-0-$((shards - 1))}"
[[ -n $max_running ]] && array_spec+="%$max_running"
array_opts=(--job-name=maps-suite --array="$array_spec" --cpus-per-task="$cpus" --dependency="afterok:$prep"
  --kill-on-invalid-dep=yes --output="$out/logs/shard-%a.out" --open-mode=append)
[[ -n $time_limit ]] && array_opts+=(--time="$time_limit")
[[ -n $mem ]] && array_opts+=(--mem="$mem")
array_out="$(sbatch "${common[@]}" "${array_opts[@]}" "$HERE/suite_array.sbatch" "$config" "$out" "$shards")" ||
  { scancel "$prep" 2>/dev/null || true; die "sbatch (array) failed; cancelled the prepare job $prep"; }
array="$(job_id "$array_out")"

merge_out="$(sbatch "${common[@]}" --job-name=maps-merge --time="$merge_time" --dependency="afterany:$array" \
  --kill-on-invalid-dep=yes --output="$out/logs/merge-%j.out" "$HERE/suite_merge.sbatch" "$out")" ||
  die "sbatch (merge) failed (prepare $prep and array $array are queued)"
merge="$(job_id "$merge_out")"

echo "$(date -u +%FT%TZ) prepare=$prep array=$array shards=$shards tasks=$array_spec cpus=$cpus merge=$merge" >> "$out/logs/submissions.txt"
cat <<EOF
== submitted
   prepare  $prep   maps suite prepare           log $out/logs/prepare-$prep.out
   array    $array   shards $array_spec of $shards, $cpus CPU(s) each   logs $out/logs/shard-<i>.out
   merge    $merge   merge + report after the array   log $out/logs/merge-$merge.out
== watch
   squeue -j $prep,$array,$merge
   $MAPS_BIN suite status $out/shard-*     (the shards read as one)
   tail -f $out/logs/shard-0.out
== when done
   $MAPS_BIN suite status $out/merged
   report: $out/merged/report/report.md
== resume (after timeouts or preemption): the same command again
EOF

((wait)) || exit 0

# ---------------------------------------------------------------------------------------------------
# --wait: poll squeue until the three jobs have left the queue.
started=$SECONDS
last=""
while :; do
  queue="$(squeue -h -j "$prep,$array,$merge" -o '%i %j %T %r' 2>/dev/null || true)"
  [[ -z $queue ]] && break
  # A dependency that can never be met (the prepare job failed) keeps a job pending forever on clusters
  # that do not cancel such jobs themselves (--kill-on-invalid-dep is not honoured everywhere).
  stuck="$(awk '$4 ~ /DependencyNeverSatisfied/ {print $1}' <<< "$queue" | tr '\n' ' ')"
  if [[ -n ${stuck// /} ]]; then
    echo "== jobs whose dependency can never be satisfied: $stuck-- cancelling them"
    # shellcheck disable=SC2086
    scancel $stuck 2>/dev/null || true
  fi
  summary="$(awk '{print $2 ":" $3}' <<< "$queue" | sort | uniq -c | awk '{printf "%s x%s  ", $2, $1}')"
  if [[ $summary != "$last" ]]; then
    echo "   [$((SECONDS - started)) s] $summary"
    last="$summary"
  fi
  sleep "$poll"
done
echo "== the jobs left the queue after $((SECONDS - started)) s"

# Every job's (and array task's) final state and exit code, from scontrol (finished jobs stay there for the
# cluster's MinJobAge, 300 s by default; poll well within it).
failed=0
report_job() { # report_job LABEL JOBID LOGFILE
  local label=$1 id=$2 log=$3 lines line state code task rows=""
  lines="$(scontrol show job -o "$id" 2>/dev/null || true)"
  if [[ -z $lines ]]; then
    echo "   $label $id: no longer known to scontrol; see $log"
    failed=1
    return
  fi
  while read -r line; do
    state="$(grep -o 'JobState=[A-Z_]*' <<< "$line" | cut -d= -f2 || true)"
    code="$(grep -o ' ExitCode=[0-9:]*' <<< "$line" | cut -d= -f2 || true)"
    task="$(grep -o 'ArrayTaskId=[0-9,%-]*' <<< "$line" | cut -d= -f2 || true)"
    rows+="${task:-0}|$(printf '   %-8s %s%s  %-10s exit %s' "$label" "$id" "${task:+_$task}" "$state" "$code")"$'\n'
    [[ $state == COMPLETED && $code == 0:0 ]] || failed=1
  done <<< "$lines"
  printf '%s' "$rows" | sort -t'|' -n -k1,1 | cut -d'|' -f2-
}
echo "== final states"
report_job prepare "$prep" "$out/logs/prepare-$prep.out"
report_job shard "$array" "$out/logs/shard-<i>.out"
report_job merge "$merge" "$out/logs/merge-$merge.out"
if ((failed)); then
  echo "== FAILED: some job did not complete; see the logs in $out/logs (resubmit the same command to resume)"
  exit 1
fi
echo "== all jobs COMPLETED; results: $out/merged, report: $out/merged/report/report.md"
