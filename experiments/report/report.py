#!/usr/bin/python3
"""The report of a suite folder written by `maps suite` (what `maps report DIR [--out OUT]` runs):

    /usr/bin/python3 experiments/report/report.py DIR [OUT] [--study DIR2 | --no-study]   (OUT defaults to DIR/report)

writes to OUT
- results.csv: one row per finished cell and task;
- report.md: the protocol, the counts of finished / missing / failed cells, the main results, per set the score
  table (per-task mean +- 95% CI over seeds), paired differences from MAPS, MAPS's module usage and routing; the
  comparison with Single BC (Fig. 3), the paper's claims with a verdict each (claims.py), ablations (Fig. 4), the
  module-count sweep (Fig. 5), every variant against its base method and the paper's checkpoint rule beside the
  best-validation one, where those cells exist, and the figures;
- the figures (fig2_scores.png, fig2_tasks_<set>.png, fig3_vs_single_bc.png, fig4_ablations.png,
  fig5_modules_heatmap.png, fig6_module_usage.png, validation.png), each with its numbers in a CSV beside it;
- last_step.md, where DIR/last-checkpoint/ holds `maps eval --last` files of its cells: the last training step against
  the best-validation checkpoint (last_step.py), paired as the suite config's report.last_step_base and
  report.last_step_against say.
A quick-scale suite (trained at most a quarter of the committed study's steps: scripts/run.sh's quick.json, medium.json)
ranks the methods otherwise than the study does, so its report says so in its first line and puts beside each number
of its main table, and in Fig. 2 and Fig. 4's scores, the study's for the same set, method and demos (results/study of
this checkout, or --study DIR2; where there is none, one line says why and the report goes on without it).
Prints the main results table and, last, "report: OUT/report.md". Exit code 2: no suite.json, no finished cells,
no matplotlib / numpy, or last_step.md cannot be made (a file of last-checkpoint/ disagrees with its cell, or the suite
report.last_step_against names cannot be read: report.md is written, stderr names the file); 1: a figure could not
be drawn (the rest is written; stderr and report.md say which).
A damaged result.json is named in the report and skipped.

Needs matplotlib and numpy (Debian: python3-matplotlib, python3-numpy)."""
import argparse
import csv
import functools
import os
import pathlib
import re
import sys
import traceback
from collections import Counter
from dataclasses import dataclass, field

import aggregates
import claims
import comparisons
import imitation
import last_step
import suite_results
import tables
from suite_results import SET_ORDER, SuiteError, groups, load_suite, read_json, score_name, success_scored
from routing_summary import routing_summary
from suite_stats import describe_n, fmt, vs_single_bc

OWN_FILES = ["results.csv", "report.md", "fig[2-6]_*.png", "fig[2-6]_*.csv", "validation.png", "validation.csv",
             "zoo_routing.png", "zoo_routing.csv", "imitation_scores.png", "imitation_scores.csv", "gail_curves.png",
             "gail_curves.csv", "gail_module_usage.png", "gail_module_usage.csv", "last_step.md"]
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
    report.md) rather than ending the report. Keyword arguments go to the figure's function."""

    def __init__(self, figures, cells, out):
        self.figures, self.cells, self.out, self.failed = figures, cells, out, []

    def __call__(self, name, **extra):
        try:
            return getattr(self.figures, name)(self.cells, self.out, **extra)
        except Exception as error:  # noqa: BLE001 (one figure's failure must not lose the tables)
            traceback.print_exc()
            message = f"{name} could not be drawn ({type(error).__name__}: {error})"
            print(f"report: {message}", file=sys.stderr)
            self.failed.append(message)
            return []


# The committed study (docs/results.md) whose numbers stand beside a quick-scale suite's: results/study of the checkout
# this script is in. Installed (share/maps/experiments/report) there is none: the comparison is then skipped with one
# line saying why.
DEFAULT_STUDY = pathlib.Path(__file__).resolve().parents[2] / "results" / "study"
STUDY_STEPS = 20000  # the study's training steps (docs/results.md), when its suite.json cannot say
# The rule (issue 43): a suite is quick-scale when its longest-trained finished cell trained at most a quarter of the
# study's steps (the most common in the study's suite.json). At such budgets every method is still improving and they
# rank otherwise than at the study's (at 1000 steps MAPS leads every baseline on the cheetah sets by far; at 20000 it
# is level with MT-BC). A quarter takes in tiny.json (60 steps), quick.json (1000) and medium.json (5000), and leaves
# out the paper-scale suites (20000-30000), the study itself among them. Decided from the cells' own run configs, so a
# suite needs no key saying so.
QUICK_SHARE = 0.25


