#!/usr/bin/python3
"""The final-checkpoint rule beside a suite's headline one: each finished cell's policy after its last training step,
scored by `maps eval --last` (eval.json's "last"), against the same cell's best-validation checkpoint and against the
base method's headline score, paired by seed.

A suite's cells keep no checkpoints in the repository, so the evaluations are made where training left last.ckpt and
kept as files of their own, one per cell, named <set>-<cell>.json (the eval.json of a copy of the cell folder):

    for d in results/zoo-modern/cells/gravity/diffusion_policy-*_d5_s*; do
      t=/tmp/last/$(basename $d); mkdir -p $t; cp $d/config.json $d/best.ckpt $d/last.ckpt $t/
      build/bin/maps eval --run $t --last && cp $t/eval.json results/zoo-modern/last-checkpoint/gravity-$(basename $d).json
    done
    python3 experiments/report/last_step.py results/zoo-modern results/zoo-modern/last-checkpoint

`maps report DIR` writes the same tables to DIR/report/last_step.md where DIR/last-checkpoint/ holds such files, paired
as the suite config's report.last_step_base and report.last_step_against say.

Every file is checked against its cell before it is used: the cell exists and has finished, the file's method, seed and
demonstrations are the cell's, its best-checkpoint score is the cell's headline score (the same checkpoint evaluated on
the same episodes: evaluation is deterministic), each of its tasks is one of the cell's, once, with the cell's score for
that task, and its last step is the cell's last training step. Per (set, method, demonstrations): both rules' mean
scores (mean +- 95% t interval over seeds), last - best validation paired by seed, and last - the base method (its
headline checkpoint) paired by seed, with the paired t test and Holm over each set's rows (each comparison a family);
and the aggregates of the last step's task scores: their IQM and the probability that a base-method run beats a
last-step run on a task. The base method's own cells are not evaluated so (they are what every row is paired with);
with `--base none` every method's may be, and no row is paired with another method. `--against SUITE VARIANT` adds
a table of SUITE's VARIANT cells (trained otherwise: GAIL's) against each row's two rules, paired by seed. Files whose
"last" carries the last step's routing (a policy that routes; maps eval --last since 2026-12-05) add a table of it
beside the best-validation checkpoint's (and SUITE's VARIANT cells', with their usage distance between tasks paired
by seed):

    python3 experiments/report/last_step.py results/adversarial/bc-last results/adversarial/bc-last/last-checkpoint \
        --base none --against results/adversarial gail_mt10"""
import argparse
import math
import pathlib
import sys
import types

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

import numpy as np  # noqa: E402

from aggregates import fmt_improvement, fmt_iqm, runs_by_tasks  # noqa: E402
from suite_results import SuiteError, groups, load_suite, read_json, task_names, task_score  # noqa: E402
from suite_stats import fmt, fmt_p, holm_within, mean, paired_p, usage_distances  # noqa: E402
from tables import table as markdown_table  # noqa: E402

SECTION = "The last step against the best-validation checkpoint"
ROUTING_SECTION = "Routing at the last step"
# The file's best-checkpoint score must be the cell's to this precision (both printed from the same double).
SAME_SCORE = 1e-9


class EvalFileError(Exception):
    pass


def finite(value, where):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise EvalFileError(f"{where} is {value!r}; expected a finite number")
    return float(value)


