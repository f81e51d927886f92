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
for path in lib/libmaps_autograd.a lib/libmaps_core.a include/maps/autograd/tensor.h include/maps/maps/policies/maps_policy.h \
  lib/cmake/maps/mapsConfig.cmake; do
  [[ -e "$prefix/usr/$path" ]] || { echo "install: $path missing under the prefix" >&2; exit 1; }
done
cmake -S "$source_dir/consumer" -B "$prefix/consumer" -DCMAKE_PREFIX_PATH="$prefix/usr" -DCMAKE_BUILD_TYPE=Release \
  > "$prefix/configure.log" || { cat "$prefix/configure.log" >&2; exit 1; }
cmake --build "$prefix/consumer" -j2 > "$prefix/build.log" 2>&1 || { cat "$prefix/build.log" >&2; exit 1; }
"$prefix/consumer/consumer"
