#!/usr/bin/python3
"""Tables of a grid's results (experiments/suites/run_grid.sh), in Markdown:
- per method and demo count, each task's score as mean over seeds with a 95% confidence interval (t distribution),
  and the mean over tasks, with the range of best-validation steps;
- where MAPS ran, each method's paired difference from MAPS (same seeds, so the same demonstrations);
- MAPS's per-task module usage (mean selector score over the states of that task's evaluation episodes), and how
  decisively it routes: per-state entropy of the scores and the largest score, and how far each task's usage is
  from the mean usage over tasks (total variation; 0 = every task uses the modules alike), each computed per
  seed before averaging, since module indices mean nothing across seeds.

    /usr/bin/python3 experiments/suites/aggregate.py results/compare-gravity-20k
"""
import math
import statistics
import sys

from grid_results import ci95, cells, load_runs


def fmt(values):
    return f"{statistics.mean(values):.2f} +- {ci95(values):.2f}"


def score_table(by_cell, tasks):
    print("| method | demos | k | seeds | steps | " + " | ".join(tasks) + " | mean | best step |")
    print("|---" * (len(tasks) + 7) + "|")
    for (label, demos, k), runs in sorted(by_cell.items(), key=lambda item: (item[0][1], item[0][2], item[0][0])):
        budgets = sorted({r.config.get("train", {}).get("steps", "?") for r in runs}, key=str)
        row = [label, str(demos), str(k), str(len(runs)), "/".join(map(str, budgets))]
        row += [fmt([r.eval["tasks"][i]["score"] for r in runs]) for i in range(len(tasks))]
        row.append(f"**{fmt([r.eval['mean_score'] for r in runs])}**")
        best = [r.eval["best_step"] for r in runs]
        row.append(f"{min(best)}-{max(best)}" if min(best) != max(best) else str(best[0]))
        print("| " + " | ".join(row) + " |")


def paired_table(by_cell):
    maps = {(d, k): {r.seed: r for r in rs} for (label, d, k), rs in by_cell.items() if label == "maps"}
    has_pairs = any(label != "maps" and (d, k) in maps and any(r.seed in maps[(d, k)] for r in rs)
                    for (label, d, k), rs in by_cell.items())
    if not has_pairs:
        return
    print("\nPaired difference of the mean score, method - MAPS, over the seeds both ran (95% CI; an interval that"
          " excludes 0 is a difference):\n")
    print("| method | demos | k | pairs | difference |")
    print("|---|---|---|---|---|")
    for (label, demos, k), runs in sorted(by_cell.items(), key=lambda item: (item[0][1], item[0][2], item[0][0])):
        if label == "maps" or (demos, k) not in maps:
            continue
        diffs = [r.eval["mean_score"] - maps[(demos, k)][r.seed].eval["mean_score"]
                 for r in runs if r.seed in maps[(demos, k)]]
        if diffs:
            print(f"| {label} | {demos} | {k} | {len(diffs)} | {statistics.mean(diffs):+.2f} +- {ci95(diffs):.2f} |")


def total_variation(p, q):
    return 0.5 * sum(abs(a - b) for a, b in zip(p, q))


def usage_tables(by_cell, tasks):
    for (label, demos, k), runs in sorted(by_cell.items(), key=lambda item: (item[0][1], item[0][2])):
        if runs[0].method != "maps" or "module_usage" not in runs[0].eval["tasks"][0]:
            continue
        modules = len(runs[0].eval["tasks"][0]["module_usage"])
        print(f"\n{label}, {demos} demos, k = {k}, {len(runs)} seeds: module usage (mean selector score over the"
              f" task's evaluation states; seed {runs[0].seed}, then the range over seeds of each task's most"
              f" used module's share)\n")
        print("| task | " + " | ".join(f"m{i}" for i in range(modules)) + " | top module, all seeds |")
        print("|---" * (modules + 2) + "|")
        for i, task in enumerate(tasks):
            usage = runs[0].eval["tasks"][i]["module_usage"]
            tops = [max(r.eval["tasks"][i]["module_usage"]) for r in runs]
            print(f"| {task} | " + " | ".join(f"{u:.2f}" for u in usage) + f" | {min(tops):.2f}-{max(tops):.2f} |")

        # Routing: per seed, then mean +- CI over seeds.
        have_entropy = all("selector_entropy" in t for r in runs for t in r.eval["tasks"])
        print(f"\nRouting ({len(runs)} seeds, mean +- 95% CI over seeds; uniform over {modules} modules: entropy"
              f" {math.log(modules):.2f}, top score {1 / modules:.2f}):\n")
        header = "| task | usage distance from the tasks' mean usage (TV) |"
        if have_entropy:
            header += " per-state entropy (nats) | per-state top score |"
        print(header)
        print("|---" * (header.count("|") - 1) + "|")
        for i, task in enumerate(tasks):
            tv = []
            for r in runs:
                usages = [t["module_usage"] for t in r.eval["tasks"]]
                mean_usage = [statistics.mean(col) for col in zip(*usages)]
                tv.append(total_variation(usages[i], mean_usage))
            row = f"| {task} | {fmt(tv)} |"
            if have_entropy:
                row += f" {fmt([r.eval['tasks'][i]['selector_entropy'] for r in runs])} |"
                row += f" {fmt([r.eval['tasks'][i]['selector_top_score'] for r in runs])} |"
            print(row)


def main(root):
    runs = load_runs(root)
    by_cell = cells(runs)
    tasks = runs[0].tasks
    score_table(by_cell, tasks)
    paired_table(by_cell)
    usage_tables(by_cell, tasks)


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
