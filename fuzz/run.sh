#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, ASan + UBSan) in build-fuzz/ and runs each one.
#   fuzz/run.sh --runs 1000000            # every target to a million inputs (the acceptance run; hours on 2 cores)
#   fuzz/run.sh --seconds 60              # every target for a minute (CI)
#   fuzz/run.sh --seconds 60 fuzz_expert  # one target
# Inputs start from fuzz/corpus/<target>/ (committed seeds); what a run adds goes to build-fuzz/corpus/<target>/.
# A crash, leak, sanitizer report or hang (> 10 s for one input) stops the target with a non-zero exit and leaves
# the input as build-fuzz/crash-* (or leak-*, timeout-*): reproduce with build-fuzz/bin/<target> <file>.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

limit=(-max_total_time=60)
targets=()
while [[ $# -gt 0 ]]; do
  case "$1" in
    --runs) limit=(-runs="$2"); shift 2 ;;
    --seconds) limit=(-max_total_time="$2"); shift 2 ;;
    fuzz_*) targets+=("$1"); shift ;;
    *) echo "usage: fuzz/run.sh [--runs N | --seconds S] [fuzz_<target>...]" >&2; exit 2 ;;
  esac
done
[[ ${#targets[@]} -gt 0 ]] || targets=(fuzz_run_config fuzz_suite_config fuzz_expert fuzz_checkpoint fuzz_demo_file)

command -v clang++ > /dev/null || { echo "fuzz/run.sh: clang++ not found (bash scripts/setup.sh installs clang)" >&2; exit 1; }
CC=clang CXX=clang++ cmake -S . -B build-fuzz -DMAPS_BUILD_FUZZERS=ON -DMAPS_BUILD_TESTS=OFF \
  -DMAPS_BUILD_BENCHMARKS=OFF -DMAPS_BUILD_RENDER=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo > /dev/null
cmake --build build-fuzz -j"$(nproc)" --target "${targets[@]}"

export ASAN_OPTIONS=detect_leaks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
for target in "${targets[@]}"; do
  mkdir -p "build-fuzz/corpus/$target"
  log="build-fuzz/$target.log"
  echo "== $target (${limit[*]}; log: $log)"
  status=0
  (cd build-fuzz && "bin/$target" "${limit[@]}" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
     "corpus/$target" "../fuzz/corpus/$target") > "$log" 2>&1 || status=$?
  grep -E "^#[0-9]+[[:space:]]+DONE|^Done|ERROR|SUMMARY" "$log" || true
  [[ $status -eq 0 ]] || { echo "$target found a failure (exit $status): see $log and build-fuzz/" >&2; exit 1; }
done
echo "fuzz: every target ran clean"
