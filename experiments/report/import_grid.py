#!/usr/bin/python3
"""Turns a grid of run folders made by the shell grid that `maps suite` replaced (run_grid.sh: one folder per run,
METHOD[_wW | _VARIANT]_d<demos>_k<k>_s<seed>, with config.json, train.json, eval.json, curve.csv) into a suite
folder that `maps report` and `maps suite status` read, as cells of a suite whose config gives them the same run
configs.

    build/bin/maps suite run experiments/suites/gravity-20k.json --out OUT --shard 99999/100000   # suite.json only
    /usr/bin/python3 experiments/report/import_grid.py results/compare-gravity-20k OUT [--map w430=_w430 ...]

Each old folder's name is mapped to the suite's cell name (set from the suite; "_w430" -> variant "w430",
"_sparse05" -> "sparse05"); its config must equal the cell's run config, apart from keys the old tool did not
write yet whose value is the suite's default (then the cell's resolved config is recorded). A folder that maps to
no cell, or whose config differs, is an error naming both. Copies config.json, train.json, eval.json and curve.csv
and writes result.json (maps-suite-cell/1) with "imported_from" naming the old folder; checkpoints are not copied.
"""
import json
import pathlib
import re
import shutil
import sys

from suite_results import JsonTooDeep, read_json

# Keys a run folder written before they existed lacks; the value they then had.
IMPLIED = {"baselines": {"hidden": [128, 128, 128]}}


def same_config(old, request):
    for key, value in request.items():
        if key not in old:
            if IMPLIED.get(key) != value:
                return False
        elif old[key] != value:
            return False
    return set(old) <= set(request)


def main(old_dir, out_dir):
    old_dir, out_dir = pathlib.Path(old_dir), pathlib.Path(out_dir)
    manifest_path = out_dir / "suite.json"
    if not manifest_path.exists():
        sys.exit(f"import_grid: {manifest_path} is missing: write it first (maps suite run CONFIG --out {out_dir}"
                 " --shard 99999/100000 runs no cell and writes only suite.json)")
    manifest = read_json(manifest_path)
    cells = {c["name"]: c for c in manifest["cells"]}
    sets = {c["set"] for c in manifest["cells"]}
    if len(sets) != 1:
        sys.exit(f"import_grid: {manifest_path} has cells of {len(sets)} sets; the old grids hold one set")
    set_name = sets.pop()
    variants = {c["variant"] for c in manifest["cells"]} - {"base"}
    pattern = re.compile(r"(maps|single_bc|mt_bc|mt_mh_bc|maml)(?:_(" + "|".join(map(re.escape, variants)) +
                         r"))?_d(\d+)_k(\d+)_s(\d+)$" if variants else
                         r"(maps|single_bc|mt_bc|mt_mh_bc|maml)()_d(\d+)_k(\d+)_s(\d+)$")
    imported = 0
    for folder in sorted(p for p in old_dir.iterdir() if (p / "eval.json").exists()):
        match = pattern.match(folder.name)
        if not match:
            sys.exit(f"import_grid: {folder}: its name maps to no cell of {manifest_path}")
        method, variant, demos, k, seed = match.groups()
        name = f"{set_name}/{method}{'-' + variant if variant else ''}_d{demos}_s{seed}"
        cell = cells.get(name)
        if cell is None:
            sys.exit(f"import_grid: {folder}: no cell {name} in {manifest_path}")
        old_config = read_json(folder / "config.json")
        if not same_config(old_config, cell["request"]) or int(k) != cell["subsample"]:
            sys.exit(f"import_grid: {folder}: its config.json is not the run config of cell {name}")
        target = out_dir / "cells" / name
        target.mkdir(parents=True, exist_ok=True)
        for file in ("train.json", "eval.json", "curve.csv", "train.log", "eval.log"):
            if (folder / file).exists():
                shutil.copy2(folder / file, target / file)
        (target / "config.json").write_text(json.dumps(cell["request"], indent=2) + "\n")
        identity = {key: cell[key] for key in ("index", "name", "grid", "set", "method", "variant", "demos",
                                                "subsample", "seed")}
        train = read_json(folder / "train.json")
        evaluation = read_json(folder / "eval.json")
        # The old folders kept the last process's training time and the evaluation's: their sum stands in for the
        # wall time (a resumed run's earlier processes are not in it).
        result = {"format": "maps-suite-cell/1", "cell": identity, "config": cell["request"], "train": train,
                  "eval": evaluation,
                  "wall_seconds": train.get("seconds_this_process", 0.0) + evaluation.get("seconds", 0.0),
                  "threads": 1, "host": "", "finished": "", "imported_from": folder.name}
        temporary = target / "result.json.tmp"
        temporary.write_text(json.dumps(result, indent=2) + "\n")
        temporary.replace(target / "result.json")
        imported += 1
    print(f"import_grid: {imported} run folders of {old_dir} imported into {out_dir}")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    try:
        main(sys.argv[1], sys.argv[2])
    except JsonTooDeep as e:
        sys.exit(f"import_grid: {e}")
