#!/usr/bin/python3
"""Issue 17's results from a suite folder of experiments/suites/transfer.json (or any suite with holdout and
new_task grids): per (set, new task, method, demonstrations of the new task) the new task's score, mean +- 95% t
interval over seeds; paired differences of transfer from each other method, and summed up across the tasks (per set
and over all: how often above and below, the mean, how many with p < 0.05 before and after Holm); the training cost
(the best-validation step and the training CPU seconds to reach it, from curve.csv; transfer's source run beside;
per task and summed up per set and method; and the CPU-hours of the whole folder, as maps report's Compute);
and which modules the new task picks: per seed its most used ones next to its named neighbour's in the source run,
and how far its usage is (total variation) from the neighbour's, from every other trained task's and from the trained
tasks' mean; per count how often the neighbour is the nearest trained task against chance.

    python3 experiments/report/transfer_table.py results/transfer --out results/transfer/report

writes OUT/transfer.md (the tables) and OUT/transfer_scores.png (score against demonstrations, per task). A
damaged or stale result, a new-task cell whose evaluation lacks the new task, a transfer cell whose source is not
a finished cell, and a transfer the module comparison cannot use are listed under "Cells left out" (and on stderr);
failed and unfinished cells under "Cells not finished"; cells run a second time (a source whose checkpoint was gone,
with the transfers from it) beside their earlier results under "Cells run twice"; nothing is dropped silently."""
import argparse
import math
import pathlib
import statistics
import sys
from collections import namedtuple

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

from suite_results import (SuiteError, display_label, load_suite, order, read_cell, METHOD_ORDER,  # noqa: E402
                           method_of_label as base_of)
from suite_stats import ci95, fmt, fmt_p, holm, mean, paired, paired_p, total_variation  # noqa: E402
from tables import compute_table, machines_line  # noqa: E402

# The trained task each new task is nearest to (its neighbour in the set's parameter, or its counterpart).
NEIGHBOUR = {"gravity/0.5": "gravity/0.75", "gravity/1.5": "gravity/1.25", "modified/big_foot": "modified/original",
             "modified/small_thigh": "modified/original", "mt10/drawer-open": "mt10/drawer-close",
             "mt10/window-close": "mt10/window-open"}
NAMES = {"transfer": "MAPS transfer", "single_bc": "Single BC (new task alone)", "mt_bc": "MT-BC (all tasks)",
         "maps": "MAPS from scratch (all tasks)", "mt_mh_bc": "MT-MH-BC (all tasks)", "maml": "MAML (all tasks)"}


def new_task_of(cell):
    """The new task of a new_task cell (variant "...new-<task>", the task's own demo count in data.task_demos)."""
    demos = cell.config.get("data", {}).get("task_demos", {})
    if len(demos) != 1:
        return None
    task = next(iter(demos))
    return task if cell.variant.endswith("new-" + task.rsplit("/", 1)[-1]) else None


def label_of(cell, task):
    """What a cell's row is called: its method, with the variant it ran under when a grid gave one (a new_task cell's
    variant is "[<variant>-]new-<task>"): "transfer", "transfer (tuned)"."""
    prefix = cell.variant[:-len("new-" + short(task))].rstrip("-")
    return f"{cell.method} ({prefix})" if prefix else cell.method


def name_of(label):
    return display_label(label, NAMES)


def ordered(labels):
    """Transfer's rows first (the plain one, then its variants), then the other methods in the report's order, each
    method's variants after it."""
    labels = set(labels)
    bases = order(METHOD_ORDER, {base_of(label) for label in labels})
    bases = (["transfer"] if "transfer" in bases else []) + [b for b in bases if b != "transfer"]
    return [label for b in bases for label in sorted(l for l in labels if base_of(l) == b)]


def source_of(cell, by_folder):
    """The holdout cell a transfer cell started from (its init.run, a sibling folder), or None."""
    run = cell.config.get("init", {}).get("run", "")
    if not run:
        return None
    return by_folder.get(cell.set + "/" + pathlib.PurePosixPath(run).name)


def score_of(cell, task):
    for t in cell.tasks:
        if t.task == task:
            return t.score
    return None


def top_modules(usage, count=3):
    ranked = sorted(range(len(usage)), key=lambda m: -usage[m])[:count]
    return ", ".join(f"m{m} ({usage[m]:.2f})" for m in ranked)


def short(task):
    return task.rsplit("/", 1)[-1]


