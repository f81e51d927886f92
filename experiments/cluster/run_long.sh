#!/usr/bin/env bash
# The project's long suites: the study (issue 14, docs/results.md), transfer (issue 17, docs/transfer.md), the zoo
# (issue 19, docs/zoo.md), each resuming where it stopped (a finished one returns at once).
# Usage: experiments/cluster/run_long.sh [JOBS] (default 2): JOBS runners of one job each, side by side. Runner 1
# takes the zoo first, every other runner the study first; then all take the zoo, then transfer. Two runners on one
# suite share it (a cell another process holds is skipped, a transfer cell waits for its source). The zoo (about 8
# CPU-hours left on 2026-11-27, against transfer's 49) goes before transfer because it is the shorter: both cores on
# it close its issue sooner, and transfer ends about as late (the same CPU-hours on the same two cores; a
# transfer cell waiting for its source can leave a core idle meanwhile). Each runner
# appends its progress to results/<name>.log.
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
    runner "$i" study zoo transfer &
  fi
  sleep 2  # the runners take their first cells one after the other
done
wait