def read_last(path, cells_by_folder):
    """(cell, last step's mean score, {task: last step's score}, the last step's routing or None) from one `maps eval
    --last` file, checked against its cell."""
    name = path.stem
    set_name, dash, cell_name = name.partition("-")
    if not dash:
        raise EvalFileError(f"{path}: the name is not <set>-<cell>.json")
    cell = cells_by_folder.get((set_name, cell_name))
    if cell is None:
        raise EvalFileError(f"{path}: the suite has no finished cell {set_name}/{cell_name}")
    try:
        record = read_json(path)
    except Exception as e:  # unreadable, not JSON, nested too deep: named, never trusted
        raise EvalFileError(f"{path}: {e}") from e
    if not isinstance(record, dict):
        raise EvalFileError(f"{path}: expected a JSON object (maps eval's eval.json)")
    # The same cell and the same evaluation: identity, the checkpoint's step and the episodes, each of its type.
    for key, expected in (("method", cell.method), ("seed", cell.seed), ("demos_per_task", cell.demos),
                          ("subsample", cell.subsample), ("best_step", cell.best_step), ("episodes", cell.episodes)):
        value = record.get(key)
        if type(value) is not type(expected) or value != expected:
            raise EvalFileError(f"{path}: {key} is {value!r}; cell {set_name}/{cell_name} has {expected!r}")
    best = finite(record.get("mean_score"), f"{path}: mean_score")
    if abs(best - cell.mean_score) > SAME_SCORE:
        raise EvalFileError(f"{path}: best.ckpt scored {best!r} here and {cell.mean_score!r} in the cell's result.json:"
                            " not the same checkpoint or not the same evaluation")
    last = record.get("last")
    if not isinstance(last, dict):
        raise EvalFileError(f"{path}: no \"last\" object (evaluate with maps eval --last)")
    step = last.get("step")
    if type(step) is not int or step != cell.steps:
        raise EvalFileError(f"{path}: last.step is {step!r}; the cell trained {cell.steps} steps")
    score = finite(last.get("mean_score"), f"{path}: last.mean_score")
    scores = last.get("scores")
    if not isinstance(scores, list) or len(scores) != len(cell.tasks):
        raise EvalFileError(f"{path}: last.scores is not a list of {len(cell.tasks)} task scores")
    for i, value in enumerate(scores):
        finite(value, f"{path}: last.scores[{i}]")
    if abs(sum(scores) / len(scores) - score) > 1e-6:
        raise EvalFileError(f"{path}: last.mean_score {score!r} is not the mean of last.scores")
    # last.scores follow the file's tasks by position (maps eval writes both in one order), and the aggregates read
    # them by name: each task must be one of the cell's, once, with the cell's score for it (the same checkpoint on
    # the same episodes), so a renamed, repeated or foreign task is refused.
    tasks = record.get("tasks")
    if not isinstance(tasks, list) or len(tasks) != len(scores):
        raise EvalFileError(f"{path}: tasks is not a list of {len(scores)} tasks, one per last.scores entry")
    names = []
    for i, task in enumerate(tasks):
        name = task.get("task") if isinstance(task, dict) else None
        in_cell = task_score(cell, name) if isinstance(name, str) else None
        if in_cell is None or name in names:
            raise EvalFileError(f"{path}: tasks[{i}] names {name!r}; expected one of the cell's tasks"
                                f" ({', '.join(t.task for t in cell.tasks)}), each once")
        best_here = finite(task.get("score"), f"{path}: tasks[{i}].score")
        if abs(best_here - in_cell) > SAME_SCORE:
            raise EvalFileError(f"{path}: tasks[{i}] ({name}) scored {best_here!r} here and {in_cell!r} in the cell's"
                                " result.json: not the same task or not the same evaluation")
        names.append(name)
    return cell, score, dict(zip(names, scores)), read_routing(path, last, cell)


def read_routing(path, last, cell):
    """last.routing (files of `maps eval --last` since 2026-12-05, for a policy that routes) as routing(): each of the
    cell's tasks once, its usage a distribution over the cell's modules, entropy in [0, ln M], top score in [1/M, 1].
    None where the file has none (an older file, or a policy that does not route)."""
    entries = last.get("routing")
    if entries is None:
        return None
    modules = len(cell.tasks[0].usage or [])
    if not modules:
        raise EvalFileError(f"{path}: last.routing for a cell whose evaluation has no module usage")
    if not isinstance(entries, list) or sorted(str(e.get("task")) if isinstance(e, dict) else "" for e in entries) != \
            sorted(t.task for t in cell.tasks):
        raise EvalFileError(f"{path}: last.routing must hold each of the cell's {len(cell.tasks)} tasks once")
    tasks = []
    for i, entry in enumerate(entries):
        where = f"{path}: last.routing[{i}]"
        usage = entry.get("module_usage")
        if not isinstance(usage, list) or len(usage) != modules:
            raise EvalFileError(f"{where}.module_usage is not a list of {modules} shares")
        usage = [finite(u, f"{where}.module_usage") for u in usage]
        if min(usage) < 0 or abs(sum(usage) - 1.0) > 1e-4:
            raise EvalFileError(f"{where}.module_usage is not a distribution (shares >= 0 summing to 1)")
        entropy = finite(entry.get("selector_entropy"), f"{where}.selector_entropy")
        top = finite(entry.get("selector_top_score"), f"{where}.selector_top_score")
        if not 0.0 <= entropy <= math.log(modules) + 1e-6 or not 1.0 / modules - 1e-6 <= top <= 1.0:
            raise EvalFileError(f"{where}: selector_entropy {entropy} or selector_top_score {top} outside [0, ln"
                                f" {modules}] and [1/{modules}, 1]")
        tasks.append(types.SimpleNamespace(task=entry["task"], usage=usage, entropy=entropy, top_score=top))
    return routing(types.SimpleNamespace(tasks=tasks))


