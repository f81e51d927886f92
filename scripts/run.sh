#!/usr/bin/env bash
# Installs what is missing, builds the `maps` tool, and runs the main job: the quick comparison suite
# (experiments/suites/quick.json: MAPS and the four baselines on Gravity, Modified and MT10 at a small budget),
# then the report (results table on stdout; runs/quick/report/: report.md, results.csv, the paper's figures).
# A rerun skips finished cells and resumes unfinished ones; delete the output folder to start over.
#
#   bash scripts/run.sh [CONFIG] [OUT]        (defaults: experiments/suites/quick.json runs/quick)
#   bash scripts/run.sh experiments/suites/medium.json runs/medium     (about 2 hours on 2 cores)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
config=${1:-experiments/suites/quick.json} out=${2:-runs/quick}

bash scripts/setup.sh
cmake -S . -B build
cmake --build build -j"$(nproc)" --target maps
start=$SECONDS
build/bin/maps suite plan "$config"
echo
# Cells whose training or evaluation failed are listed by the run and by `maps suite status`; the report covers
# the finished ones either way.
status=0
build/bin/maps suite run "$config" --out "$out" || status=$?
echo
build/bin/maps report "$out"
echo "run: the suite and its report took $((SECONDS - start)) s"
exit "$status"