def seconds_text(value):
    """Seconds at a precision that keeps a short transfer's few seconds readable."""
    return f"{value:.1f}" if value < 10 else f"{value:.0f}"


def mean_of(values):
    """Mean of the values that are known, and how many there were; "-" when none."""
    known = [v for v in values if v is not None]
    return (seconds_text(mean(known)) + ("" if len(known) == len(values) else f" ({len(known)} of {len(values)})")
            if known else "-")


def steps_text(steps):
    """The median best step and the range over seeds: a mean would blend seeds that kept the start (step 0) with
    trained ones."""
    median = statistics.median(steps)
    return f"{median:.0f}" + (f" ({min(steps)}-{max(steps)})" if min(steps) != max(steps) else "")


def seeds_text(seeds):
    return ", ".join(str(s) for s in sorted(seeds))


def not_finished_lines(suite):
    """Failed cells with their error; unfinished ones (no result, no error) counted per grid, named when few."""
    lines = []
    if suite.failed:
        lines += [f"{len(suite.failed)} failed (a rerun of the suite retries them):", ""]
        lines += [f"- `{name}`: {stage}: {message}" for name, stage, message in sorted(suite.failed)]
        lines.append("")
    if suite.missing:
        grid_of = {ident.get("name"): ident.get("grid", "-") for ident in suite.planned if isinstance(ident, dict)}
        by_grid = {}
        for name in suite.missing:
            by_grid.setdefault(grid_of.get(name, "-"), []).append(name)
        lines += [f"{len(suite.missing)} not run or still running (no result.json, no error.json):", ""]
        for grid, names in sorted(by_grid.items()):
            lines.append(f"- grid {grid}: {len(names)}" + (": " + ", ".join(f"`{n}`" for n in sorted(names))
                                                          if len(names) <= 10 else ""))
        lines.append("")
    if suite.dropped:
        lines += [f"{len(suite.dropped)} dropped (in suite.json, no longer in the suite config, never finished).", ""]
    return lines


# One transfer cell's routing against its source run: kept_start (best step 0), usage (the new task's),
# neighbour_usage (in the source run), distance (TV to each trained task), to_center (TV to the trained tasks' mean
# usage), between (the trained tasks' TV from one another, every pair).
ModuleRow = namedtuple("ModuleRow", "cell kept_start usage neighbour_usage distance to_center between")


def module_rows(cells, task, neighbour, by_folder, left_out):
    """A ModuleRow per transfer cell of one (method, count). Cells that cannot be compared go to left_out with the
    reason."""
    rows = []
    for cell in cells:
        mine = next((t.usage for t in cell.tasks if t.task == task), None)
        source = source_of(cell, by_folder)
        trained = {t.task: t.usage for t in source.tasks if t.usage} if source else {}
        if not mine:
            left_out.append((str(cell.folder), "its evaluation has no module usage for the new task: left out of the "
                             "module comparison"))
            continue
        if source is None:
            continue  # already named: its source is not a finished cell
        if neighbour not in trained:
            left_out.append((str(cell.folder), f"its source run has no module usage for the neighbour {neighbour}: "
                             "left out of the module comparison"))
            continue
        if any(len(u) != len(mine) for u in trained.values()):
            left_out.append((str(cell.folder), f"its usage is over {len(mine)} modules, its source run's over"
                             f" {len(trained[neighbour])}: left out of the module comparison"))
            continue
        center = [statistics.mean(column) for column in zip(*trained.values())]
        distance = {t: total_variation(mine, u) for t, u in trained.items()}
        between = [total_variation(trained[a], trained[b]) for i, a in enumerate(sorted(trained))
                   for b in sorted(trained)[i + 1:]]
        rows.append(ModuleRow(cell, cell.best_step == 0, mine, trained[neighbour], distance,
                              total_variation(mine, center), between))
    return rows


def earlier_results(suite):
    """Every result.json kept in a finished cell's replaced/ folder (a cell run again), as the tool judged it
    (suite.replaced): (path, cell) or, for one that does not count as an earlier run of the cell, (path, why)."""
    out = []
    for path, damage in sorted(suite.replaced, key=lambda r: str(r[0])):
        if damage:
            out.append((path, damage))
            continue
        try:
            out.append((path, read_cell(path)))
        except (OSError, ValueError, KeyError, TypeError, AttributeError, IndexError) as e:
            out.append((path, f"{type(e).__name__}: {e}"))
    return out


