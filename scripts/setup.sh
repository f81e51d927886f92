#!/usr/bin/env bash
# Installs every Debian package the project needs (apt-get only). Idempotent: packages already
# installed are skipped, and apt-get runs only when something is missing.
set -euo pipefail

PACKAGES=(
  build-essential
  cmake
  libeigen3-dev
  libgtest-dev
  libgmock-dev
  googletest
  libbenchmark-dev
  nlohmann-json3-dev
  libcli11-dev
  clang-format
  clang               # fuzz/run.sh: libFuzzer targets (clang 14 with libclang-rt-14-dev)
  libclang-rt-14-dev
  lld                 # .ci/run links the sanitizer builds' 70 MB executables with lld (5x faster than GNU ld)
  libomp-14-dev       # .ci/run: ThreadSanitizer with clang needs libomp and its Archer tool (libarcher.so)
  libmujoco-dev
  libqhull-dev  # mujoco's CMake config names /usr/include/libqhull_r
  libhdf5-dev
  libboost-dev  # Boost.Math: Student's t quantiles of the evaluation's confidence intervals
  libssl-dev    # SHA-256 of the demo file a run trained on (experiments/run/provenance.cpp)
  hdf5-tools  # h5diff: the kill tests compare demo files by content (tests/experiments/kill_test.py)
  libosmesa6-dev  # offscreen rendering (maps render); optional for the build
  libpng-dev
  libgif-dev    # animated GIFs of a trained policy's episode (maps render --run RUN --out x.gif)
  python3             # /usr/bin/python3 runs the result tables and plots (experiments/suites/)
  python3-matplotlib  # plots
  python3-scipy       # the report's t tests (experiments/report/suite_stats.py)
  python3-h5py        # tests that read demo files as robomimic, D4RL and Minari users do (tests/experiments/)
  python3-dev         # the `maps` Python module (python/, docs/python.md): Python's headers,
  python3-numpy       #   numpy arrays in and out,
  pybind11-dev        #   pybind11's headers and CMake package,
  python3-pybind11    #   and its Python side
)

export DEBIAN_FRONTEND=noninteractive

is_installed() {
  [[ "$(dpkg-query -W -f='${Status}' "$1" 2>/dev/null || true)" == "install ok installed" ]]
}

missing=()
for pkg in "${PACKAGES[@]}"; do
  is_installed "$pkg" || missing+=("$pkg")
done

if ((${#missing[@]} == 0)); then
  echo "setup: all ${#PACKAGES[@]} packages already installed"
  exit 0
fi

if ((EUID == 0)); then
  as_root=()
elif command -v sudo >/dev/null 2>&1; then
  as_root=(sudo env DEBIAN_FRONTEND=noninteractive)
else
  echo "setup: missing packages: ${missing[*]}" >&2
  echo "setup: installing them needs root, and this is not root and has no sudo; run as root:" >&2
  echo "  apt-get update && apt-get install -y --no-install-recommends ${missing[*]}" >&2
  exit 1
fi

echo "setup: installing ${missing[*]}"
"${as_root[@]}" apt-get update
"${as_root[@]}" apt-get install -y --no-install-recommends "${missing[@]}"

still_missing=()
for pkg in "${missing[@]}"; do
  is_installed "$pkg" || still_missing+=("$pkg")
done
if ((${#still_missing[@]} > 0)); then
  echo "setup: still not installed after apt-get: ${still_missing[*]}" >&2
  exit 1
fi
echo "setup: done"
