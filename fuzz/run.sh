#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, ASan + UBSan) and runs each one.
#   fuzz/run.sh --runs 1000000            # every target to a million inputs (the acceptance run; hours on 2 cores)
#   fuzz/run.sh --seconds 60              # every target for a minute
#   fuzz/run.sh --seconds 60 fuzz_expert  # one target
#   fuzz/run.sh --build-dir build-asan --jobs 2 --seconds 60   # CI: the sanitizer build .ci/run configured
# --build-dir (default build-fuzz/) is configured here unless it already has MAPS_BUILD_FUZZERS=ON; --jobs N runs N
# targets at once. Inputs start from fuzz/corpus/<target>/ (committed seeds); what a run adds goes to
# <build-dir>/corpus/<target>/. A crash, leak, sanitizer report or hang (> 10 s for one input) stops that target
# with a non-zero exit and leaves the input as <build-dir>/crash-* (or leak-*, timeout-*): reproduce with
# <build-dir>/bin/<target> <file>. The script exits non-zero if any target failed.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

limit=(-max_total_time=60)
targets=()
build_dir=build-fuzz
jobs=1
usage="usage: fuzz/run.sh [--runs N | --seconds S] [--build-dir DIR] [--jobs N] [fuzz_<target>...]"
while [[ $# -gt 0 ]]; do
  case "$1" in
    --runs) limit=(-runs="$2"); shift 2 ;;
    --seconds) limit=(-max_total_time="$2"); shift 2 ;;
    --build-dir) build_dir="$2"; shift 2 ;;
    --jobs) jobs="$2"; shift 2 ;;
    fuzz_*) targets+=("$1"); shift ;;
    *) echo "$usage" >&2; exit 2 ;;
  esac
done
[[ "$jobs" =~ ^[1-9][0-9]*$ ]] || { echo "fuzz/run.sh: --jobs needs a positive integer, got '$jobs'" >&2; exit 2; }
[[ ${#targets[@]} -gt 0 ]] || targets=(fuzz_run_config fuzz_suite_config fuzz_expert fuzz_checkpoint fuzz_demo_file)
for target in "${targets[@]}"; do
  [[ -n "$(ls -A "fuzz/corpus/$target" 2> /dev/null)" ]] ||
    { echo "fuzz/run.sh: fuzz/corpus/$target/ (the target's committed seed inputs) is missing or empty" >&2; exit 1; }
done

if ! grep -qs "^MAPS_BUILD_FUZZERS:BOOL=ON" "$build_dir/CMakeCache.txt"; then
  command -v clang++ > /dev/null ||
    { echo "fuzz/run.sh: clang++ not found (bash scripts/setup.sh installs clang)" >&2; exit 1; }
  CC=clang CXX=clang++ cmake -S . -B "$build_dir" -DMAPS_BUILD_FUZZERS=ON -DMAPS_BUILD_TESTS=OFF \
    -DMAPS_BUILD_BENCHMARKS=OFF -DMAPS_BUILD_RENDER=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo > /dev/null
fi
cmake --build "$build_dir" -j"$(nproc)" --target "${targets[@]}"

export ASAN_OPTIONS=detect_leaks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1

# Runs one target to its limit; prints its summary lines and returns its exit status.
fuzz_one() {
  local target="$1" status=0
  mkdir -p "$build_dir/corpus/$target"
  local log="$build_dir/$target.log"
  (cd "$build_dir" && "bin/$target" "${limit[@]}" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
     "corpus/$target" "$OLDPWD/fuzz/corpus/$target") > "$log" 2>&1 || status=$?
  { echo "== $target (${limit[*]}; log: $log)"; grep -E "^#[0-9]+[[:space:]]+DONE|^Done|ERROR|SUMMARY" "$log" || true; }
  [[ $status -eq 0 ]] || echo "$target found a failure (exit $status): see $log and $build_dir/" >&2
  return "$status"
}

failed=0
running=0
for target in "${targets[@]}"; do
  fuzz_one "$target" &
  running=$((running + 1))
  if [[ $running -ge $jobs ]]; then
    wait -n || failed=1
    running=$((running - 1))
  fi
done
while [[ $running -gt 0 ]]; do
  wait -n || failed=1
  running=$((running - 1))
done
[[ $failed -eq 0 ]] || { echo "fuzz: a target failed" >&2; exit 1; }
echo "fuzz: every target ran clean"
