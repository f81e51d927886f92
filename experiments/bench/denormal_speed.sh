#!/usr/bin/env bash
# How much flushing denormals to zero (train.flush_denormal) speeds up training from a trained state: copies RUN (a
# run folder with last.ckpt, e.g. an unfinished suite cell) twice, resumes each copy for SECONDS with the flush on
# and off, alternating ROUNDS times, and prints the steps per second each reached (the copies' curve.csv rows after
# the checkpoint). A fresh run has no denormals yet: `maps bench step` times that; this times the state that has.
# Usage: experiments/bench/denormal_speed.sh RUN [SECONDS] [ROUNDS] [MAPS_BIN]
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
run="${1:?usage: denormal_speed.sh RUN [SECONDS] [ROUNDS] [MAPS_BIN]}"
seconds="${2:-20}"
rounds="${3:-2}"
maps="${4:-$here/build/bin/maps}"
[[ -x "$maps" ]] || { echo "denormal_speed.sh: '$maps' is not an executable maps binary (build it: cmake --build build)" >&2; exit 2; }
[[ -f "$run/last.ckpt" && -f "$run/config.json" ]] ||
  { echo "denormal_speed.sh: $run has no last.ckpt and config.json (a run folder that trained, not finished or kept)" >&2; exit 2; }
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
echo "run $run (resumed from last.ckpt), $seconds s per try, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
for round in $(seq "$rounds"); do
  for flush in true false; do
    copy="$work/$flush-$round"
    cp -r "$run" "$copy"
    rm -f "$copy/request.json"
    # The copy's own config with the flush set (and train.steps past the end so it cannot finish inside the try).
    /usr/bin/python3 - "$copy/config.json" "$flush" <<'PY'
import json, sys
path, flush = sys.argv[1], sys.argv[2] == "true"
config = json.load(open(path))
config["train"]["flush_denormal"] = flush
config["train"]["steps"] = 10 ** 9
json.dump(config, open(path, "w"))
PY
    timeout "$seconds" "$maps" train --config "$copy/config.json" --out "$copy" --threads 1 > "$copy.out" 2>&1 || true
    /usr/bin/python3 - "$copy/curve.csv" "$copy.out" "$flush" "$round" <<'PY'
import csv, re, statistics, sys
resumed = re.search(r"resumed from .* at step (\d+)", open(sys.argv[2]).read())
if not resumed:
    sys.exit(f"denormal_speed.sh: the copy did not resume from last.ckpt (see {sys.argv[2]})")
rows = list(csv.DictReader(open(sys.argv[1])))
fresh = [float(r["steps_per_second"]) for r in rows if int(r["step"]) > int(resumed.group(1))]
if not fresh:
    sys.exit(f"denormal_speed.sh: no validation row written within the try; give it more seconds")
print(f"round {sys.argv[4]}, flush_denormal {sys.argv[3]:5}: {statistics.median(fresh):7.1f} steps/s (median of"
      f" {len(fresh)} validation windows)")
PY
  done
done
