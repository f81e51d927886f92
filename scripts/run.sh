#!/usr/bin/env bash
# Installs what is missing, builds the `maps` tool, and runs the main job: the quick comparison suite
# (experiments/suites/quick.sh: MAPS and the four baselines on the Gravity set at a small budget; prints the
# results table and writes plots to runs/quick/). Arguments go to quick.sh: [OUT] [STEPS] [SEEDS] [EPISODES].
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

bash scripts/setup.sh
cmake -S . -B build
cmake --build build -j"$(nproc)" --target maps
experiments/suites/quick.sh "$@"
