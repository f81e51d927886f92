#!/usr/bin/env bash
# examples/python/ as a user runs it (issue 43): the library installed into a temporary prefix, the example copied out
# of the tree and run with that prefix's Python package and tool: the Python loss gradchecked, the Python loss and
# policy trained by maps.train, evaluated by the tool, compared in a tiny suite the tool runs (its embedded
# interpreter) and reported; then what the runs record of the Python code, and the refusal of a broken Python plugin.
#   python_example_test.sh BUILD_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/installed_example.sh"
installed_example python "$1"
/usr/bin/python3 "$work/example/example.py" "$work/usr/bin/maps" > "$work/example.log" 2>&1 ||
  { tail -40 "$work/example.log" >&2; fail "example.py failed"; }
grep -q "task_overlap_py: gradcheck and gradgradcheck passed" "$work/example.log" || fail "no gradcheck line"
cd "$work/example"
/usr/bin/python3 - <<'PY' || fail "the runs do not record the Python code as expected"
import hashlib, json, os
here = os.getcwd()
for run, source, registered in (("film", "film_policy.py", "method film_mlp_py"),
                                ("maps_task_overlap", "task_overlap.py", "selector loss task_overlap_py")):
    path = os.path.join(here, source)
    digest = hashlib.sha256(open(path, "rb").read()).hexdigest()
    config = json.load(open(f"runs/{run}/config.json"))
    assert config["plugins"] == [path], (run, config["plugins"])
    records = json.load(open(f"runs/{run}/provenance.json"))
    assert records, run
    for record in records:  # maps.train's record, and the tool's when it evaluated
        [entry] = [p for p in record["plugins"] if p["path"] == path]
        assert entry["sha256"] == digest and entry["built_against"] == "python", (run, entry)
        assert any(name.startswith(registered) for name in entry["registered"]), (run, entry["registered"])
    assert json.load(open(f"runs/{run}/eval.json")), run
assert "task_overlap_py" in open("runs/maps_task_overlap/curve.csv").readline()
report = open("runs/suite/report/report.md").read()
for name in ("film_mlp_py", "task_overlap_py"):
    assert name in report, f"{name} is not in the suite's report"
status = json.load(open("runs/suite/report/status.json"))
states = {cell["name"]: cell["state"] for cell in status["cells"]}
assert len(states) == 8 and set(states.values()) == {"done"}, states
print("python example: runs and suite record the Python files")
PY
# A Python plugin that raises is refused with Python's message, naming the file; nothing is trained.
printf 'raise RuntimeError("this plugin is broken on purpose")\n' > broken.py
sed 's#../task_overlap.py#../broken.py#' configs/maps_task_overlap.json > configs/broken.json
if "$work/usr/bin/maps" train --config configs/broken.json --out runs/broken 2> "$work/broken.log"; then
  fail "a config naming a broken Python plugin trained"
fi
grep -q "plugin '.*broken.py' failed: .*this plugin is broken on purpose" "$work/broken.log" ||
  { cat "$work/broken.log" >&2; fail "the broken plugin's error is not named"; }
[[ ! -e runs/broken/config.json ]] || fail "a refused run left a config.json"
echo "python example: every check passed"
