#!/usr/bin/env bash
# Runs a grid of `maps train` + `maps eval` runs, one folder per cell, skipping cells whose eval.json exists
# (so an interrupted grid resumes where it stopped; a cell interrupted mid-training resumes from its checkpoint).
# Two cells run at once (the machine's two cores).
#
#   experiments/suites/run_grid.sh OUT DATA METHODS COUNTS SEEDS SUBSAMPLE STEPS [EPISODES]
#   experiments/suites/run_grid.sh results/gate-gravity data/gravity.h5 "single_bc" "1 2 5 10 25" "0 1 2 3 4" 10 3000 100
# MAPS_BIN=path/to/maps runs another build of the tool.
# A method written METHOD@W (e.g. mt_bc@430) gives a baseline three hidden layers of W units (cell mt_bc_w430_...);
# METHOD%VARIANT (e.g. maps%sparse05) merges experiments/suites/variants/VARIANT.json into the run's config (cell
# maps_sparse05_...): a record of a tuning run, in the same grid as the runs it is compared with.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
if [[ $# -lt 7 ]]; then
  sed -n '2,11p' "$0" >&2
  exit 2
fi
out=$1 data=$2 methods=$3 counts=$4 seeds=$5 subsample=$6 steps=$7 episodes=${8:-100}
[[ -f "$data" ]] || { echo "run_grid: no demo file '$data' (make it with maps collect)" >&2; exit 2; }
maps=${MAPS_BIN:-build/bin/maps}  # another build of the tool, e.g. while build/ is rebuilt
mkdir -p "$out"
cells=()
for method in $methods; do
  for count in $counts; do
    for seed in $seeds; do
      cells+=("$method $count $seed")
    done
  done
done
run_cell() {
  local method=${1%%[@%]*} count=$2 seed=$3 name=$1 extra="{}"
  if [[ $1 == *@* ]]; then
    local width=${1#*@}
    [[ $method != maps ]] || { echo "run_grid: method '$1': @W sets a baseline's width; MAPS has no baseline MLP" >&2; return 2; }
    [[ $width =~ ^[1-9][0-9]*$ ]] || { echo "run_grid: method '$1': expected METHOD@WIDTH with WIDTH > 0" >&2; return 2; }
    name="${method}_w${width}"
    extra="{\"baselines\": {\"hidden\": [$width, $width, $width]}}"
  elif [[ $1 == *%* ]]; then
    local variant=${1#*%}
    local file="experiments/suites/variants/$variant.json"
    [[ -f $file ]] || { echo "run_grid: method '$1': no variant file $file" >&2; return 2; }
    name="${method}_${variant}"
    extra=$(cat "$file")
  fi
  local dir="$out/${name}_d${count}_k${subsample}_s${seed}"
  [[ -f "$dir/eval.json" ]] && return 0
  mkdir -p "$dir"
  # The request: the grid's settings, with the variant's keys merged in (objects merged key by key).
  /usr/bin/python3 - "$dir/request.json" "$extra" "$method" "$seed" "$data" "$count" "$subsample" "$steps" "$episodes" <<'PY' ||
import json, sys
out, extra, method, seed, data, count, subsample, steps, episodes = sys.argv[1:]
def merge(base, more):
    for key, value in more.items():
        base[key] = merge(base.get(key, {}), value) if isinstance(value, dict) else value
    return base
request = {"method": method, "seed": int(seed),
           "data": {"file": data, "demos_per_task": int(count), "subsample": int(subsample)},
           "train": {"steps": int(steps), "validate_every": 250, "checkpoint_every": 500},
           "eval": {"episodes": int(episodes), "threads": 1}}
json.dump(merge(request, json.loads(extra)), open(out, "w"), indent=1)
PY
    { echo "run_grid: method '$1': cannot write the request (bad variant JSON, or a count/seed/steps not a number)" >&2; return 2; }
  # A failed step must not leave a cell that looks finished (eval.json from a half-trained run).
  "$maps" train --config "$dir/request.json" --out "$dir" > "$dir/train.log" 2>&1 ||
    { echo "$(date +%T) $dir: training failed, see $dir/train.log: $(tail -1 "$dir/train.log")" >&2; return 1; }
  "$maps" eval --run "$dir" > "$dir/eval.log" 2>&1 ||
    { echo "$(date +%T) $dir: evaluation failed, see $dir/eval.log: $(tail -1 "$dir/eval.log")" >&2; return 1; }
  echo "$(date +%T) $dir: $(tail -1 "$dir/eval.log")"
}
export -f run_cell
export out data subsample steps episodes maps
printf '%s\n' "${cells[@]}" | xargs -P2 -L1 bash -c 'run_cell $0 $1 $2'