@dataclass
class Beside:
    """The study beside a suite: whether the suite is quick-scale (quick; longest: its longest training, steps: the
    study's), the study's cells comparable with the suite's (cells, grouped in groups; none when skipped) and, when
    a quick-scale suite has no study beside it, why (note)."""
    quick: bool = False
    longest: int = 0
    steps: int = STUDY_STEPS
    root: pathlib.Path = None
    cells: list = field(default_factory=list)
    groups: dict = field(default_factory=dict)
    note: str = ""


def planned_steps(root):
    """The training steps of the study at root: the most common among its suite.json's cells' run configs; None when
    it cannot say (no suite.json, an unreadable one)."""
    try:
        planned = read_json(root / "suite.json").get("cells", [])
        steps = Counter(int(c["request"]["train"]["steps"]) for c in planned if isinstance(c, dict) and "request" in c)
    except (OSError, ValueError, AttributeError, TypeError, KeyError):
        return None
    return steps.most_common(1)[0][0] if steps else None


def comparable(suite, study):
    """The study's cells whose label means the same as in the suite: the base methods, and variants both configs
    define alike (a variant named alike but defined otherwise is not the same cell)."""
    here, there = suite.config.get("variants") or {}, study.config.get("variants") or {}
    return [c for c in study.cells if c.label == c.method or here.get(c.variant) == there.get(c.variant)]


def beside_study(suite, study_dir=None, wanted=True):
    """The Beside of a suite: the study at study_dir (default DEFAULT_STUDY) when the suite is quick-scale (QUICK_SHARE)
    and wanted. A study that is not there or cannot be read leaves a note, never an error."""
    root = pathlib.Path(study_dir) if study_dir else DEFAULT_STUDY
    steps = planned_steps(root) or STUDY_STEPS
    # A GAIL cell's steps are its iterations, not training steps: the rule reads the BC cells alone, and a suite of
    # GAIL cells only is not quick-scale.
    trained = [c.steps for c in suite.cells if imitation.objective(c) == "bc"]
    if not trained:
        return Beside(False, 0, steps, root)
    longest = max(trained)
    beside = Beside(longest <= QUICK_SHARE * steps, longest, steps, root)
    if not beside.quick:
        return beside
    if not wanted:
        beside.note = "the report was made with --no-study"
    elif not (root / "suite.json").is_file():
        beside.note = f"no study at {root} (no suite.json there" + (
            "; outside a checkout the report scripts have no results/, and --study DIR names one)"
            if root == DEFAULT_STUDY else ")")
    elif root.resolve() == suite.root.resolve():
        beside.note = f"{root} is the suite reported"
    else:
        order = list(SET_ORDER)  # load_suite fills it in from the study's status: keep the suite's
        try:
            study = load_suite(root)
        except SuiteError as error:
            beside.note = f"the study at {root} could not be read ({error})"
        else:
            beside.cells = comparable(suite, study)
            beside.groups = groups(beside.cells)
        SET_ORDER[:] = order
    beside.note = " ".join(beside.note.split())  # one line
    return beside


def study_number(key, study_groups):
    """(the study's runs, their demos) for a (set, label, demos, k) key: at the same demos, else at the nearest count
    the study ran (ties: the larger); None where the study has no such method on the set at that k."""
    same = [k for k in study_groups if (k.set, k.label, k.subsample) == (key.set, key.label, key.subsample)]
    if not same:
        return None
    nearest = min(same, key=lambda k: (abs(k.demos - key.demos), -k.demos))
    return study_groups[nearest], nearest.demos


def study_text(key, study_groups):
    """"0.83 +- 0.09 (n=5)", "0.62 +- 0.05 (n=5, at 14 demos)", or "-"."""
    found = study_number(key, study_groups)
    if not found:
        return "-"
    runs, demos = found
    return f"{fmt([c.mean_score for c in runs])} (n={len(runs)}{'' if demos == key.demos else f', at {demos} demos'})"


def matched(cells, beside):
    """The study's cells that stand beside some number of `cells`' main table."""
    found = [study_number(key, beside.groups) for key in groups(cells)]
    return list({c.folder: c for runs, _ in filter(None, found) for c in runs}.values())


