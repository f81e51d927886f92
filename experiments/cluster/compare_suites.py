#!/usr/bin/python3
"""Checks that two suite output folders hold the same results, number for number.

    /usr/bin/python3 experiments/cluster/compare_suites.py [--whole] DIR_A DIR_B

DIR_A and DIR_B are `maps suite run --out` (or `maps suite merge --out`) folders. Their finished cells (what
`maps suite status --json DIR` counts as done: the tool decides, here as for the report; experiments/report/
suite_results.py finds the tool) must be the same set of <set>/<cell> names, and for every cell the
"eval" object's "mean_score" and, for every task i, "tasks"[i]["score"], "return_mean" and "success_rate"
must be exactly equal (runs are deterministic: a sharded run merged must equal a single-process run). Wall
times, hosts and timestamps are not compared. A task's name ("task"), where present, must match too, so
that the i-th tasks are the same task.

With --whole, every value of every result.json is compared (the resolved config, the training summary, every
evaluation number, the cell's identity, the CPU and kernel), all but what differs from one run to the next on the
same machine: the keys in VOLATILE_KEYS (wall and CPU times, the host, dates, the commit that ran), and DIR/report/
results.csv (`maps report`) when both folders have one, row by row, all but its time columns: what a change that
must not alter behaviour is checked with (issue 42).

Exit 0 when equal (prints the number of cells compared), 1 at the first difference (names the cell and the
field), 2 when a folder or a result cannot be read or holds no finished cell. Standard library only, and the tool.
"""
import csv
import math
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "report"))
from suite_results import SuiteError, read_json, suite_status  # noqa: E402

TASK_FIELDS = ("score", "return_mean", "success_rate")
# What --whole leaves out, at any depth: times, the host, dates and the commit built (training_attempts' git_commit).
VOLATILE_KEYS = {"wall_seconds", "seconds", "seconds_this_process", "finished", "started_utc", "host", "git_commit"}
VOLATILE_COLUMNS = {"wall_seconds", "compute_seconds"}


def finished_cells(root):
    """({"<set>/<cell>": path of result.json} of the cells the tool counts as done, {"<set>/<cell>": why a cell's
    result.json does not count})."""
    if not (root / "cells").is_dir():
        print(f"compare_suites: {root}: no cells/ folder (not a suite output folder)", file=sys.stderr)
        sys.exit(2)
    try:
        status = suite_status(root)
    except SuiteError as e:
        print(f"compare_suites: {e}", file=sys.stderr)
        sys.exit(2)
    found, damaged = {}, {}
    for entry in status["cells"]:
        folder = pathlib.Path(str(entry.get("folder", root / "cells" / str(entry.get("name")))))
        if entry.get("state") == "done":
            found[str(entry["name"])] = folder / "result.json"
        elif entry.get("damage"):
            damaged[str(entry["name"])] = f"{folder / 'result.json'}: {entry['damage']}"
    return found, damaged


def load(path):
    """path's JSON; exits 2 naming the file when it cannot be read or nests too deep (json_input.read_json)."""
    try:
        return read_json(path)
    except (OSError, ValueError) as e:
        print(f"compare_suites: cannot read {path}: {e}", file=sys.stderr)
        sys.exit(2)


def same_number(a, b):
    if isinstance(a, bool) or isinstance(b, bool):
        return a is b
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
            return True
        return a == b
    return a == b  # None, strings: must be identical too


def first_difference(a, b):
    """A description of the first differing compared field of two results, or None."""
    eval_a, eval_b = a.get("eval"), b.get("eval")
    if not isinstance(eval_a, dict) or not isinstance(eval_b, dict):
        return "eval: missing in " + ("A" if not isinstance(eval_a, dict) else "B")
    for key in ("mean_score",):
        if key not in eval_a or key not in eval_b:
            return f"eval.{key}: missing in " + ("A" if key not in eval_a else "B")
        if not same_number(eval_a[key], eval_b[key]):
            return f"eval.{key}: {eval_a[key]!r} != {eval_b[key]!r}"
    tasks_a, tasks_b = eval_a.get("tasks"), eval_b.get("tasks")
    if not isinstance(tasks_a, list) or not isinstance(tasks_b, list):
        return "eval.tasks: missing in " + ("A" if not isinstance(tasks_a, list) else "B")
    if len(tasks_a) != len(tasks_b):
        return f"eval.tasks: {len(tasks_a)} tasks != {len(tasks_b)} tasks"
    for i, (ta, tb) in enumerate(zip(tasks_a, tasks_b)):
        if "task" in ta or "task" in tb:
            if ta.get("task") != tb.get("task"):
                return f"eval.tasks[{i}].task: {ta.get('task')!r} != {tb.get('task')!r}"
        for key in TASK_FIELDS:
            if key not in ta or key not in tb:
                return f"eval.tasks[{i}].{key}: missing in " + ("A" if key not in ta else "B")
            if not same_number(ta[key], tb[key]):
                return f"eval.tasks[{i}].{key}: {ta[key]!r} != {tb[key]!r}"
    return None


