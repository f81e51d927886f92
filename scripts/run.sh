#!/usr/bin/env bash
# Installs what is missing, builds the `maps` tool, and runs the main job. For now that is
# `maps demo` (a small tanh MLP trained on a synthetic regression); later issues make it the
# quick comparison suite. Extra arguments go to the job, e.g. `bash scripts/run.sh --steps 2000`.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

bash scripts/setup.sh
cmake -S . -B build
cmake --build build -j"$(nproc)" --target maps
build/bin/maps demo "$@"
