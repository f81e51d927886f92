"""Reading a grid's run folders (experiments/suites/run_grid.sh): one Run per folder holding eval.json, grouped
into cells by (label, demos per task, subsample k). Shared by aggregate.py and plot.py."""
import csv
import json
import math
import pathlib
import statistics
from dataclasses import dataclass, field

# Two-sided 95% t quantiles by degrees of freedom (1-30); 1.96 past the table.
T95 = dict(enumerate([12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
                      2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
                      2.052, 2.048, 2.045, 2.042], start=1))

DEFAULT_HIDDEN = [128, 128, 128]


def ci95(values):
    """Half-width of the 95% confidence interval of the mean (t distribution); nan for fewer than 2 values."""
    if len(values) < 2:
        return float("nan")
    return T95.get(len(values) - 1, 1.96) * statistics.stdev(values) / math.sqrt(len(values))


@dataclass
class Run:
    folder: pathlib.Path
    label: str  # the cell's name: run_grid.sh's folder name without _d<demos>_k<k>_s<seed> ("mt_bc_w430")
    method: str
    seed: int
    demos: int
    subsample: int
    eval: dict
    config: dict = field(default_factory=dict)

    @property
    def tasks(self):
        return [t["task"] for t in self.eval["tasks"]]

    def curve(self):
        """(steps, validation losses) from curve.csv; empty lists when it is missing."""
        path = self.folder / "curve.csv"
        if not path.exists():
            return [], []
        steps, valid = [], []
        with path.open() as f:
            for row in csv.DictReader(f):
                steps.append(int(row["step"]))
                valid.append(float(row["validation_bc"]))
        return steps, valid


def label_of(folder_name, method, config, demos, subsample, seed):
    """run_grid.sh names a cell METHOD[_wW | _VARIANT]_d<demos>_k<k>_s<seed>; other folders get the method, with
    the baseline's width when it is not the default."""
    suffix = f"_d{demos}_k{subsample}_s{seed}"
    if folder_name.endswith(suffix) and folder_name.startswith(method):
        return folder_name[: -len(suffix)]
    return method_label(method, config)


def method_label(method, config):
    hidden = config.get("baselines", {}).get("hidden", DEFAULT_HIDDEN)
    if method != "maps" and hidden != DEFAULT_HIDDEN:
        return f"{method} ({'x'.join(map(str, hidden)) if len(set(hidden)) > 1 else f'{len(hidden)}x{hidden[0]}'})"
    return method


def load_runs(root):
    root = pathlib.Path(root)
    runs = []
    for path in sorted(root.glob("*/eval.json")):
        try:
            result = json.loads(path.read_text())
            config_path = path.parent / "config.json"
            config = json.loads(config_path.read_text()) if config_path.exists() else {}
            label = label_of(path.parent.name, result["method"], config, result["demos_per_task"],
                             result["subsample"], result["seed"])
            runs.append(Run(path.parent, label, result["method"], result["seed"], result["demos_per_task"],
                            result["subsample"], result, config))
        except (json.JSONDecodeError, KeyError) as error:
            raise SystemExit(f"{path}: unreadable run result ({error}); delete the run folder to redo it")
    if not runs:
        raise SystemExit(f"no */eval.json under {root} (run experiments/suites/run_grid.sh first)")
    return runs


def cells(runs):
    """{(label, demos, k): [runs sorted by seed]}"""
    out = {}
    for run in runs:
        out.setdefault((run.label, run.demos, run.subsample), []).append(run)
    for key in out:
        out[key].sort(key=lambda r: r.seed)
    return out
