#!/usr/bin/python3
"""What the training curves say, per (set, method, demos) group of a suite folder: how far each run's validation BC
loss ends above its best, and for MAPS the selector terms at the end of training (curve.csv logs each term before
its weight). docs/results.md's statements about the curves (section 2d, section 4) are this table's numbers.

    python3 experiments/report/curve_stats.py results/study [--set mt10] [--method maps] [--seeds 0,1,2]

Columns, each the range over the group's seeds (min-max):
- best valid, best step: the lowest validation BC loss and its step;
- end / best: the last validation BC loss over the best; end valid: the last;
- modules in use (MAPS): M / (1 + L_explore) at the last row, the effective number of modules in a batch (L_explore
  is the squared coefficient of variation of the modules' summed scores, so this is (sum u)^2 / sum u^2);
- sparse first -> last (MAPS): the sparse term at the first and the last row.
A cell without a readable curve.csv is listed on stderr and left out."""
import argparse
import csv
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

from suite_results import SuiteError, groups, load_suite  # noqa: E402
from suite_stats import span_fixed  # noqa: E402


def read_rows(cell):
    """curve.csv's rows as dicts of floats; [] when missing, empty or unreadable."""
    try:
        with (cell.folder / "curve.csv").open() as f:
            return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]
    except (OSError, ValueError, TypeError, AttributeError):
        return []


def group_row(key, cells, left_out):
    best, best_step, ratio, end, in_use, sparse = [], [], [], [], [], []
    for cell in cells:
        rows = read_rows(cell)
        if not rows or "validation_bc" not in rows[0]:
            left_out.append(cell.name)
            continue
        at_best = min(rows, key=lambda r: r["validation_bc"])
        best.append(at_best["validation_bc"])
        best_step.append(at_best["step"])
        end.append(rows[-1]["validation_bc"])
        ratio.append(end[-1] / best[-1] if best[-1] > 0 else float("inf"))
        if cell.modules and "explore" in rows[-1]:
            in_use.append(cell.modules / (1.0 + rows[-1]["explore"]))
        if cell.modules and "sparse" in rows[0]:
            sparse.append((rows[0]["sparse"], rows[-1]["sparse"]))
    if not best:
        return None
    return [key.set, key.label, key.demos, len(best), span_fixed(best, 3), span_fixed(best_step, 0),
            span_fixed(ratio, 1), span_fixed(end, 3), span_fixed(in_use, 1) if in_use else "-",
            f"{span_fixed([a for a, _ in sparse], 3)} -> {span_fixed([b for _, b in sparse], 3)}" if sparse else "-"]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dir", help="a suite folder written by `maps suite run`")
    parser.add_argument("--set", help="only this set (e.g. mt10)")
    parser.add_argument("--method", help="only this method, with its variants (e.g. maps)")
    parser.add_argument("--seeds", help="only these seeds, comma-separated (e.g. 0,1,2: the ablations' seeds)")
    args = parser.parse_args(argv)
    seeds = None
    if args.seeds:
        try:
            seeds = {int(s) for s in args.seeds.split(",")}
        except ValueError:
            parser.error(f"--seeds {args.seeds!r}: expected comma-separated integers, e.g. 0,1,2")
    try:
        suite = load_suite(args.dir)
    except SuiteError as e:
        print(f"curve_stats: {e}", file=sys.stderr)
        return 2
    cells = [c for c in suite.cells if (not args.set or c.set == args.set)
             and (not args.method or c.method == args.method) and (seeds is None or c.seed in seeds)]
    if not cells:
        known = sorted({(c.set, c.method) for c in suite.cells})
        print(f"curve_stats: no finished cells in {args.dir} match --set {args.set} --method {args.method}"
              f" --seeds {args.seeds};"
              f" it has (set, method): {known}", file=sys.stderr)
        return 2
    left_out, rows = [], []
    for key, runs in groups(cells).items():
        row = group_row(key, runs, left_out)
        if row:
            rows.append(row)
    header = ["set", "method", "demos", "seeds", "best valid", "best step", "end / best", "end valid",
              "modules in use (end)", "sparse first -> last"]
    print("| " + " | ".join(header) + " |")
    print("|---" * len(header) + "|")
    try:
        for row in rows:
            print("| " + " | ".join(str(v) for v in row) + " |")
    except BrokenPipeError:  # `| head`
        sys.stderr.close()
        return 0
    if left_out:
        print(f"curve_stats: no readable curve.csv, left out: {', '.join(left_out)}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