def routing(cell):
    """(per-state selector entropy, top score, usage distance between tasks (TV)), each the mean over the tasks; None
    where a task lacks its entropy or top score (a result.json from before evaluations recorded them), as the mean of
    the others would be another quantity."""
    if any(t.entropy is None or t.top_score is None for t in cell.tasks):
        return None
    return (mean([t.entropy for t in cell.tasks]), mean([t.top_score for t in cell.tasks]),
            mean(usage_distances(cell)))


def rows_of(suite, files, base):
    cells_by_folder = {(c.set, c.folder.name): c for c in suite.cells}
    last_score, last_tasks, last_routing = {}, {}, {}
    for path in files:
        cell, score, per_task, routed = read_last(path, cells_by_folder)
        if base is not None and cell.label == base:
            raise EvalFileError(f"{path}: a cell of {base}, the method every row is paired with at its headline "
                                "checkpoint (evaluate the others)")
        last_score[id(cell)] = score
        last_tasks[id(cell)] = per_task
        if routed is not None:
            last_routing[id(cell)] = routed
    grouped = groups(suite.cells)
    rows = []
    for key, cells in grouped.items():
        with_last = [c for c in cells if id(c) in last_score]
        if not with_last:
            continue
        base_cells = next((g for k, g in grouped.items()
                           if base is not None and k.set == key.set and k.label == base and k.demos == key.demos
                           and k.subsample == key.subsample), [])
        base_by_seed = {c.seed: c.mean_score for c in base_cells}
        tasks = task_names(with_last)
        last_runs = np.asarray([[last_tasks[id(c)][t] for t in tasks] for c in with_last])
        base_runs = runs_by_tasks(base_cells, tasks) if base_cells else None
        rows.append(dict(iqm_text=fmt_iqm(last_runs),
                         improvement_text=fmt_improvement(base_runs, last_runs) if base_runs is not None else "-",
                         set=key.set, method=key.label, demos=key.demos, k=key.subsample,
                         seeds=f"{len(with_last)} of {len(cells)}", seed_list=[c.seed for c in with_last],
                         best=[c.mean_score for c in with_last], last=[last_score[id(c)] for c in with_last],
                         gain=[last_score[id(c)] - c.mean_score for c in with_last],
                         headline_vs_base=[c.mean_score - base_by_seed[c.seed] for c in with_last
                                           if c.seed in base_by_seed],
                         vs_base=[last_score[id(c)] - base_by_seed[c.seed] for c in with_last
                                  if c.seed in base_by_seed],
                         routing={c.seed: (best, last_routing[id(c)]) for c in with_last if id(c) in last_routing
                                  for best in [routing(c)] if best is not None}))
    for row in rows:
        row["gain_p"] = paired_p(row["gain"])
        row["p"] = paired_p(row["vs_base"])
    sets = [r["set"] for r in rows]
    for row, adjusted in zip(rows, holm_within([r["gain_p"] for r in rows], sets)):
        row["gain_holm"] = adjusted
    for row, adjusted in zip(rows, holm_within([r["p"] for r in rows], sets)):
        row["holm"] = adjusted
    return rows


def against_rows(rows, other, variant):
    """Each row's last step and best-validation checkpoint against the cells of `variant` in the suite `other` at the
    same set, method, demos and k (GAIL's, trained otherwise), paired by seed: the differences other - last step and
    other - best validation, the paired t test, Holm over each set's rows (each column a family)."""
    found = []
    for row in rows:
        theirs = {c.seed: c.mean_score for c in other.cells
                  if (c.set, c.method, c.variant, c.demos, c.subsample) == (row["set"], row["method"], variant,
                                                                          row["demos"], row["k"])}
        seeds = [s for s in row["seed_list"] if s in theirs]
        if not seeds:
            continue
        last = dict(zip(row["seed_list"], row["last"]))
        best = dict(zip(row["seed_list"], row["best"]))
        found.append(dict(set=row["set"], method=row["method"], demos=row["demos"], k=row["k"], pairs=len(seeds),
                          other=[theirs[s] for s in seeds], last=[last[s] for s in seeds],
                          best=[best[s] for s in seeds], vs_last=[theirs[s] - last[s] for s in seeds],
                          vs_best=[theirs[s] - best[s] for s in seeds]))
    sets = [r["set"] for r in found]
    for column in ("vs_last", "vs_best"):
        for r in found:
            r[column + "_p"] = paired_p(r[column])
        for r, adjusted in zip(found, holm_within([r[column + "_p"] for r in found], sets)):
            r[column + "_holm"] = adjusted
    return found


