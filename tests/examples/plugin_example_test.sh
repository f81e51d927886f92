#!/usr/bin/env bash
# examples/plugin/ as a user runs it (issue 43): the library installed into a temporary prefix, the example copied
# out of the tree and built against the prefix, its method and its selector loss trained, evaluated, run in a tiny
# suite beside MAPS and MT-BC and reported by the installed tool; then what the runs record of the plugin, and the
# tool's refusal of a missing plugin (the loader's other refusals: tests/experiments/plugins_test.cpp).
#   plugin_example_test.sh BUILD_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/installed_example.sh"
installed_example plugin "$1"
bash "$work/example/run_example.sh" "$work/usr" > "$work/example.log" 2>&1 || { tail -40 "$work/example.log" >&2; fail "run_example.sh failed"; }
cd "$work/example"
plugin="$(pwd)/build/libmaps_example_plugin.so"
digest="$(sha256sum "$plugin" | cut -d' ' -f1)"
/usr/bin/python3 - "$plugin" "$digest" <<'PY' || fail "the runs do not record the plugin as expected"
import json, sys
plugin, digest = sys.argv[1], sys.argv[2]
for run, registered in (("film", "method film_mlp"), ("maps_task_overlap", "selector loss task_overlap")):
    config = json.load(open(f"runs/{run}/config.json"))
    assert config["plugins"] == [plugin], (run, config["plugins"])
    for record in json.load(open(f"runs/{run}/provenance.json")):
        [entry] = record["plugins"]
        assert entry["path"] == plugin and entry["sha256"] == digest, (run, entry)
        assert registered in entry["registered"], (run, entry["registered"])
    evaluation = json.load(open(f"runs/{run}/eval.json"))
    assert evaluation, run
overlap = json.load(open("runs/maps_task_overlap/config.json"))["maps"]["selector_losses"]
assert overlap["task_overlap"] == 0.5, overlap
assert "task_overlap" in open("runs/maps_task_overlap/curve.csv").readline(), "the plugin's loss is not in the curve"
report = open("runs/suite/report/report.md").read()
for name in ("film_mlp", "task_overlap"):
    assert name in report, f"{name} is not in the suite's report"
status = json.load(open("runs/suite/report/status.json"))
states = {cell["name"]: cell["state"] for cell in status["cells"]}
assert len(states) == 8 and set(states.values()) == {"done"}, states
print("plugin example: runs and suite record", plugin, digest[:12])
PY
# A missing plugin is named; a plugin whose name is taken is refused naming both; neither leaves a run behind.
sed 's#../build/libmaps_example_plugin.so#../build/libnot_there.so#' configs/film.json > configs/missing.json
if "$work/usr/bin/maps" train --config configs/missing.json --out runs/missing 2> "$work/missing.log"; then
  fail "a config naming a missing plugin trained"
fi
grep -q "plugin '.*build/libnot_there.so' does not exist" "$work/missing.log" || { cat "$work/missing.log" >&2; fail "missing plugin not named"; }
[[ ! -e runs/missing/config.json ]] || fail "a refused run left a config.json"
echo "plugin example: every check passed"
