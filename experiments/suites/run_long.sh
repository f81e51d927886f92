#!/usr/bin/env bash
# The project's long suites: the study (issue 14, docs/results.md), transfer (issue 17, docs/transfer.md), the zoo
# (issue 19, docs/zoo.md), each resuming where it stopped (a finished one returns at once).
# Usage: experiments/suites/run_long.sh [JOBS] (default 2): JOBS runners of one job each, side by side. Runner 0 takes
# the suites in issue order, runner 1 in reverse order, the others in issue order again. Two runners on one suite
# share it (a cell another process holds is skipped, a transfer cell waits for its source), so the shorter last suite
# (the zoo, about 8 CPU-hours against transfer's 40) finishes first instead of waiting for the longer, and then its
# runner joins the other. Each runner appends its progress to results/<name>.log.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
jobs="${1:-2}"
[[ "$jobs" =~ ^[1-9][0-9]*$ ]] || { echo "run_long.sh: JOBS must be a positive whole number, got '$jobs'" >&2; exit 2; }
[[ -x build/bin/maps ]] || { echo "run_long.sh: build/bin/maps is missing (cmake --build build)" >&2; exit 2; }

runner() {
  local index="$1"
  shift
  for name in "$@"; do
    echo "run_long.sh: runner $index: $name ($(date -u +%FT%TZ))" >> "results/$name.log"
    # A suite that ends with failed cells, or with cells the other runner held, exits non-zero; the next one runs
    # anyway (status and the report name them).
    build/bin/maps suite run "experiments/suites/$name.json" --out "results/$name" --jobs 1 >> "results/$name.log" 2>&1 ||
      echo "run_long.sh: runner $index: $name exited $? ($(date -u +%FT%TZ))" >> "results/$name.log"
  done
}

for ((i = 0; i < jobs; i++)); do
  if ((i == 1)); then
    runner "$i" zoo transfer study &
  else
    runner "$i" study transfer zoo &
  fi
  sleep 2  # the runners take their first cells one after the other
done
wait
