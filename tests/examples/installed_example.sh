# Sourced by the examples' tests: `installed_example NAME BUILD_DIR` installs BUILD_DIR into a temporary prefix
# ($work/usr, removed on exit), points the installed tool at the prefix's data, and copies examples/NAME there
# ($work/example) without what an earlier run of it left; `fail MESSAGE` stops the test naming the example.
installed_example() {
  example_name="$1"
  local build source_dir
  build="$(cd "$2" && pwd)"
  source_dir="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
  work="$(mktemp -d "${TMPDIR:-/tmp}/maps-$example_name-example-XXXXXX")"
  trap 'rm -rf "$work"' EXIT
  cmake --install "$build" --prefix "$work/usr" > "$work/install.log"
  export MAPS_ASSETS_DIR="$work/usr/share/maps/envs/assets" MAPS_EXPERTS_DIR="$work/usr/share/maps/envs/experts"
  export MAPS_SUITES_DIR="$work/usr/share/maps/experiments/suites"
  export PYTHONPATH="$work/usr/lib/python3/dist-packages"
  cp -r "$source_dir/examples/$example_name" "$work/example"
  rm -rf "$work/example/build" "$work/example/data" "$work/example/runs" "$work/example/__pycache__"
}
fail() { echo "$example_name example: $*" >&2; exit 1; }
