#!/usr/bin/env bash
# docs/reliability.md's table of damaged and hostile inputs (issue 41): the property tests of every file format at
# CASES mutants each (random truncations, byte flips, structural JSON edits, from a fixed seed), the walks of every
# schema key with the edge values of its type, and the sweep of every numeric CLI option. Prints the markdown rows.
#   scripts/reliability_table.sh [BUILD_DIR] [CASES]     (defaults: build 2000)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
build="${1:-build}"
cases="${2:-2000}"
for binary in maps maps_envs_tests maps_core_tests maps_experiments_tests; do
  [[ -x "$build/bin/$binary" ]] || { echo "reliability_table: $build/bin/$binary is missing: build first" >&2; exit 1; }
done
log="$(mktemp)"
trap 'rm -f "$log"' EXIT
run() {  # a gtest binary and filter, at CASES mutants, its output appended to the log; a failure stops the table
  MAPS_PROPERTY_CASES="$cases" "$build/bin/$1" --gtest_filter="$2" --gtest_brief=1 >> "$log" 2>&1 ||
    { cat "$log" >&2; echo "reliability_table: $1 $2 failed" >&2; exit 1; }
}
run maps_envs_tests 'DemoFileProperty.*:ExpertProperty.*'
run maps_core_tests 'CheckpointProperty.*'
run maps_experiments_tests 'RunFolderProperty.*:SuiteFolderProperty.*'
# Crashes and hangs are 0 by construction of a table that is printed at all: a crash ends the test binary (and this
# script), a read over 60 s fails the test.
echo "| input | mutants | refused (naming the file) | accepted (every invariant held) | crashes | hangs | slowest read |"
echo "|---|---|---|---|---|---|---|"
grep -E '^property .* mutants' "$log" |
  sed -E 's/^property (.*): ([0-9]+) mutants, ([0-9]+) refused, ([0-9]+) accepted, 0 crashes, slowest read (.*) s$/| \1 | \2 | \3 | \4 | 0 | 0 | \5 s |/'
echo
sed -n 's/^property demo file bytes: \([0-9]*\) of the refusals were the reading child.s death$/- demo files: \1 of the refused mutants killed the child process that reads a demo file first (libhdf5)/p' "$log"
: > "$log"
run maps_core_tests 'RunConfigSchema.EveryKeyTakesTheValuesOfItsRangeAndRefusesEveryOtherByName'
sed -n 's/^tried \(.*\) values of \(.*\) keys, \(.*\) refused$/- run config: \1 edge values of its \2 keys, \3 refused by name, every accepted one kept as given/p' "$log"
: > "$log"
run maps_experiments_tests 'SuiteConfigSchema.EveryKeyTakesTheValuesOfItsRangeAndRefusesEveryOtherByName'
sed -n 's/^tried \(.*\) values of \(.*\) keys, \(.*\) refused$/- suite config: \1 edge values of its \2 keys, \3 refused by name/p' "$log"
: > "$log"
run maps_core_tests 'CheckpointRecordSchema.*'
# Two walks, best.ckpt's record first, then last.ckpt's.
grep '^tried ' "$log" | awk '{ printf "- %s record: %s edge values of its %s keys, %s refused by name\n", (NR == 1 ? "best.ckpt" : "last.ckpt"), $2, $5, $7 }'
: > "$log"
run maps_envs_tests 'ExpertProperty.EveryKey*'
sed -n 's/^tried \(.*\) values of \(.*\) keys, \(.*\) refused$/- expert file: \1 edge values of its \2 keys, \3 refused by name/p' "$log"
sweep="$(/usr/bin/python3 tests/experiments/bad_input_test.py "$build/bin/maps" \
  BadInputTest.test_every_numeric_option_refuses_bad_values 2>&1 | grep '^bad_input sweep:' || true)"
[[ -n "$sweep" ]] || { echo "reliability_table: the CLI sweep printed no counts" >&2; exit 1; }
echo "- command line: ${sweep#bad_input sweep: }"