def main_results_beside(cells, beside):
    """tables.main_results with the study's number beside each."""
    theirs = matched(cells, beside)
    protocol = (f"{'/'.join(str(s) for s in sorted({c.steps for c in theirs}))} steps,"
                f" {'/'.join(str(e) for e in sorted({c.episodes for c in theirs}))} episodes") if theirs else "none"
    rows = [[key.set, key.label, key.demos, key.subsample, len(runs), fmt([c.mean_score for c in runs]),
             study_text(key, beside.groups)] for key, runs in groups(cells).items()]
    return tables.table(["set", "method", "demos", "k", "seeds", "mean score over tasks", f"study ({protocol})"], rows)


def warning_line(beside):
    """The report's first line for a quick-scale suite."""
    return (f"**The quick scale checks the pipeline, not the ranking**: this suite trained {beside.longest} steps, the"
            f" study {beside.steps}, and at so few steps the methods rank otherwise than there; see results/study"
            " (docs/results.md) for the ranking.")


def study_protocol(cells, beside):
    """The header's line on the study beside the numbers: per set, its n, episodes, steps and demo counts."""
    theirs = matched(cells, beside)
    sets = suite_results.order(SET_ORDER, {c.set for c in theirs})
    per_set = "; ".join(f"{s}: {describe_n([c for c in theirs if c.set == s])}, demos per task"
                        f" {', '.join(str(d) for d in sorted({c.demos for c in beside.cells if c.set == s}))}"
                        for s in sets)
    shown = "`results/study`, docs/results.md" if beside.root == DEFAULT_STUDY else f"`{beside.root}`"
    return [f"- **The study beside these numbers** ({shown}; the same set, method and demos,"
            f" else its nearest count, named): {per_set or 'no cell of this suite is in it'}."]


def section(title, body, empty):
    """A report section; `empty` says what is absent when there is nothing to show."""
    return ["", f"## {title}", ""] + (body if body else [empty])


def holm_families(suite):
    """The suite config's report.holm ("variant" when it says none; `maps suite` has checked the value)."""
    report = suite.config.get("report") or {}
    return report.get("holm", "variant") if isinstance(report, dict) else "variant"


def check_report_config(suite):
    """suite.json's report settings, read from a file that may come from elsewhere: SuiteError naming the key and what
    was expected (`maps suite` checks them in a config it plans, but not in a suite.json edited since)."""
    report = suite.config.get("report")
    where = f"{suite.root / 'suite.json'}: config.report"
    if report is None:
        return
    if not isinstance(report, dict):
        raise SuiteError(f"{where}: expected an object, got {report!r}")
    if report.get("holm", "variant") not in ("variant", "set"):
        raise SuiteError(f"{where}.holm: expected \"variant\" or \"set\", got {report.get('holm')!r}")
    compare = report.get("compare", [])
    if not isinstance(compare, list) or not all(isinstance(entry, str) for entry in compare):
        raise SuiteError(f"{where}.compare: expected a list of \"A - B\" strings, got {compare!r}")
    for i, entry in enumerate(compare):
        try:
            comparisons.parse(entry)
        except ValueError as error:
            raise SuiteError(f"{where}.compare[{i}]: {str(error).partition(': ')[2]}") from None
    base = report.get("last_step_base", "maps")
    if not isinstance(base, str) or not base:
        raise SuiteError(f"{where}.last_step_base: expected a method's name or \"none\", got {base!r}")
    against = report.get("last_step_against", [])
    if not (isinstance(against, list) and len(against) in (0, 2) and all(isinstance(e, str) and e for e in against)):
        raise SuiteError(f"{where}.last_step_against: expected [] or [SUITE, VARIANT] (two non-empty strings), got"
                         f" {against!r}")


def report_comparisons(suite):
    """The suite config's report.compare ("A - B" entries; [] when it names none)."""
    report = suite.config.get("report") or {}
    return list(report.get("compare", [])) if isinstance(report, dict) else []


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


def imitation_section(cells, draw):
    """GAIL against BC (imitation.py, imitation_figures.py), for a suite with cells trained by GAIL."""
    import imitation_figures
    figures = Drawer(imitation_figures, cells, draw.out)
    body = (["### Scores", ""] + (imitation.objective_table(cells) or ["No GAIL cell has a BC cell of the same"
                                                                        " setting and seed to pair with."])
            + embed(figures("imitation_scores")) + embed(figures("gail_curves")))
    against = imitation.maps_table(cells)
    body += ["", "### MAPS against the others under each objective", ""] + (
        against or ["No MAPS cells, or no other method at the same settings."])
    speed = imitation.speed_table(cells)
    body += ["", "### How fast each method learns under GAIL", ""] + (
        speed or ["No GAIL cell with a learning curve (curve.csv) to read."])
    routing = imitation.routing_table(cells)
    body += ["", "### MAPS's routing under each objective", ""] + (
        routing or ["No MAPS cells with module usage under both objectives."]) + embed(figures("gail_module_usage"))
    draw.failed += figures.failed
    return section("Imitation objective: GAIL against BC", body, "")


