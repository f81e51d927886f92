#!/usr/bin/python3
"""The report of a suite folder written by `maps suite` (what `maps report DIR [--out OUT]` runs):

    /usr/bin/python3 experiments/report/report.py DIR [OUT]        (OUT defaults to DIR/report)

writes to OUT
- results.csv: one row per finished cell and task;
- report.md: the protocol, the counts of finished / missing / failed cells, the main results, per set the score
  table (per-task mean +- 95% CI over seeds), paired differences from MAPS, MAPS's module usage and routing; the
  comparison with Single BC (Fig. 3), the paper's claims with a verdict each (claims.py), ablations (Fig. 4), the
  module-count sweep (Fig. 5), every variant against its base method and the paper's checkpoint rule beside the
  best-validation one, where those cells exist, and the figures;
- the figures (fig2_scores.png, fig2_tasks_<set>.png, fig3_vs_single_bc.png, fig4_ablations.png,
  fig5_modules_heatmap.png, fig6_module_usage.png, validation.png), each with its numbers in a CSV beside it.
Prints the main results table and, last, "report: OUT/report.md". Exit code 2: no suite.json, no finished cells,
or no matplotlib / numpy; 1: a figure could not be drawn (the rest is written; stderr and report.md say which).
A damaged result.json is named in the report and skipped.

Needs matplotlib and numpy (Debian: python3-matplotlib, python3-numpy)."""
import argparse
import csv
import pathlib
import re
import sys
import traceback

import claims
import suite_results
import tables
from suite_results import SuiteError, load_suite, score_name, success_scored
from routing_summary import routing_summary
from suite_stats import vs_single_bc

OWN_FILES = ["results.csv", "report.md", "fig[2-6]_*.png", "fig[2-6]_*.csv", "validation.png", "validation.csv",
             "zoo_routing.png", "zoo_routing.csv"]
RESULT_COLUMNS = ["set", "method", "variant", "modules", "demos", "subsample", "seed", "task", "score", "success",
                  "success_at_end", "return_mean", "return_unclipped_cost", "best_step", "steps", "wall_seconds",
                  "compute_seconds", "grid", "cell"]


def write_results_csv(suite, path):
    """One row per finished cell and task, sorted by set, method, variant, demos, subsample and seed."""
    cells = sorted(suite.cells, key=lambda c: (suite_results.key_sort(c.key), c.seed))
    with path.open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(RESULT_COLUMNS)
        for c in cells:
            cost = c.compute_seconds()[0]  # reads the cell's curve.csv: once per cell, not per task row
            for t in c.tasks:
                writer.writerow([c.set, c.method, c.variant, "" if c.modules is None else c.modules, c.demos,
                                 c.subsample, c.seed, t.task, t.score, t.success, t.success_at_end, t.return_mean,
                                 t.return_unclipped_cost, c.best_step, c.steps, c.wall_seconds, cost, c.grid, c.name])


def embed(figures):
    lines = []
    for figure in figures:
        lines += ["", f"![]({figure.file})", "", f"*{figure.caption}*"]
    return lines


class Drawer:
    """Draws the figures of `cells` into `out`; a figure that fails is reported (stderr, with its traceback, and
    report.md) rather than ending the report."""

    def __init__(self, figures, cells, out):
        self.figures, self.cells, self.out, self.failed = figures, cells, out, []

    def __call__(self, name):
        try:
            return getattr(self.figures, name)(self.cells, self.out)
        except Exception as error:  # noqa: BLE001 (one figure's failure must not lose the tables)
            traceback.print_exc()
            message = f"{name} could not be drawn ({type(error).__name__}: {error})"
            print(f"report: {message}", file=sys.stderr)
            self.failed.append(message)
            return []


def section(title, body, empty):
    """A report section; `empty` says what is absent when there is nothing to show."""
    return ["", f"## {title}", ""] + (body if body else [empty])


def per_set(suite, make, intro):
    """Each set's table from make(cells) under a heading, after the intro lines (or intro(set name)'s); [] when no set
    has one."""
    lines = []
    for set_name in suite.sets():
        table = make(suite.cells_of(set_name))
        if table:
            lines += [f"### {set_name}", ""] + (intro(set_name) if callable(intro) else intro) + table + [""]
    return lines