def rerun_lines(suite, earlier, left_out):
    """Cells run a second time (a source whose checkpoint was gone while transfers from it were left, with those
    transfers: experiments/suite/folder.h, retire_sources_without_checkpoint): each earlier result, kept in the cell's
    replaced/ folder, beside the result counted above, and how far they differ. Earlier results that cannot be
    compared go to left_out with the reason; those of cells not finished again yet are listed."""
    finished = {cell.folder.resolve(): cell for cell in suite.cells}
    pairs, waiting = [], []
    for path, old in earlier:
        folder = path.parent.parent.parent
        name = f"{folder.parent.name}/{folder.name}"
        if isinstance(old, str):
            left_out.append((str(path), f"an earlier result of the cell that does not count ({old}): not compared"))
            continue
        new = finished.get(folder.resolve())
        if new is None and (folder / "result.json").exists():
            left_out.append((str(path), "an earlier result of a cell whose current result is left out (below): not "
                             "compared"))
        elif new is None:
            waiting.append((name, path.parent.name))
        elif rerun_score(old) is None or rerun_score(new) is None:
            left_out.append((str(path), f"an earlier result without a score for {new_task_of(new)}: not compared"))
        else:
            pairs.append((old, new))
    if not pairs and not waiting:
        return []

    lines = ["## Cells run twice", "",
             "The results keep each cell's result.json and curve.csv, not its checkpoints. A source run whose "
             "best.ckpt was gone while transfers from it were left ran again, and so did every transfer that had "
             "started from it, so that all of a seed's transfers start from one run of the source; the tables above "
             "count the second runs, and the first results stay in each cell's `replaced/` folder. The same run "
             "config and seed on another CPU (or GEMM kernel) need not give the same floating-point sums, so the "
             "two runs measure how much a result moves with that alone. Score: the source's mean over its trained "
             "tasks, a transfer's the new task's.", ""]
    if pairs:
        lines += ["| cell | CPU (first; second) | best step | best validation loss | score |", "|---|---|---|---|---|"]
    for old, new in sorted(pairs, key=lambda p: (p[1].method != "maps", p[1].name)):
        lines.append(f"| `{new.name}` | {cpu_model(old)}; {cpu_model(new)} | {old.best_step} -> {new.best_step} | "
                     f"{best_loss(old):.6g} -> {best_loss(new):.6g} | "
                     f"{rerun_score(old):.2f} -> {rerun_score(new):.2f} |")
    sources = [(o, n) for o, n in pairs if n.method == "maps"]
    transfers = [(o, n) for o, n in pairs if n.method == "transfer"]
    lines.append("")
    if sources:
        same = sum(o.best_step == n.best_step for o, n in sources)
        rel = [abs(best_loss(n) - best_loss(o)) / best_loss(o) for o, n in sources
               if best_loss(o) > 0 and math.isfinite(best_loss(n))]
        moved = [abs(rerun_score(n) - rerun_score(o)) for o, n in sources]
        loss = (f"the best validation loss moved by a median {statistics.median(rel):.2g} of itself (at most "
                f"{max(rel):.2g})" if rel else "no best validation loss to compare")
        lines.append(f"Source runs: {len(sources)} run twice; the same best step in {same}; {loss}; the score by a "
                     f"median {statistics.median(moved):.3f} (at most {max(moved):.3f}).")
    if transfers:
        moved = [rerun_score(n) - rerun_score(o) for o, n in transfers]
        same = sum(o.best_step == n.best_step for o, n in transfers)
        lines.append(f"Transfers: {len(transfers)} run twice; the same best step in {same}; the new task's score "
                     f"moved by a median {statistics.median([abs(m) for m in moved]):.3f} (at most "
                     f"{max(abs(m) for m in moved):.3f}; mean change {mean(moved):+.3f}).")
    if waiting:
        lines += ["", f"Not finished again yet ({len(waiting)}; their earlier results are not counted above): " +
                  ", ".join(f"`{name}` (first finished {stamp})" for name, stamp in waiting) + "."]
    return lines + [""]


Difference = namedtuple("Difference", "transfer method set task demos diffs p p_holm")


