#!/usr/bin/env bash
# Installs what is missing, configures and builds build/ (Release), and runs every test.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

bash scripts/setup.sh
cmake -S . -B build
cmake --build build -j"$(nproc)"
# --no-tests=error: an empty test list is a failure, not a silent pass.
ctest --test-dir build --output-on-failure -j2 --no-tests=error