ADDED_SEEDS_GRID = re.compile(r"_seeds_\d+(_\d+)*$")  # more_seeds.py's names: <grid>_seeds_3_4, <grid>_seeds_3_4_1


def added_seed_grids(suite, set_name=None):
    """The grids more_seeds.py added (by their names) that have a finished cell on the set (on any set without one),
    from suite.json's plan: a copied result may name another suite's grid."""
    finished = {c.name for c in suite.cells}
    return sorted({str(i.get("grid")) for i in suite.planned if isinstance(i, dict)
                   and ADDED_SEEDS_GRID.search(str(i.get("grid", ""))) and i.get("name") in finished
                   and (set_name is None or i.get("set") == set_name)})


def adaptive_seeds_caveat(suite, set_name):
    """When more_seeds.py added seeds on the set after looking at the first ones, the p values are not the nominal
    ones: say so."""
    added = added_seed_grids(suite, set_name)
    if not added:
        return []
    return [f"Some settings have more seeds than others: grids {', '.join(added)} were added by more_seeds.py after"
            " the first seeds finished, where a difference's interval included 0. Choosing where to add seeds from"
            " the results makes a p below 0.05 more likely than 5% when there is no difference, so read these p"
            " values (Holm too) as indicative, not as nominal tests; a setting that kept its first seeds was tested"
            " once, at the nominal level.", ""]


