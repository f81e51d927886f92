#!/usr/bin/env bash
# What a selector loss written in Python costs per MAPS training step, against the same loss in C++ (issue 43): `maps
# bench step` on each set, MAPS with the paper's four losses alone, plus examples/plugin's task_overlap (the C++
# plugin, built by the tests as build/tests/plugins/libmaps_example_task_overlap.so), plus examples/python's
# task_overlap_py (run by the tool's embedded interpreter). The three are timed in turn, ROUNDS times; the table
# gives each one's median ms/step and the median over rounds of each round's ratio (the three of a round ran within
# seconds of each other, so a ratio is less exposed to the machine's drift than a ratio of medians).
#   experiments/bench/selector_loss_overhead.sh [BUILD_DIR] [ROUNDS] [SECONDS]     (defaults: build 3 3)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
build="${1:-build}" rounds="${2:-3}" seconds="${3:-3}"
plugin="$PWD/$build/tests/plugins/libmaps_example_task_overlap.so"
[[ -f "$plugin" ]] || { echo "selector_loss_overhead: $plugin is missing: build the tests first" >&2; exit 1; }
configs="$(mktemp -d)"
trap 'rm -rf "$configs"' EXIT
losses='"share": 1, "explore": 0.5, "sparse": 0.001, "smooth": 1'
echo "{\"maps\": {\"selector_losses\": {$losses}}}" > "$configs/base.json"
echo "{\"plugins\": [\"$plugin\"], \"maps\": {\"selector_losses\": {$losses, \"task_overlap\": 0.5}}}" > "$configs/cpp.json"
echo "{\"plugins\": [\"$PWD/examples/python/task_overlap.py\"], \"maps\": {\"selector_losses\": {$losses, \"task_overlap_py\": 0.5}}}" > "$configs/python.json"
echo "CPU: $(grep -m1 'model name' /proc/cpuinfo | sed 's/^[^:]*: //'), one thread, $rounds rounds of ${seconds} s each"
echo
echo "| set | MAPS, 4 losses (ms/step) | + task_overlap in C++ | + task_overlap_py in Python | Python over C++ (median of rounds) | with the Python loss over MAPS alone |"
echo "|---|---|---|---|---|---|"
for set in gravity modified mt10; do
  declare -A times=([base]="" [cpp]="" [python]="")
  for ((round = 0; round < rounds; ++round)); do
    for kind in base cpp python; do
      ms="$("$build/bin/maps" bench step --set "$set" --config "$configs/$kind.json" --seconds "$seconds" --json |
        /usr/bin/python3 -c 'import json, sys; print(json.load(sys.stdin)["ms_per_step"])')"
      times[$kind]+="$ms "
    done
  done
  /usr/bin/python3 - "$set" "${times[base]}" "${times[cpp]}" "${times[python]}" <<'PY'
import statistics, sys
name, (base, cpp, python) = sys.argv[1], ([float(x) for x in v.split()] for v in sys.argv[2:])
median = statistics.median
over_cpp = median(p / c - 1 for p, c in zip(python, cpp))
over_base = median(p / b - 1 for p, b in zip(python, base))
print(f"| {name} | {median(base):.2f} | {median(cpp):.2f} | {median(python):.2f} | {over_cpp:+.1%} | {over_base:+.1%} |")
PY
done
