#!/usr/bin/env bash
# The example as docs/extending.md walks through it: build the plugin against an installed maps, train and evaluate
# its method and a MAPS run with its selector loss, then run them in a tiny suite beside MAPS and MT-BC and report.
#   bash run_example.sh [PREFIX]        (default: the prefix of the `maps` on the PATH)
# Writes build/, data/gravity.h5 and runs/ here; a rerun resumes (finished runs and cells are kept).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")"
prefix="${1:-$(dirname "$(dirname "$(command -v maps)")")}"
maps="$prefix/bin/maps"
cmake -S . -B build -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_BUILD_TYPE=Release
cmake --build build -j2
[[ -f data/gravity.h5 ]] || "$maps" collect --set gravity --demos 4 --out data/gravity.h5
for run in film maps_task_overlap; do
  "$maps" train --config "configs/$run.json" --out "runs/$run"
  "$maps" eval --run "runs/$run"
done
"$maps" suite run suite.json --out runs/suite
"$maps" report runs/suite
