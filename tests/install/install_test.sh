#!/usr/bin/env bash
# Installs the built library into a temporary prefix, then configures, builds and runs tests/install/consumer/ (a
# user's project: find_package(maps), maps::nn) against it, built without this build's -march=native.
#   install_test.sh BUILD_DIR
set -euo pipefail
build="$1"
source_dir="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
prefix="$(mktemp -d "${TMPDIR:-/tmp}/maps-install-test-XXXXXX")"
trap 'rm -rf "$prefix"' EXIT
cmake --install "$build" --prefix "$prefix/usr" > "$prefix/install.log"
for path in bin/maps share/maps/experiments/report/report.py share/maps/experiments/suites/costs.json \
  share/maps/experiments/process/json_input.py lib/libmaps_autograd.a lib/libmaps_core.a include/maps/autograd/tensor.h include/maps/policies/maps_policy.h \
  lib/cmake/maps/mapsConfig.cmake share/maps/envs/assets share/maps/envs/experts/gravity/1.0.json; do
  [[ -e "$prefix/usr/$path" ]] || { echo "install: $path missing under the prefix" >&2; exit 1; }
done
cmake -S "$source_dir/consumer" -B "$prefix/consumer" -DCMAKE_PREFIX_PATH="$prefix/usr" -DCMAKE_BUILD_TYPE=Release \
  > "$prefix/configure.log" || { cat "$prefix/configure.log" >&2; exit 1; }
cmake --build "$prefix/consumer" -j2 > "$prefix/build.log" 2>&1 || { cat "$prefix/build.log" >&2; exit 1; }
# Every installed header includes the others under the maps/ prefix, so only include/ is on a user's path.
if grep -rEn '#include "(autograd|nn|envs)/' "$prefix/usr/include/maps" >&2; then
  echo "install: the headers above include a library header without the maps/ prefix" >&2
  exit 1
fi
# The compiled-in data folder is the configured prefix's; this prefix is a temporary one, so point at it.
export MAPS_ASSETS_DIR="$prefix/usr/share/maps/envs/assets" MAPS_EXPERTS_DIR="$prefix/usr/share/maps/envs/experts"
"$prefix/consumer/consumer"
# The installed tool runs, names its version, and finds the data it reads under the prefix when pointed there.
"$prefix/usr/bin/maps" --version | grep -q "^maps 0\." || { echo "install: bin/maps --version failed" >&2; exit 1; }
MAPS_SUITES_DIR="$prefix/usr/share/maps/experiments/suites" "$prefix/usr/bin/maps" suite plan \
  "$prefix/usr/share/maps/experiments/suites/tiny.json" > "$prefix/plan.log" ||
  { cat "$prefix/plan.log" >&2; echo "install: bin/maps suite plan failed" >&2; exit 1; }
# The Python package, when the build made it (PYTHONPATH: a temporary prefix is not on python3's path).
if [[ -d "$build/python/maps" ]]; then
  PYTHONPATH="$prefix/usr/lib/python3/dist-packages" /usr/bin/python3 -c '
import maps
env = maps.make_env("mt10/reach")
obs, _ = env.reset(seed=1)
expert = maps.load_expert("mt10/reach")
steps = 0
while True:
    obs, reward, terminated, truncated, info = env.step(expert.act(obs))
    steps += 1
    if terminated or truncated or info["success"]:
        break
assert info["success"], "the installed expert did not reach"
print(f"python: import maps from the prefix ({maps.__file__}); mt10/reach reached in {steps} steps")
'
fi
