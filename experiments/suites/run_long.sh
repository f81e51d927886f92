#!/usr/bin/env bash
# The project's long suites one after another, each resuming where it stopped (a finished one returns at once):
# the study (issue 14, docs/results.md), transfer (issue 17, docs/transfer.md), the zoo (issue 19, docs/zoo.md): in issue order.
# Each appends its progress to results/<name>.log. Usage: experiments/suites/run_long.sh [JOBS] (default 2).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
jobs="${1:-2}"
[[ -x build/bin/maps ]] || { echo "run_long.sh: build/bin/maps is missing (cmake --build build)" >&2; exit 2; }
for name in study transfer zoo; do
  echo "run_long.sh: $name ($(date -u +%FT%TZ))" >> "results/$name.log"
  # A suite that ends with failed cells exits non-zero; the next one runs anyway (status and the report name them).
  build/bin/maps suite run "experiments/suites/$name.json" --out "results/$name" --jobs "$jobs" >> "results/$name.log" 2>&1 ||
    echo "run_long.sh: $name exited $? ($(date -u +%FT%TZ))" >> "results/$name.log"
done
