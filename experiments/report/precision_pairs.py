#!/usr/bin/python3
"""Issue 44's question, from a suite folder of experiments/suites/precision.json: does training in bfloat16
(train.precision "bf16", the cells of variant bf16) change results against float32 (the base cells) trained on the
same seed and data?

Per (set, method, demonstrations): the mean score of each precision (mean +- 95% t interval over seeds), the paired
difference bf16 - float32 over the seeds both ran, the seeds' spread (the standard deviation of float32's scores
across seeds: how much a result moves with the seed alone), the paired t test's p-value and its Holm adjustment over
all rows, the same for the best validation BC loss (relative difference), and the training CPU time's ratio
float32 / bf16 from each cell's curve.csv (cpu_seconds; the real cells' speed-up, not a benchmark's).

The judgement, stated before the numbers were seen: a row shows "no difference beyond the seeds' spread" when its
Holm-adjusted p is >= 0.05 and its mean difference is smaller in size than the seeds' spread. The overall verdict
holds when every row does.

    python3 experiments/report/precision_pairs.py results/precision [--out results/precision/pairs.md]

A group with fewer than two pairs is listed but not judged; unfinished, failed and damaged cells are listed on
stderr and under "Cells not used"."""
import argparse
import math
import pathlib
import statistics
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

from suite_results import load_suite_or_exit, order, METHOD_ORDER  # noqa: E402
from suite_stats import ci95, fmt_p, holm, mean, paired, paired_p  # noqa: E402

BF16 = "bf16"
ALPHA = 0.05


def is_float32(cell):
    return cell.variant in ("", "base")


def training_cpu_seconds(cell):
    return cell.cpu_seconds_to(cell.steps)


def pm(values, digits=3):
    if not values:
        return "-"
    half = ci95(values)
    text = f"{mean(values):.{digits}f}"
    return text if math.isnan(half) else f"{text} +- {half:.{digits}f}"


def rows_of(cells):
    """One row per (set, method, demos) with both precisions, in the suite's order."""
    by_key = {}
    for cell in cells:
        if is_float32(cell) or cell.variant == BF16:
            by_key.setdefault((cell.set, cell.method, cell.demos), {}).setdefault(
                "float32" if is_float32(cell) else BF16, []).append(cell)
    methods = order(METHOD_ORDER, {key[1] for key in by_key})
    keys = sorted(by_key, key=lambda k: (k[0], methods.index(k[1]), k[2]))
    rows = []
    for key in keys:
        f32 = sorted(by_key[key].get("float32", []), key=lambda c: c.seed)
        b16 = sorted(by_key[key].get(BF16, []), key=lambda c: c.seed)
        diffs = paired(b16, f32, lambda c: c.mean_score)
        f32_by_seed = {c.seed: c for c in f32}
        pairs = [(c, f32_by_seed[c.seed]) for c in b16 if c.seed in f32_by_seed]
        relative_loss = [b.best_validation_bc / a.best_validation_bc - 1 for b, a in pairs
                         if b.best_validation_bc is not None and a.best_validation_bc]
        cpu = []
        for b, a in pairs:
            a_seconds, b_seconds = training_cpu_seconds(a), training_cpu_seconds(b)
            if a_seconds and b_seconds:
                cpu.append(a_seconds / b_seconds)
        spread = statistics.stdev([c.mean_score for c in f32]) if len(f32) >= 2 else float("nan")
        rows.append(dict(set=key[0], method=key[1], demos=key[2], f32=[c.mean_score for c in f32],
                         b16=[c.mean_score for c in b16], diffs=diffs, spread=spread, p=paired_p(diffs),
                         loss_p=paired_p(relative_loss), relative_loss=relative_loss, cpu=cpu))
    for row, adjusted in zip(rows, holm([r["p"] for r in rows])):
        row["holm"] = adjusted
    for row, adjusted in zip(rows, holm([r["loss_p"] for r in rows])):
        row["loss_holm"] = adjusted
    for row in rows:
        judged = len(row["diffs"]) >= 2 and not math.isnan(row["spread"])
        row["judged"] = judged
        row["same"] = judged and row["holm"] >= ALPHA and abs(mean(row["diffs"])) < row["spread"]
    return rows


def table(rows):
    lines = ["| set | method | demos | pairs | float32 score | bf16 score | bf16 - float32 | seeds' spread (sd) "
             "| p | Holm p | within the spread | validation BC, bf16 / float32 - 1 | Holm p (loss) "
             "| training CPU, float32 / bf16 |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        verdict = ("yes" if r["same"] else "NO") if r["judged"] else "not judged (< 2 pairs)"
        spread = "-" if math.isnan(r["spread"]) else f"{r['spread']:.3f}"
        loss = pm([100 * v for v in r["relative_loss"]], 1) + " %" if r["relative_loss"] else "-"
        cpu = pm(r["cpu"], 2) + "x" if r["cpu"] else "-"
        lines.append(f"| {r['set']} | {r['method']} | {r['demos']} | {len(r['diffs'])} | {pm(r['f32'])} "
                     f"| {pm(r['b16'])} | {pm(r['diffs'])} | {spread} | {fmt_p(r['p'])} | {fmt_p(r['holm'])} "
                     f"| {verdict} | {loss} | {fmt_p(r['loss_holm'])} | {cpu} |")
    return "\n".join(lines)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("suite", help="suite folder of experiments/suites/precision.json")
    parser.add_argument("--out", help="also write the markdown here")
    args = parser.parse_args()
    suite = load_suite_or_exit(args.suite, "precision_pairs.py")
    rows = rows_of(suite.cells)
    if not any(r["diffs"] for r in rows):
        print(f"precision_pairs.py: {args.suite}: no (set, method, demos) has float32 and bf16 cells "
              f"(variant '{BF16}')", file=sys.stderr)
        return 2
    judged = [r for r in rows if r["judged"]]
    all_cpu = [v for r in rows for v in r["cpu"]]
    parts = [f"# bfloat16 against float32: {len(rows)} paired groups from {args.suite}", "",
             "Same seed and data in each pair; evaluation in float32 for both. A row is within the seeds' spread "
             "when its Holm-adjusted paired t test gives p >= 0.05 and its mean difference is smaller in size than "
             "the standard deviation of float32's scores across seeds.", "", table(rows), ""]
    different = [r for r in judged if not r["same"]]
    parts.append(f"Verdict: {len(judged) - len(different)} of {len(judged)} judged groups within the seeds' spread"
                 + (": no difference beyond it." if not different and judged else
                    "; beyond it: " + ", ".join(f"{r['set']}/{r['method']}/{r['demos']}" for r in different) + "."))
    if all_cpu:
        parts.append(f"Training CPU time, float32 / bf16, over all {len(all_cpu)} pairs: median "
                     f"{statistics.median(all_cpu):.2f}x (range {min(all_cpu):.2f}-{max(all_cpu):.2f}x).")
    unused = ([f"{name}: not finished" for name in suite.missing] +
              [f"{name}: dropped (no longer in the suite config)" for name in suite.dropped] +
              [f"{name}: failed at {stage}: {error}" for name, stage, error in suite.failed] +
              [f"{path}: damaged: {why}" for path, why in suite.damaged])
    if unused:
        parts += ["", "## Cells not used", ""] + [f"- {u}" for u in unused]
        for u in unused:
            print(f"precision_pairs.py: {u}", file=sys.stderr)
    text = "\n".join(parts) + "\n"
    sys.stdout.write(text)
    if args.out:
        pathlib.Path(args.out).write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