def report_lines(suite, draw, beside=None):
    cells = suite.cells
    beside = beside or Beside()
    holm = holm_families(suite)
    caveat = functools.partial(adaptive_seeds_caveat, suite)  # heads each set's paired tables
    lines = [f"# Suite report: {suite.root.name}", ""]
    if beside.quick:
        lines += [warning_line(beside), ""]
        if beside.note:
            lines += [f"(The study's numbers are not beside this suite's: {beside.note}.)", ""]
    lines += ["## Protocol", ""] + tables.protocol(suite)
    if beside.cells:
        lines += [""] + study_protocol(cells, beside)
    lines += ["", "## Cells", ""] + tables.cell_counts(suite)
    if beside.cells:
        main = (["Mean score over tasks, mean +- 95% CI over seeds; beside it the study's for the same set, method and"
                 " demos (mean +- 95% CI over its n seeds; where the study did not run this count, at its nearest"
                 " count, named; ties: the larger):", ""] + main_results_beside(cells, beside)
                + embed(draw("fig2_scores", study=beside.cells, variants_are_methods=holm == "set")))
    else:
        main = ["Mean score over tasks, mean +- 95% CI over seeds:", ""] + tables.main_results(cells) + embed(
            draw("fig2_scores", variants_are_methods=holm == "set"))
    lines += section("Main results", main, "")

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
    if imitation.has_gail(cells):
        lines += imitation_section(cells, draw)
    if {c.method for c in cells} - set(claims.COMPARED):
        # The zoo's methods: every set's paired differences in one place (the same tables as the sets' sections).
        lines += section("Against MAPS, every set", per_set(suite, lambda c: tables.paired_table(c, holm), caveat),
                         "Nothing to pair with MAPS (no MAPS cells, or no other cells at the same demos and seeds).")

    compare = report_comparisons(suite)
    if compare:
        lines += section("Chosen comparisons (report.compare)",
                         per_set(suite, lambda c: comparisons.compare_table(c, compare), caveat),
                         "No entry of report.compare has both its rows at the same demos, k and seeds.")

    lines += section("Aggregate statistics: IQM and probability of improvement",
                     per_set(suite, aggregates.aggregate_table, []), "No cells with a score for every task.")

    task_figures = {f.file: f for f in draw("fig2_tasks", variants_are_methods=holm == "set")}
    for set_name in suite.sets():
        mine = suite.cells_of(set_name)
        lines += ["", f"## Set {set_name}", "", f"Score: {score_name(set_name, mine)}.", "", "### Scores", ""]
        lines += ["Per task: mean +- 95% CI over seeds; mean: the mean over tasks, per seed, then over seeds; best"
                  " step: the range over seeds of the checkpoint evaluated.", ""] + tables.score_table(mine)
        if success_scored(set_name, mine):
            rules = tables.success_rules_table(mine)
            lines += [""] + rules if rules else []
        paired = tables.paired_table(mine, holm)
        paired = caveat(set_name) + paired if paired else paired
        lines += ["", "### Paired differences from MAPS", ""] + (paired or [
            "Nothing to pair with MAPS (no MAPS cells, or no other cells at the same demos and seeds)."])
        pooling = tables.pooling_table(mine)
        lines += ["", "### Paired differences from Single BC (learning the tasks together against each alone)", ""] + (
            pooling or ["Nothing to pair with Single BC (no Single BC cells, or none at the same demos and seeds)."])
        figure = task_figures.get(f"fig2_tasks_{set_name}.png")
        lines += embed([figure] if figure else [])
        usage = tables.usage_tables(mine, holm == "set")
        lines += ["", "### Module usage and routing (MAPS, and the zoo's methods that route)"] + (
            usage or ["", "No cells with module usage."])

    ablations = per_set(suite, tables.ablation_table, [])
    fig4 = (draw("fig4_ablations", study=beside.cells) if beside.cells else draw("fig4_ablations")) if ablations else []
    lines += section("Fig. 4: ablations of the selector terms",
                     ablations + embed(fig4) if ablations else [],
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
    rule = per_set(suite, tables.checkpoint_rule_table, caveat)
    lines += section("The paper's checkpoint rule", rule,
                     "No cells kept checkpoints (train.keep_every) to judge by the paper's rule.")
    lines += section("Fig. 6: module usage per task", embed(draw("fig6_module_usage")),
                     "No MAPS cells with module usage in this suite.")
    summary = routing_summary(cells, seeds_added=bool(added), variants_are_methods=holm == "set")
    zoo = draw("zoo_routing", variants_are_methods=holm == "set")
    if zoo or summary:
        lines += section("Routing of every method (the zoo)", summary + embed(zoo), "")
    lines += section("Validation curves", embed(draw("validation")) + embed(draw("denoising_validation")),
                     "No validation curves (curve.csv) in this suite.")
    lines += section("Compute", tables.compute_table(cells), "")
    if draw.failed:
        lines += section("Figures that failed", [f"- {message}" for message in draw.failed], "")
    return lines


def write_last_step(suite, root, out):
    """OUT/last_step.md, the last-step tables of last_step.py, when the suite folder holds `maps eval --last` files of
    its cells in last-checkpoint/ (last_step.py says how they are made): each row paired with the suite config's
    report.last_step_base (default maps; none: no pairing) and, with report.last_step_against [SUITE, VARIANT] (SUITE
    relative to the suite folder), with that suite's VARIANT cells. The path written, or None where there are no such
    files. SuiteError or last_step.LastStepError when the files or the other suite cannot be read."""
    evals = pathlib.Path(root) / "last-checkpoint"
    if not any(evals.glob("*.json")):
        return None
    settings = suite.config.get("report") or {}
    base = settings.get("last_step_base", "maps")
    against = None
    if settings.get("last_step_against"):
        other_path, variant = settings["last_step_against"]
        other_name = os.path.normpath(os.path.join(str(root), other_path))
        against = (other_name, load_suite(other_name), variant)
    text = last_step.report_text(str(root), suite, evals, None if base == "none" else base, against)
    path = out / "last_step.md"
    path.write_text(last_step.page(str(root), text))
    return path


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("dir", help="the suite folder (holds suite.json and cells/)")
    parser.add_argument("out", nargs="?", help="where to write the report (default: DIR/report)")
    parser.add_argument("--status", help="`maps suite status --json DIR`'s output, which says what each cell is "
                                         "(`maps report` passes it; default: ask the tool)")
    study = parser.add_mutually_exclusive_group()
    study.add_argument("--study", metavar="DIR2", help="the study whose numbers stand beside a quick-scale suite's "
                                                       f"(default: {DEFAULT_STUDY.relative_to(DEFAULT_STUDY.parents[1])}"
                                                       " of this checkout)")
    study.add_argument("--no-study", action="store_true", help="no study beside a quick-scale suite's numbers")
    args = parser.parse_args(argv)
    try:
        suite = load_suite(args.dir, args.status)
        check_report_config(suite)
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

    beside = beside_study(suite, args.study, wanted=not args.no_study)
    if beside.quick and beside.note and not args.no_study:
        print(f"report: the study's numbers are not beside this quick-scale suite's: {beside.note}")

    write_results_csv(suite, out / "results.csv")
    draw = Drawer(figures, suite.cells, out)
    (out / "report.md").write_text("\n".join(report_lines(suite, draw, beside)) + "\n")
    try:
        last_step_page = write_last_step(suite, args.dir, out)
    except (SuiteError, last_step.LastStepError) as error:
        print(f"report: the last-step tables: {error}", file=sys.stderr)
        return 2
    dropped = f", {len(suite.dropped)} dropped" if suite.dropped else ""
    print(f"{len(suite.cells)} finished, {len(suite.missing)} missing, {len(suite.failed)} failed,"
          f" {len(suite.damaged)} damaged{dropped} of {len(suite.planned)} cells\n")
    if beside.quick:
        print(warning_line(beside).replace("**", "") + "\n")
    print("\n".join(main_results_beside(suite.cells, beside) if beside.cells else tables.main_results(suite.cells)))
    if last_step_page:
        print(f"last step: {last_step_page}")
    print(f"report: {out / 'report.md'}")
    return 1 if draw.failed else 0


if __name__ == "__main__":
    sys.exit(main())
