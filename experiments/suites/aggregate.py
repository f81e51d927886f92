#!/usr/bin/python3
"""Tables of a grid's results (experiments/suites/run_grid.sh): per method and demo count, each task's score as
mean over seeds with a 95% confidence interval (t distribution), and the mean over tasks; where MAPS ran, each
method's paired difference from MAPS (same seeds, so the same demonstrations) and MAPS's per-task module usage.

    /usr/bin/python3 experiments/suites/aggregate.py results/gate-gravity
"""
import json
import math
import pathlib
import statistics
import sys

T95 = {1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571, 6: 2.447, 7: 2.365, 8: 2.306, 9: 2.262, 10: 2.228}


def ci(values):
    if len(values) < 2:
        return float("nan")
    return T95.get(len(values) - 1, 1.96) * statistics.stdev(values) / math.sqrt(len(values))


def main(root):
    cells = {}
    for path in sorted(pathlib.Path(root).glob("*/eval.json")):
        result = json.loads(path.read_text())
        key = (result["method"], result["demos_per_task"], result["subsample"])
        cells.setdefault(key, []).append(result)
    if not cells:
        sys.exit(f"aggregate: no */eval.json under {root}")
    tasks = [t["task"] for t in next(iter(cells.values()))[0]["tasks"]]
    print("| method | demos | k | seeds | " + " | ".join(tasks) + " | mean |")
    print("|---" * (len(tasks) + 5) + "|")
    for (method, demos, k), results in sorted(cells.items()):
        row = [method, str(demos), str(k), str(len(results))]
        for i in range(len(tasks)):
            scores = [r["tasks"][i]["score"] for r in results]
            row.append(f"{statistics.mean(scores):.2f} +- {ci(scores):.2f}")
        means = [r["mean_score"] for r in results]
        row.append(f"**{statistics.mean(means):.2f} +- {ci(means):.2f}**")
        print("| " + " | ".join(row) + " |")

    maps_cells = {(d, k): {r["seed"]: r for r in rs} for (m, d, k), rs in cells.items() if m == "maps"}
    if maps_cells:
        print("\nPaired difference of the mean score, method - MAPS, over the seeds both ran (95% CI):\n")
        print("| method | demos | k | pairs | difference |")
        print("|---|---|---|---|---|")
        for (method, demos, k), results in sorted(cells.items()):
            if method == "maps" or (demos, k) not in maps_cells:
                continue
            diffs = [r["mean_score"] - maps_cells[(demos, k)][r["seed"]]["mean_score"]
                     for r in results if r["seed"] in maps_cells[(demos, k)]]
            if diffs:
                print(f"| {method} | {demos} | {k} | {len(diffs)} | {statistics.mean(diffs):+.2f} +- {ci(diffs):.2f} |")
        print("\nMAPS module usage: mean selector score of each module over the states of each task's evaluation"
              " episodes, averaged over seeds:\n")
        for (demos, k), by_seed in sorted(maps_cells.items()):
            runs = list(by_seed.values())
            modules = len(runs[0]["tasks"][0].get("module_usage", []))
            if not modules:
                continue
            print(f"{demos} demos, k = {k}, {len(runs)} seeds:\n")
            print("| task | " + " | ".join(f"m{i}" for i in range(modules)) + " |")
            print("|---" * (modules + 1) + "|")
            for i, task in enumerate(tasks):
                usage = [statistics.mean(r["tasks"][i]["module_usage"][j] for r in runs) for j in range(modules)]
                print(f"| {task} | " + " | ".join(f"{u:.2f}" for u in usage) + " |")
            print()


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "results/gate-gravity")