def whole_difference(a, b, where=""):
    """The first value of a and b that differs outside VOLATILE_KEYS ("where: a != b"), or None."""
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted((a.keys() | b.keys()) - VOLATILE_KEYS):
            if key not in a or key not in b:
                return f"{where}.{key}: missing in " + ("A" if key not in a else "B")
            found = whole_difference(a[key], b[key], f"{where}.{key}")
            if found:
                return found
        return None
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return f"{where}: {len(a)} items != {len(b)} items"
        for i, (x, y) in enumerate(zip(a, b)):
            found = whole_difference(x, y, f"{where}[{i}]")
            if found:
                return found
        return None
    return None if same_number(a, b) else f"{where}: {a!r} != {b!r}"


def results_csv_difference(root_a, root_b):
    """(rows compared, the first difference or None) of DIR/report/results.csv, time columns aside; (0, None)
    unless both folders have one."""
    paths = [root / "report" / "results.csv" for root in (root_a, root_b)]
    if not all(path.is_file() for path in paths):
        return 0, None
    tables = []
    for path in paths:
        with open(path, newline="", encoding="utf-8") as f:
            rows = list(csv.DictReader(f))
        tables.append([{k: v for k, v in row.items() if k not in VOLATILE_COLUMNS} for row in rows])
    if len(tables[0]) != len(tables[1]):
        return len(tables[0]), f"results.csv: {len(tables[0])} rows != {len(tables[1])} rows"
    for i, (row_a, row_b) in enumerate(zip(*tables)):
        if row_a != row_b:
            key = next(k for k in sorted(row_a.keys() | row_b.keys()) if row_a.get(k) != row_b.get(k))
            return len(tables[0]), f"results.csv row {i + 2} ({row_a.get('cell')}), {key}: {row_a.get(key)!r} != {row_b.get(key)!r}"
    return len(tables[0]), None


def main(argv):
    whole = "--whole" in argv[1:]
    argv = [argv[0]] + [a for a in argv[1:] if a != "--whole"]
    if len(argv) != 3 or argv[1] in ("-h", "--help"):
        print(__doc__.strip(), file=sys.stderr)
        return 2
    root_a, root_b = pathlib.Path(argv[1]), pathlib.Path(argv[2])
    (cells_a, damaged_a), (cells_b, damaged_b) = finished_cells(root_a), finished_cells(root_b)
    only_a = sorted(set(cells_a) - set(cells_b))
    only_b = sorted(set(cells_b) - set(cells_a))
    if only_a or only_b:
        for only, here, there, damaged in ((only_a, root_a, root_b, damaged_b), (only_b, root_b, root_a, damaged_a)):
            if only:
                why = f"; there its result does not count: {damaged[only[0]]}" if only[0] in damaged else ""
                print(f"DIFFER: cell {only[0]} is finished in {here} but not in {there} ({len(only)} such cells){why}")
        return 1
    if not cells_a:
        print(f"compare_suites: no finished cell in {root_a} nor {root_b}: nothing to compare", file=sys.stderr)
        return 2
    for name in sorted(cells_a):
        a, b = load(cells_a[name]), load(cells_b[name])
        diff = whole_difference(a, b) if whole else first_difference(a, b)
        if diff is not None:
            print(f"DIFFER: cell {name}: {diff}")
            return 1
    tasks = sum(len(load(p)["eval"]["tasks"]) for p in cells_a.values())
    rows = 0
    if whole:
        rows, diff = results_csv_difference(root_a, root_b)
        if diff is not None:
            print(f"DIFFER: {diff}")
            return 1
    what = "every value but times, hosts, dates and commits" if whole else "the scores"
    csv_note = f"; report/results.csv: {rows} rows identical" if rows else ""
    print(f"EQUAL: {len(cells_a)} cells ({tasks} task results) identical in {root_a} and {root_b} ({what}){csv_note}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