def routing_rows(rows, other=None, variant=None):
    """Per row whose files carry the last step's routing: entropy, top score and usage distance between tasks (TV) at
    the best-validation checkpoint and at the last step, per seed; with another suite's variant, its cells' routing at
    the same seeds and variant - last step in TV paired by seed (p: paired t test; Holm over each set's rows)."""
    found = []
    for row in rows:
        if not row["routing"]:
            continue
        seeds = sorted(row["routing"])
        theirs = {}
        if other is not None:
            theirs = {c.seed: measured for c in other.cells
                      if (c.set, c.method, c.variant, c.demos, c.subsample) == (row["set"], row["method"], variant,
                                                                              row["demos"], row["k"]) and c.has_usage
                      for measured in [routing(c)] if measured is not None}
        paired = [s for s in seeds if s in theirs]
        found.append(dict(set=row["set"], method=row["method"], demos=row["demos"], k=row["k"], seeds=len(seeds),
                          best=[row["routing"][s][0] for s in seeds], last=[row["routing"][s][1] for s in seeds],
                          other=[theirs[s] for s in paired],
                          vs_last=[theirs[s][2] - row["routing"][s][1][2] for s in paired]))
    for r in found:
        r["vs_last_p"] = paired_p(r["vs_last"])
    for r, adjusted in zip(found, holm_within([r["vs_last_p"] for r in found], [r["set"] for r in found])):
        r["vs_last_holm"] = adjusted
    return found


def routing_table(found, variant=None):
    column = lambda runs, i: fmt([run[i] for run in runs]) if runs else "-"  # noqa: E731
    header = ["set", "method", "demos", "k", "seeds", "entropy: best validation", "entropy: last step",
              "top score: best validation", "top score: last step", "TV: best validation", "TV: last step"]
    cells = [[r["set"], r["method"], r["demos"], r["k"], r["seeds"], column(r["best"], 0), column(r["last"], 0),
              column(r["best"], 1), column(r["last"], 1), column(r["best"], 2), column(r["last"], 2)] for r in found]
    if variant is not None:
        header += ["pairs", f"entropy: {variant}", f"top score: {variant}", f"TV: {variant}",
                   f"TV: {variant} - last step", "p", "p (Holm)"]
        cells = [row + [len(r["other"]), column(r["other"], 0), column(r["other"], 1), column(r["other"], 2),
                        fmt(r["vs_last"], signed=True) if r["vs_last"] else "-", fmt_p(r["vs_last_p"]),
                        fmt_p(r["vs_last_holm"])] for row, r in zip(cells, found)]
    return "\n".join(markdown_table(header, cells))


def against_table(found, variant):
    return "\n".join(markdown_table(
        ["set", "method", "demos", "k", "pairs", variant, "last step", "best validation", f"{variant} - last step", "p",
         "p (Holm)", f"{variant} - best validation", "p", "p (Holm)"],
        [[r["set"], r["method"], r["demos"], r["k"], r["pairs"], fmt(r["other"]), fmt(r["last"]), fmt(r["best"]),
          fmt(r["vs_last"], signed=True), fmt_p(r["vs_last_p"]), fmt_p(r["vs_last_holm"]),
          fmt(r["vs_best"], signed=True), fmt_p(r["vs_best_p"]), fmt_p(r["vs_best_holm"])] for r in found]))


def table(rows, base):
    """The rows' table; without a base method (base None) its columns of the pairing with one are left out."""
    header = ["set", "method", "demos", "k", "seeds", "best validation", "last step", "last - best validation", "p",
              "p (Holm)"]
    cells = [[r["set"], r["method"], r["demos"], r["k"], r["seeds"], fmt(r["best"]), fmt(r["last"]),
              fmt(r["gain"], signed=True), fmt_p(r["gain_p"]), fmt_p(r["gain_holm"])] for r in rows]
    if base is None:
        return "\n".join(markdown_table(header + ["IQM last step [95% CI]"],
                                         [row + [r["iqm_text"]] for row, r in zip(cells, rows)]))
    header += [f"pairs with {base}", f"best validation - {base}", f"last step - {base}", "p (last)", "p (last, Holm)",
               "IQM last step [95% CI]", f"P({base} > last step) [95% CI]"]
    cells = [row + [len(r["vs_base"]), fmt(r["headline_vs_base"], signed=True) if r["vs_base"] else "-",
                    fmt(r["vs_base"], signed=True) if r["vs_base"] else "-", fmt_p(r["p"]), fmt_p(r["holm"]),
                    r["iqm_text"], r["improvement_text"]] for row, r in zip(cells, rows)]
    return "\n".join(markdown_table(header, cells))


AGAINST_SECTION = "Another objective against both checkpoint rules"