def report_lines(suite, draw):
    cells = suite.cells
    lines = [f"# Suite report: {suite.root.name}", "", "## Protocol", ""] + tables.protocol(suite)
    lines += ["", "## Cells", ""] + tables.cell_counts(suite)
    lines += section("Main results", ["Mean score over tasks, mean +- 95% CI over seeds:", ""]
                     + tables.main_results(cells) + embed(draw("fig2_scores")), "")

    fig3 = vs_single_bc(cells)
    body = []
    if fig3:
        body = (["Each (set, task, demos) setting both a method and Single BC ran: better / worse by the mean score"
                 " over seeds; better by > 10%: mean score > 1.1 x Single BC's; significantly: paired over the seeds"
                 " both ran, the 95% CI of the difference excludes 0 (never with one seed).", ""]
                + tables.fig3_table(fig3) + embed(draw("fig3_vs_single_bc")))
    lines += section("Fig. 3: against Single BC", body, "No Single BC cells to compare with in this suite.")
    lines += section("The paper's claims", claims.claims_table(cells, tables.table),
                     "No MAPS cells: none of the paper's claims can be checked.")
    added = added_seed_grids(suite)
    if added and any(c.method == "maps" for c in cells):
        lines += ["", "Where a claim's comparisons include seeds that more_seeds.py added after the first seeds"
                  f" ({', '.join(added)}), its p values and so its verdict are indicative, not"
                  " nominal tests: choosing where to add seeds from the results makes a p below 0.05 more likely than"
                  " 5% when there is no difference."]
    if {c.method for c in cells} - set(claims.COMPARED):
        # The zoo's methods: every set's paired differences in one place (the same tables as the sets' sections).
        caveat = lambda set_name: adaptive_seeds_caveat(suite, set_name)  # noqa: E731
        lines += section("Against MAPS, every set", per_set(suite, tables.paired_table, caveat),
                         "Nothing to pair with MAPS (no MAPS cells, or no other cells at the same demos and seeds).")

    task_figures = {f.file: f for f in draw("fig2_tasks")}
    for set_name in suite.sets():
        mine = suite.cells_of(set_name)
        lines += ["", f"## Set {set_name}", "", f"Score: {score_name(set_name, mine)}.", "", "### Scores", ""]
        lines += ["Per task: mean +- 95% CI over seeds; mean: the mean over tasks, per seed, then over seeds; best"
                  " step: the range over seeds of the checkpoint evaluated.", ""] + tables.score_table(mine)
        if success_scored(set_name, mine):
            rules = tables.success_rules_table(mine)
            lines += [""] + rules if rules else []
        paired = tables.paired_table(mine)
        paired = adaptive_seeds_caveat(suite, set_name) + paired if paired else paired
        lines += ["", "### Paired differences from MAPS", ""] + (paired or [
            "Nothing to pair with MAPS (no MAPS cells, or no other cells at the same demos and seeds)."])
        pooling = tables.pooling_table(mine)
        lines += ["", "### Paired differences from Single BC (learning the tasks together against each alone)", ""] + (
            pooling or ["Nothing to pair with Single BC (no Single BC cells, or none at the same demos and seeds)."])
        figure = task_figures.get(f"fig2_tasks_{set_name}.png")
        lines += embed([figure] if figure else [])
        usage = tables.usage_tables(mine)
        lines += ["", "### Module usage and routing (MAPS, and the zoo's methods that route)"] + (
            usage or ["", "No cells with module usage."])

    ablations = per_set(suite, tables.ablation_table, [])
    lines += section("Fig. 4: ablations of the selector terms",
                     ablations + embed(draw("fig4_ablations")) if ablations else [],
                     "No ablation cells in this suite (MAPS with a selector-loss weight of 0).")
    sweep = per_set(suite, tables.sweep_table, ["MAPS's mean score over tasks (mean +- 95% CI over seeds, n seeds) by"
                                                " the number of modules M (from the config):", ""])
    lines += section("Fig. 5: number of modules", sweep + embed(draw("fig5_modules_heatmap")) if sweep else [],
                     "No module-count cells in this suite (MAPS at another M than the base one).")
    controls = per_set(suite, tables.controls_table, [])
    lines += section("Controls: what MAPS's parts are worth", controls,
                     "No control cells in this suite (MAPS with a uniform or task-only selector, a wider MT-BC).")
    variants = per_set(suite, tables.variant_table, [])
    lines += section("Variants against their base (the paper's protocol, controls, ablations, module counts)",
                     variants, "No variant cells beside their base method's in this suite.")
    rule = per_set(suite, tables.checkpoint_rule_table, [])
    lines += section("The paper's checkpoint rule", rule,
                     "No cells kept checkpoints (train.keep_every) to judge by the paper's rule.")
    lines += section("Fig. 6: module usage per task", embed(draw("fig6_module_usage")),
                     "No MAPS cells with module usage in this suite.")
    summary = routing_summary(cells, seeds_added=bool(added))
    zoo = draw("zoo_routing")
    if zoo or summary:
        lines += section("Routing of every method (the zoo)", summary + embed(zoo), "")
    lines += section("Validation curves", embed(draw("validation")), "No validation curves (curve.csv) in this suite.")
    lines += section("Compute", tables.compute_table(cells), "")
    if draw.failed:
        lines += section("Figures that failed", [f"- {message}" for message in draw.failed], "")
    return lines


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("dir", help="the suite folder (holds suite.json and cells/)")
    parser.add_argument("out", nargs="?", help="where to write the report (default: DIR/report)")
    parser.add_argument("--status", help="`maps suite status --json DIR`'s output, which says what each cell is "
                                         "(`maps report` passes it; default: ask the tool)")
    args = parser.parse_args(argv)
    try:
        suite = load_suite(args.dir, args.status)
    except SuiteError as error:
        print(f"report: {error}", file=sys.stderr)
        return 2
    try:
        import figures
    except ImportError as error:
        print(f"report: matplotlib and numpy are needed for the figures ({error}); on Debian: apt-get install"
              " python3-matplotlib python3-numpy", file=sys.stderr)
        return 2
    out = pathlib.Path(args.out) if args.out else pathlib.Path(args.dir) / "report"
    out.mkdir(parents=True, exist_ok=True)
    for pattern in OWN_FILES:  # a figure this suite no longer has must not stay behind from an earlier report
        for stale in out.glob(pattern):
            stale.unlink()
    for path, reason in suite.damaged:
        print(f"report: {path}: damaged result, skipped ({reason})", file=sys.stderr)

    write_results_csv(suite, out / "results.csv")
    draw = Drawer(figures, suite.cells, out)
    (out / "report.md").write_text("\n".join(report_lines(suite, draw)) + "\n")
    print(f"{len(suite.cells)} finished, {len(suite.missing)} missing, {len(suite.failed)} failed,"
          f" {len(suite.damaged)} damaged of {len(suite.planned)} cells\n")
    print("\n".join(tables.main_results(suite.cells)))
    print(f"report: {out / 'report.md'}")
    return 1 if draw.failed else 0


if __name__ == "__main__":
    sys.exit(main())
