#!/usr/bin/python3
"""Checks that two suite output folders hold the same results, number for number.

    /usr/bin/python3 experiments/cluster/compare_suites.py DIR_A DIR_B

DIR_A and DIR_B are `maps suite run --out` (or `maps suite merge --out`) folders. Their finished cells
(DIR/cells/<set>/<cell>/result.json) must be the same set of <set>/<cell> names, and for every cell the
"eval" object's "mean_score" and, for every task i, "tasks"[i]["score"], "return_mean" and "success_rate"
must be exactly equal (runs are deterministic: a sharded run merged must equal a single-process run). Wall
times, hosts and timestamps are not compared. A task's name ("task"), where present, must match too, so
that the i-th tasks are the same task.

Exit 0 when equal (prints the number of cells compared), 1 at the first difference (names the cell and the
field), 2 when a folder or a result cannot be read or holds no finished cell. Standard library only.
"""
import json
import math
import pathlib
import sys

TASK_FIELDS = ("score", "return_mean", "success_rate")
MAX_JSON_DEPTH = 64  # the C++ reader's limit (io/json_input.cpp); no result.json nests deeper


def finished_cells(root):
    """{"<set>/<cell>": path of result.json} for every result.json under root/cells."""
    cells_dir = root / "cells"
    if not cells_dir.is_dir():
        print(f"compare_suites: {root}: no cells/ folder (not a suite output folder)", file=sys.stderr)
        sys.exit(2)
    found = {}
    for result in sorted(cells_dir.glob("*/*/result.json")):
        found[f"{result.parent.parent.name}/{result.parent.name}"] = result
    return found


def load(path):
    """path's JSON; exits 2 naming the file when it cannot be read or nests past MAX_JSON_DEPTH levels (json
    recurses once a level: a deep enough file would otherwise end in a RecursionError traceback)."""
    too_deep = (f"compare_suites: {path} nests JSON deeper than {MAX_JSON_DEPTH} levels (arrays and objects inside "
                f"each other); no input of this tool nests so deep")
    try:
        with open(path, encoding="utf-8") as f:
            value = json.load(f)
    except (OSError, ValueError) as e:
        print(f"compare_suites: cannot read {path}: {e}", file=sys.stderr)
        sys.exit(2)
    except RecursionError:
        print(too_deep, file=sys.stderr)
        sys.exit(2)
    # Iterative: the check must not recurse on the depth it is there to bound.
    stack = [(value, 1)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, (dict, list)):
            if depth > MAX_JSON_DEPTH:
                print(too_deep, file=sys.stderr)
                sys.exit(2)
            stack.extend((child, depth + 1) for child in (item.values() if isinstance(item, dict) else item))
    return value


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


def main(argv):
    if len(argv) != 3 or argv[1] in ("-h", "--help"):
        print(__doc__.strip(), file=sys.stderr)
        return 2
    root_a, root_b = pathlib.Path(argv[1]), pathlib.Path(argv[2])
    cells_a, cells_b = finished_cells(root_a), finished_cells(root_b)
    only_a = sorted(set(cells_a) - set(cells_b))
    only_b = sorted(set(cells_b) - set(cells_a))
    if only_a or only_b:
        if only_a:
            print(f"DIFFER: cell {only_a[0]} is finished in {root_a} but not in {root_b}"
                  f" ({len(only_a)} such cells)")
        if only_b:
            print(f"DIFFER: cell {only_b[0]} is finished in {root_b} but not in {root_a}"
                  f" ({len(only_b)} such cells)")
        return 1
    if not cells_a:
        print(f"compare_suites: no finished cell in {root_a} nor {root_b}: nothing to compare", file=sys.stderr)
        return 2
    for name in sorted(cells_a):
        diff = first_difference(load(cells_a[name]), load(cells_b[name]))
        if diff is not None:
            print(f"DIFFER: cell {name}: {diff}")
            return 1
    tasks = sum(len(load(p)["eval"]["tasks"]) for p in cells_a.values())
    print(f"EQUAL: {len(cells_a)} cells ({tasks} task results) identical in {root_a} and {root_b}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