def across_lines(across):
    """The paired differences of each transfer arm from each method summed up over the tasks, per set and over all:
    how often the transfer is above or below, the mean difference, how many differ at p < 0.05 before and after Holm
    (within each task, as in its table), and how wide a difference's 95% interval is (median half-width)."""
    if not across:
        return []
    lines = ["## Across the tasks", "",
             "Each transfer arm's paired differences from each method (the rows of the tasks' tables above, one per "
             "task and count), summed up per set and over every task the method ran on: above and below count the "
             "differences whose mean is at least 0.005 either way (\"even\": it rounds to 0.00); the mean of the "
             "mean differences; how many have p < 0.05, unadjusted and after Holm (within each task, as in its "
             "table; the tuned transfer against the frozen one is not adjusted); the median half-width of a "
             "difference's 95% t interval (range). A transfer far below the all-task methods would show as most "
             "differences below with small p; differences within noise as p near chance (1 in 20 unadjusted).", "",
             "| transfer | method | tasks | differences | above | below | even | mean difference | p < 0.05 | "
             "p (Holm) < 0.05 | 95% interval half-width, median (range) |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    pairs = []
    for d in across:
        if (d.transfer, d.method) not in pairs:
            pairs.append((d.transfer, d.method))
    noted = []
    for transfer, method in pairs:
        of_pair = [d for d in across if (d.transfer, d.method) == (transfer, method)]
        sets = sorted({d.set for d in of_pair})
        for scope in sets + (["all"] if len(sets) > 1 else []):
            group = [d for d in of_pair if scope in ("all", d.set)]
            means = [mean(d.diffs) for d in group]
            halves = [ci95(d.diffs) for d in group if len(d.diffs) > 1 and not math.isnan(ci95(d.diffs))]
            tasks_in = sorted({d.task for d in group})
            adjusted = [d.p_holm for d in group if d.p_holm is not None]
            lines.append(
                f"| {name_of(transfer)} | {name_of(method)} | {scope} ({len(tasks_in)}) | {len(group)} | "
                f"{sum(m >= 0.005 for m in means)} | {sum(m <= -0.005 for m in means)} | "
                f"{sum(abs(m) < 0.005 for m in means)} | {mean(means):+.2f} | "
                f"{sum(d.p is not None and d.p < 0.05 for d in group)} | "
                + (f"{sum(p < 0.05 for p in adjusted)}" if adjusted else "(not adjusted)") + " | "
                + (f"{statistics.median(halves):.2f} ({min(halves):.2f}-{max(halves):.2f})" if halves else "-")
                + " |")
        noted += [d for d in of_pair if d.p is not None and d.p < 0.05]
    if noted:
        lines += ["", "The differences with p < 0.05 (unadjusted; Holm's in brackets):", ""]
        lines += [f"- {name_of(d.transfer)} - {name_of(d.method)}, {d.task} at {d.demos}: {fmt(d.diffs, signed=True)}, "
                  f"p {fmt_p(d.p)}" + (f" ({fmt_p(d.p_holm)})" if d.p_holm is not None else "") for d in noted]
    return lines + [""]


Cost = namedtuple("Cost", "set method model best_step to_best training cpu")
SOURCE = "source"  # the Cost.method of a transfer's source run (MAPS without the new task)


def cost_lines(costs):
    """The training cost summed up per set and method over the new tasks, counts and seeds: the best-validation step
    and the seconds to reach it and of the whole training (medians: a transfer that kept its start costs nothing to
    its best step), with each transfer source run once beside; a row per CPU model, as seconds are a machine's."""
    if not costs:
        return []
    lines = ["## Training cost across the tasks", "",
             "Per set and method, over its new tasks, every count and seed (the tasks' cost tables above, cell by "
             "cell): the best-validation step, the seconds of training to reach it and of the whole training, median "
             "(range), one thread; CPU seconds from curve.csv where every cell of a task has them, else wall seconds "
             "(said in the row); a row per CPU model the cells ran on, as one machine's second is not another's. The "
             "source run a transfer starts from (MAPS on the set without the new task) is listed once per seed and "
             "new task: it serves every count and both transfer arms.", "",
             "| set | method | CPU | cells | best step | seconds to the best step | training seconds |",
             "|---|---|---|---|---|---|---|"]

    def spread(values):
        known = [v for v in values if v is not None]
        if not known:
            return "-"
        text = seconds_text(statistics.median(known))
        if min(known) != max(known):
            text += f" ({seconds_text(min(known))}-{seconds_text(max(known))})"
        return text + ("" if len(known) == len(values) else f" ({len(known)} of {len(values)} known)")

    for set_name in sorted({c.set for c in costs}):
        methods = ordered({c.method for c in costs if c.set == set_name and c.method != SOURCE})
        for method in methods + ([SOURCE] if any(c.set == set_name and c.method == SOURCE for c in costs) else []):
            name = "MAPS without the new task (transfer's source)" if method == SOURCE else name_of(method)
            for model in sorted({c.model for c in costs if (c.set, c.method) == (set_name, method)}):
                group = [c for c in costs if (c.set, c.method, c.model) == (set_name, method, model)]
                wall = sum(not c.cpu for c in group)
                lines.append(f"| {set_name} | {name} | {model} | {len(group)} | "
                             f"{steps_text([c.best_step for c in group])} | {spread([c.to_best for c in group])} | "
                             f"{spread([c.training for c in group])}"
                             + (f" ({wall} of {len(group)} wall seconds)" if wall else "") + " |")
    return lines + [""]


def cpu_model(cell):
    """The CPU model(s) a cell's result names ("not recorded" when none)."""
    return " + ".join(cell.cpus) if cell.cpus else "not recorded"


def compute_lines(suite, earlier):
    """What the whole suite folder cost (tables.compute_table, as maps report's Compute): every finished cell of any
    grid, and the earlier results kept in replaced/ (first runs of cells run again) apart."""
    lines = ["## Compute", "", "The finished cells, every grid:", ""] + compute_table(suite.cells) + [""]
    replaced = [cell for _, cell in earlier if not isinstance(cell, str)]
    if replaced:
        lines += ["The earlier results of cells run twice (`replaced/`, not counted in the tables above; an unreadable "
                  "one is named under \"Cells run twice\"):", ""] + compute_table(replaced) + [""]
    return lines


def rerun_score(cell):
    """What the cells-run-twice comparison scores: a new-task cell's score on its new task, else its mean."""
    task = new_task_of(cell)
    return score_of(cell, task) if task else cell.mean_score


def best_loss(cell):
    """The best validation loss a result.json recorded (the curve's minimum where the summary predates the key)."""
    if cell.best_validation_bc is not None:
        return cell.best_validation_bc
    losses = cell.curve()[1]
    return min(losses) if losses else float("nan")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("suite", help="a suite folder (maps suite run C.json --out DIR)")
    parser.add_argument("--out", help="where to write transfer.md and the figure (default: SUITE/report)")
    args = parser.parse_args()
    try:
        suite = load_suite(args.suite)
    except SuiteError as e:
        sys.exit(f"transfer_table: {e}")
    out = pathlib.Path(args.out or pathlib.Path(args.suite) / "report")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        sys.exit(f"transfer_table: --out {out}: cannot make the folder ({e.strerror})")

    rows = {}  # (set, task, method, demos) -> [cells]
    left_out = [(str(path), reason) for path, reason in suite.damaged]  # what the tables do not count, and why
    by_folder = {cell.name: cell for cell in suite.cells}
    for cell in suite.cells:
        task = new_task_of(cell)
        if task is None:
            continue
        if score_of(cell, task) is None:
            left_out.append((str(cell.folder), f"its evaluation has no score for the new task {task}"))
        else:
            if cell.method == "transfer" and source_of(cell, by_folder) is None:
                left_out.append((str(cell.folder), "its score counts, but its source run (init.run) is not a finished "
                                 "cell of the suite: the source's cost and module usage leave it out"))
            rows.setdefault((cell.set, task, label_of(cell, task), cell.demos), []).append(cell)
    if not rows:
        sys.exit(f"transfer_table: {args.suite} has no finished new-task cells (grids with new_task)")

    lines = ["# Transfer: a new task from few demonstrations", "",
             f"Suite folder `{args.suite}`. The new task's score (HalfCheetah: return / the mean return of all of the "
             "new task's demonstrations in the demo file, not only the ones trained on, floored at 0; MT10: success at "
             "any step), mean +- 95% t interval over seeds, (n) seeds.", ""]
    tasks = sorted({(s, t) for s, t, _, _ in rows})
    figure_data = {}
    across = []  # every paired difference of a transfer from another method, for the summary across the tasks
    costs = []  # every counted cell's training cost, and each transfer source's once, for the summary per set
    for set_name, task in tasks:
        methods = ordered({m for s, t, m, _ in rows if (s, t) == (set_name, task)})
        counts = sorted({d for s, t, _, d in rows if (s, t) == (set_name, task)})
        lines += [f"## {task}", "",
                  "| method | " + " | ".join(f"{d} demo{'s' if d != 1 else ''}" for d in counts) + " |",
                  "|---|" + "---|" * len(counts)]
        for method in methods:
            cells_at = [rows.get((set_name, task, method, d), []) for d in counts]
            lines.append(f"| {name_of(method)} | " + " | ".join(
                fmt([score_of(c, task) for c in cells]) + f" ({len(cells)})" if cells else "-" for cells in cells_at)
                + " |")
            figure_data[(task, method)] = [(d, [score_of(c, task) for c in cells]) for d, cells in zip(counts, cells_at)
                                           if cells]
        for d in counts:
            seeds = {m: {c.seed for c in rows.get((set_name, task, m, d), [])} for m in methods}
            if len({frozenset(v) for v in seeds.values()}) > 1:
                lines += ["", f"At {d} demonstration{'s' if d != 1 else ''} the methods ran different seeds ("
                          + "; ".join(f"{name_of(m)}: {seeds_text(v) or 'none'}" for m, v in seeds.items())
                          + "): the means above are over different seeds; the paired differences below use the seeds "
                          "both ran."]
        transfers = [m for m in methods if base_of(m) == "transfer"]
        lines += ["", "Paired differences, transfer - method, over the seeds both ran (p: paired t test; Holm over "
                      "one transfer's comparisons with the other methods of this task; the tuned transfer against the "
                      "frozen one is not adjusted, and nothing is adjusted across the two families; p 0.000 where "
                      "every pair differs by the same amount, which a t test cannot weigh):", "",
                  "| transfer | method | demos | pairs | difference | p | p (Holm) |", "|---|---|---|---|---|---|---|"]
        for transfer in transfers:
            comparisons = []
            for method in (m for m in methods if m not in transfers):
                for d in counts:
                    diffs = paired(rows.get((set_name, task, transfer, d), []),
                                   rows.get((set_name, task, method, d), []), lambda c: score_of(c, task))
                    comparisons.append((method, d, diffs, paired_p(diffs)))
            adjusted = holm([p for *_, p in comparisons])
            for (method, d, diffs, p), p_holm in zip(comparisons, adjusted):
                if diffs:
                    across.append(Difference(transfer, method, set_name, task, d, diffs, p, p_holm))
                    lines.append(f"| {name_of(transfer)} | {name_of(method)} | {d} | {len(diffs)} | "
                                 f"{fmt(diffs, signed=True)} | {fmt_p(p)} | {fmt_p(p_holm)} |")
        for transfer in transfers[1:]:
            for d in counts:
                diffs = paired(rows.get((set_name, task, transfer, d), []),
                               rows.get((set_name, task, transfers[0], d), []), lambda c: score_of(c, task))
                if diffs:
                    across.append(Difference(transfer, transfers[0], set_name, task, d, diffs, paired_p(diffs), None))
                    lines.append(f"| {name_of(transfer)} | {name_of(transfers[0])} | {d} | {len(diffs)} | "
                                 f"{fmt(diffs, signed=True)} | {fmt_p(paired_p(diffs))} | (not adjusted) |")
        every = [c for m in methods for d in counts for c in rows.get((set_name, task, m, d), [])]
        sources = (source_of(c, by_folder) for c in every if c.method == "transfer")
        # One source serves a seed's transfers at every count: each cell once.
        every += list({s.folder: s for s in sources if s}.values())
        cpu = bool(every) and all(c.cpu_seconds_to(c.steps) is not None for c in every)
        clock = (lambda c, step: c.cpu_seconds_to(step)) if cpu else (lambda c, step: c.training_seconds_to(step))
        unit = "CPU seconds" if cpu else "seconds"
        lines += ["", machines_line(every)]
        lines += ["", "Training cost: the best-validation step (median over seeds, range), the mean "
                      f"{unit} of training to reach it and of the whole training (" + ("curve.csv's CPU time per validation window, which other work "
                      "on the cores does not inflate" if cpu else "curve.csv's speed per validation window, wall "
                      "time: inflated when other work shared the cores") + "; validation included, evaluation not; "
                      "a resumed run counts the attempt that wrote each kept row), one thread; \"kept the start\": the "
                      "seeds whose best checkpoint is the starting policy (step 0: training on the new task's "
                      "demonstrations never beat it on validation; only a transfer starts from a policy):", "",
                  f"| method | demos | best step | kept the start | {unit} to the best step | training {unit} |",
                  "|---|---|---|---|---|---|"]
        def cost_of(c, method):  # each cell's curve read once for this table and the summary across the tasks
            return Cost(set_name, method, cpu_model(c), c.best_step, clock(c, c.best_step), clock(c, c.steps), cpu)

        for method in methods:
            for d in counts:
                cells = rows.get((set_name, task, method, d), [])
                if cells:
                    kept = (f"{sum(c.best_step == 0 for c in cells)} of {len(cells)}"
                            if base_of(method) == "transfer" else "-")
                    row_costs = [cost_of(c, method) for c in cells]
                    costs += row_costs
                    lines.append(f"| {name_of(method)} | {d} | {steps_text([c.best_step for c in cells])} | {kept} | "
                                 f"{mean_of([c.to_best for c in row_costs])} | "
                                 f"{mean_of([c.training for c in row_costs])} |")
        held = list({id(c): c for c in (source_of(cell, by_folder) for m in transfers for d in counts
                                           for cell in rows.get((set_name, task, m, d), [])) if c}.values())
        held_costs = [cost_of(c, SOURCE) for c in held]
        costs += held_costs
        if held:
            lines += ["", f"MAPS transfer starts from a run without {short(task)} ({len(held)} seeds, the other tasks "
                          f"at {held[0].demos} demonstrations): best step {steps_text([c.best_step for c in held])}, "
                          f"{mean_of([c.to_best for c in held_costs])} {unit} to it, "
                          f"{mean_of([c.training for c in held_costs])} of training; one such run per "
                          "seed serves every count of the new task."]
        neighbour = NEIGHBOUR.get(task)
        if neighbour is None and transfers:
            left_out.append((f"{set_name}/{task}", "no neighbour is named for this task (NEIGHBOUR in "
                             "transfer_table.py): no module comparison"))
        per_seed, summary = [], []
        for method, d in ((m, d) for m in transfers for d in counts):
            if neighbour is None:
                break
            compared = module_rows(rows.get((set_name, task, method, d), []), task, neighbour, by_folder, left_out)
            for r in sorted(compared, key=lambda r: r.cell.seed):
                nearest = min(r.distance, key=r.distance.get)
                others = [v for t, v in r.distance.items() if t != neighbour]
                per_seed.append(
                    f"| {name_of(method)} | {d} | {r.cell.seed}{' (start)' if r.kept_start else ''} | "
                    f"{top_modules(r.usage)} | {top_modules(r.neighbour_usage)} | {r.distance[neighbour]:.2f} | "
                    + (f"{min(others):.2f}-{max(others):.2f}" if others else "-")
                    + f" | {r.to_center:.2f} | {short(nearest)} ({r.distance[nearest]:.2f}) |")
            trained_rows = [r for r in compared if not r.kept_start]
            if compared:
                nearest_is_neighbour = sum(min(r.distance, key=r.distance.get) == neighbour for r in trained_rows)
                others_median = [statistics.median([v for t, v in r.distance.items() if t != neighbour])
                                 for r in trained_rows if len(r.distance) > 1]
                between = [statistics.median(r.between) for r in trained_rows if r.between]
                chance = len(compared[0].distance)
                summary.append(
                    f"| {name_of(method)} | {d} | {len(trained_rows)} of {len(compared)} | "
                    + (f"{nearest_is_neighbour} of {len(trained_rows)} (chance 1/{chance}) | "
                       f"{mean([r.distance[neighbour] for r in trained_rows]):.2f} | "
                       + (f"{mean(others_median):.2f}" if others_median else "-") + " | "
                       f"{mean([r.to_center for r in trained_rows]):.2f} | "
                       + (f"{mean(between):.2f}" if between else "-")
                       if trained_rows else "- | - | - | - | -") + " |")
        if summary:
            lines += ["", f"Modules: does the new task route like its neighbour {neighbour}? Total-variation distance "
                          "(TV: 0 the same mixture of modules, 1 none in common) of the new task's module usage after "
                          "transfer from each trained task's usage in the source run (the same modules: the numbering "
                          "is the source run's). The new task's selector column starts as the mean of the trained "
                          "tasks' columns, so a seed whose best checkpoint is the start (step 0) shows that starting "
                          "point, not a choice: those seeds are left out of this summary (means over the rest). For "
                          "scale: TV to the trained tasks' mean usage, and the trained tasks' TV from one another in "
                          "the source run (median over pairs). Chance is 1 over the number of trained tasks.", "",
                      "| method | demos | seeds trained | neighbour is the nearest task | TV to the neighbour | TV to "
                      "the other tasks (median) | TV to the tasks' mean | TV between trained tasks |",
                      "|---|---|---|---|---|---|---|---|"]
            lines += summary
            lines += ["", "Per seed: the new task's three most used modules and the neighbour's in the source run; "
                          "\"(start)\": the seed kept the starting policy.", "",
                      "| method | demos | seed | new task | neighbour in the source run | TV to the neighbour | "
                      "TV to the others | TV to the tasks' mean | nearest trained task (TV) |",
                      "|---|---|---|---|---|---|---|---|---|"]
            lines += per_seed
        lines.append("")
    lines += across_lines(across)
    earlier = earlier_results(suite)
    lines += cost_lines(costs)
    lines += compute_lines(suite, earlier)
    lines += rerun_lines(suite, earlier, left_out)
    unfinished = not_finished_lines(suite)
    if unfinished:
        lines += ["## Cells not finished", "", "The tables above count finished cells only.", ""] + unfinished
    if left_out:
        lines += ["## Cells left out", "", f"{len(left_out)} result(s) not counted above, or counted in part:", ""]
        lines += [f"- `{path}`: {reason}" for path, reason in left_out]
        lines.append("")
        for path, reason in left_out:
            print(f"transfer_table: left out {path}: {reason}", file=sys.stderr)
    (out / "transfer.md").write_text("\n".join(lines) + "\n")
    draw(figure_data, tasks, out / "transfer_scores.png")
    print(f"transfer_table: {out / 'transfer.md'}, {out / 'transfer_scores.png'}")


def draw(data, tasks, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from suite_stats import ci95
    colours = {"transfer": "tab:cyan", "maps": "tab:blue", "single_bc": "tab:green", "mt_bc": "m",
               "mt_mh_bc": "tab:red", "maml": "tab:orange"}
    columns = min(2, len(tasks))
    rows = math.ceil(len(tasks) / columns)
    fig, axes = plt.subplots(rows, columns, figsize=(6 * columns, 3.4 * rows + 0.8), squeeze=False)
    handles = {}
    for ax, (set_name, task) in zip(axes.flat, tasks):
        series = [(method, points) for (t, method), points in data.items() if t == task and points]
        counts = sorted({d for _, points in series for d, _ in points})
        for k, (method, points) in enumerate(series):
            # Side by side around each count (the x axis is logarithmic), so that the bars do not hide one another.
            shift = 1.035 ** (k - (len(series) - 1) / 2)
            xs = [d * shift for d, _ in points]
            ys = [mean(v) for _, v in points]
            half = [0.0 if math.isnan(ci95(v)) else ci95(v) for _, v in points]
            # A score is never below 0 (Cheetah's is floored there) and an MT10 success rate never above 1: the bars
            # stop at those bounds. Cheetah scores are not capped at 1 (return over the demonstrations' mean return).
            top = 1.0 if set_name == "mt10" else math.inf
            err = [[y - max(0.0, y - h) for y, h in zip(ys, half)], [min(top, y + h) - y for y, h in zip(ys, half)]]
            transfer = base_of(method) == "transfer"
            line = ax.errorbar(xs, ys, yerr=err, marker="o" if transfer else "s", capsize=3, markersize=5,
                               linestyle="-" if transfer else "--",
                               color=colours.get(method, "tab:olive" if transfer else None))
            handles.setdefault(name_of(method), line)
        ax.set(title=task, xlabel="demonstrations of the new task", ylabel="new task's score")
        ax.set_xscale("log")
        ax.set_xticks(counts, [str(c) for c in counts])
        ax.minorticks_off()
        ax.set_ylim(bottom=0, top=max(1.05, ax.get_ylim()[1]))
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(tasks):]:
        ax.axis("off")
    fig.suptitle("Transfer to a held-out task: mean over seeds, bars the 95% t interval (cut at the score's bounds)")
    fig.legend(list(handles.values()), list(handles.keys()), loc="lower center", ncol=min(5, len(handles)),
               fontsize=9, frameon=False)
    fig.tight_layout(rect=(0, 0.8 / (3.4 * rows + 0.8), 1, 1))
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    main()