class LastStepError(Exception):
    """What makes the table impossible, said as the script says it (the caller adds its own name)."""


def report_text(suite_name, suite, evals, base, against=None):
    """The markdown of the last-step tables (without the page's title): `suite` loaded from the folder named
    `suite_name`, the evaluations the *.json files of the folder `evals`, `base` the method each row is paired with
    (None: none), `against` (the other suite's name, its loaded suite, a variant) or None. LastStepError when there is
    nothing to tabulate or a file disagrees with its cell."""
    files = sorted(pathlib.Path(evals).glob("*.json"))
    if not files:
        raise LastStepError(f"{evals}: no <set>-<cell>.json files (maps eval --last's eval.json)")
    try:
        rows = rows_of(suite, files, base)
    except EvalFileError as e:
        raise LastStepError(str(e)) from None
    pairing = ""
    if base is not None:
        pairing = (f"; against {base}: each method's seeds paired with {base}'s headline cells (its best-validation"
                   " checkpoint)")
    aggregates = (f", and P({base} > last step), the probability that a {base} run (its headline checkpoint) beats a"
                  f" last-step run on a task, with its interval ('-': no {base} cells at that setting, or one lacking a"
                  " task of the row)" if base is not None else "")
    parts = [
        f"## {SECTION}", "",
        f"{len(files)} cells of {suite_name} scored at their last training step (maps eval --last, the same episodes as"
        " their headline evaluation) beside their best-validation checkpoint (the suite's headline rule), mean +- 95%"
        " CI over seeds (seeds: the group's cells evaluated so, of its finished ones); last - best validation paired"
        f" by seed{pairing}; p: paired t test; Holm over each set's rows, each column a family. The aggregates"
        " (Agarwal et al., NeurIPS 2021; aggregates.py): the interquartile mean of the last step's tasks x runs scores"
        f" with its stratified bootstrap interval{aggregates}.",
        "", table(rows, base), ""]
    other_name, other, variant = against if against is not None else (None, None, None)
    routed = routing_rows(rows, other, variant)
    if routed:
        parts += [f"## {ROUTING_SECTION}", "",
                  "How the policies that route use their modules at the best-validation checkpoint and at the last"
                  " training step, on the same evaluation episodes (maps eval --last's last.routing): per-state"
                  " selector entropy (nats) and top score, mean over tasks, and the usage distance between tasks (TV:"
                  " each task's usage from the tasks' mean, total variation, mean over tasks), mean +- 95% CI over"
                  " seeds" + (f"; {other_name}'s {variant} cells at the same seeds, and {variant} - last step in TV"
                              " paired by seed, p: paired t test, Holm over each set's rows" if other is not None
                              else "") + ".", "", routing_table(routed, variant), ""]
    if against is not None:
        found = against_rows(rows, other, variant)
        if not found:
            raise LastStepError(f"{other_name} has no finished cells of variant {variant!r} at the rows' settings")
        parts += [f"## {AGAINST_SECTION}", "",
                  f"{other_name}'s {variant} cells against these cells at their last step and at their best-validation"
                  " checkpoint, paired by seed (the seeds both ran); mean +- 95% CI over seeds; p: paired t test; Holm"
                  " over each set's rows, each column a family.", "", against_table(found, variant), ""]
    return "\n".join(parts)


def page(suite_name, text):
    """The file the tables are written as: a title naming the suite, then the tables."""
    return f"# The final-checkpoint rule: {suite_name}\n\n{text}"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("suite", help="the suite folder whose cells were evaluated")
    parser.add_argument("evals", help="folder of <set>-<cell>.json files written by maps eval --last")
    parser.add_argument("--base", default="maps",
                        help="the method each row is paired with (default: maps; none: no pairing, every method's"
                             " cells may be evaluated)")
    parser.add_argument("--against", nargs=2, metavar=("SUITE", "VARIANT"),
                        help="also pair each row with SUITE's cells of VARIANT at the same set, method, demos and k,"
                             " by seed (GAIL's against BC's two checkpoint rules: results/adversarial gail_mt10)")
    parser.add_argument("--out", help="also write the markdown here")
    args = parser.parse_args()
    base = None if args.base == "none" else args.base
    try:
        suite = load_suite(args.suite)
        against = (args.against[0], load_suite(args.against[0]), args.against[1]) if args.against else None
        text = report_text(args.suite, suite, args.evals, base, against)
    except (SuiteError, LastStepError) as e:
        print(f"last_step.py: {e}", file=sys.stderr)
        return 2
    print(text)
    if args.out:
        pathlib.Path(args.out).write_text(page(args.suite, text))
    return 0


if __name__ == "__main__":
    sys.exit(main())
