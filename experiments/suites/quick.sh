#!/usr/bin/env bash
# The quick comparison suite: MAPS and the four baselines on the Gravity set at a small budget, then the results
# table (experiments/suites/aggregate.py) and plots (experiments/suites/plot.py). About 3.5 minutes on 2 cores
# (measured: the grid 188 s, the whole script 198 s with the tool built).
# A rerun reuses finished cells; delete the output folder to start over.
#
#   experiments/suites/quick.sh [OUT] [STEPS] [SEEDS] [EPISODES]      (defaults: runs/quick 2000 "0 1" 20)
#
# The numbers are a smoke test of the whole pipeline, not the study: docs/results-gravity.md has the full runs.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
out=${1:-runs/quick} steps=${2:-2000} seeds=${3:-"0 1"} episodes=${4:-20}
maps=${MAPS_BIN:-build/bin/maps}
[[ -x "$maps" ]] || { echo "quick: no maps tool at $maps (build it: cmake --build build --target maps)" >&2; exit 2; }
data=data/gravity.h5
if [[ ! -f "$data" ]]; then
  echo "quick: collecting $data from the committed experts (35 demos per task, about 15 s)"
  "$maps" collect --set gravity --demos 35 --out "$data"
fi
echo "quick: 5 methods x 2 demo counts (5, 10; k = 10) x seeds {$seeds}, $steps steps, $episodes episodes per task -> $out"
start=$SECONDS
experiments/suites/run_grid.sh "$out" "$data" "maps single_bc mt_bc mt_mh_bc maml" "5 10" "$seeds" 10 "$steps" "$episodes"
echo "quick: grid done in $((SECONDS - start)) s"
echo
/usr/bin/python3 experiments/suites/aggregate.py "$out" | tee "$out/results.md"
echo
/usr/bin/python3 experiments/suites/plot.py "$out"
echo "quick: table in $out/results.md"
