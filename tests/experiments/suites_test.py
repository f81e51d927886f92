#!/usr/bin/python3
"""Tests of the suite report (experiments/report/report.py and its modules) on the committed fixture
tests/experiments/fixtures/suite-small (written by make_suite_small.py, whose hand-chosen scores give the numbers
below): results.csv, the score table, paired differences, routing, Fig. 3's shares, ablation and module-count
tables, every figure and its CSV, the study's numbers beside a quick-scale suite's, and the errors (damaged result, no
suite.json, nothing finished, no matplotlib).
Also curve_stats.py and more_seeds.py, the tools beside the report. Run by ctest (tests/CMakeLists.txt)."""
import csv
import dataclasses
import filecmp
import json
import math
import pathlib
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]
REPORT_DIR = ROOT / "experiments" / "report"
FIXTURE = ROOT / "tests" / "experiments" / "fixtures" / "suite-small"
REPORT = REPORT_DIR / "report.py"
sys.path.insert(0, str(REPORT_DIR))
sys.path.insert(0, str(FIXTURE.parent))

import more_seeds  # noqa: E402
import routing_summary  # noqa: E402
import suite_results  # noqa: E402
import suite_stats  # noqa: E402
import tables  # noqa: E402
from markdown_rows import rows_of  # noqa: E402

FIGURES = ["fig2_scores", "fig2_tasks_gravity", "fig2_tasks_mt10", "fig3_vs_single_bc", "fig4_ablations",
           "fig5_modules_heatmap", "fig6_module_usage", "validation"]
CSVS = ["results", "fig2_scores", "fig2_tasks", "fig3_vs_single_bc", "fig4_ablations", "fig5_modules_heatmap",
        "fig6_module_usage", "validation"]

# The fixture's finished cells: set, method, variant, M (MAPS), demos, seed, the two tasks' scores.
CELLS = """
gravity maps base 10 5 0 0.8 0.6
gravity maps base 10 5 1 0.6 0.4
gravity maps base 10 10 0 0.9 0.7
gravity maps base 10 10 1 0.9 0.9
gravity single_bc base - 5 0 0.5 0.3
gravity single_bc base - 5 1 0.7 0.3
gravity single_bc base - 10 0 0.8 0.7
gravity single_bc base - 10 1 0.8 0.5
gravity mt_bc base - 5 0 0.6 0.4
gravity mt_bc base - 5 1 0.5 0.3
gravity mt_bc base - 10 0 0.7 0.8
gravity mt_bc w430 - 5 0 0.7 0.5
gravity mt_bc w430 - 5 1 0.6 0.4
mt10 maps base 10 5 0 0.8 0.6
mt10 maps base 10 5 1 0.6 0.6
mt10 maps base 10 10 0 1.0 0.8
mt10 maps base 10 10 1 0.9 0.7
mt10 maps m5 5 5 0 0.7 0.5
mt10 maps m5 5 5 1 0.6 0.4
mt10 maps m5 5 10 0 0.9 0.9
mt10 maps m5 5 10 1 0.8 0.8
mt10 maps no_explore 10 5 0 0.4 0.2
mt10 maps no_explore 10 5 1 0.3 0.3
mt10 maps no_explore 10 10 0 0.6 0.4
mt10 maps no_explore 10 10 1 0.5 0.5
mt10 maps paper_protocol 10 5 0 0.6 0.4
mt10 maps paper_protocol 10 5 1 0.5 0.5
mt10 single_bc base - 5 0 0.6 0.4
mt10 single_bc base - 5 1 0.7 0.5
mt10 single_bc base - 10 0 0.9 0.9
mt10 single_bc base - 10 1 0.8 0.8
mt10 mt_bc base - 5 0 0.5 0.5
mt10 mt_bc base - 5 1 0.4 0.2
mt10 mt_bc base - 10 0 0.9 0.7
mt10 mt_bc paper_protocol - 5 0 0.4 0.4
mt10 mt_bc paper_protocol - 5 1 0.5 0.5
"""
TASKS = {"gravity": ["gravity/0.5", "gravity/1.0"], "mt10": ["mt10/reach", "mt10/push"]}
EXPERT_RETURN = {"gravity/0.5": 5000.0, "gravity/1.0": 4000.0}


def expected_results():
    """results.csv's rows, in its order (set, method, base variant first, demos, seed, task)."""
    rows = []
    for line in CELLS.strip().splitlines():
        set_name, method, variant, modules, demos, seed, *scores = line.split()
        subsample = "10" if set_name == "gravity" else "1"
        folder = f"{method}{'' if variant == 'base' else '-' + variant}_d{demos}_s{seed}"
        grid = {"base": "comparison", "no_explore": "ablation", "m5": "modules", "w430": "controls",
                "paper_protocol": "paper_protocol"}[variant]
        for task, score in zip(TASKS[set_name], map(float, scores)):
            success, ret = (score, 500.0 + 4000.0 * score) if set_name == "mt10" else (0.0, score * EXPERT_RETURN[task])
            rows.append({"set": set_name, "method": method, "variant": variant,
                         "modules": "" if modules == "-" else modules, "demos": demos, "subsample": subsample,
                         "seed": seed, "task": task, "score": score, "success": success, "return_mean": ret,
                         "best_step": "750" if seed == "0" else "1000", "steps": "1000", "grid": grid,
                         "cell": f"{set_name}/{folder}"})
    return rows


def run_report(*args, env_prelude=None, study=None):
    """(exit code, stdout, stderr) of report.py run as `maps report` runs it. The fixture is a quick-scale suite (1000
    steps), whose report puts the committed study's numbers beside its own: the tests of its numbers leave that out
    (--no-study) unless they name a study (study=DIR)."""
    args = list(args) + (["--no-study"] if study is None else ["--study", study])
    if env_prelude is None:
        command = [sys.executable, str(REPORT), *map(str, args)]
    else:
        command = [sys.executable, "-c", f"{env_prelude}\nimport sys\nsys.path.insert(0, {str(REPORT_DIR)!r})\n"
                   f"import report\nsys.exit(report.main({[str(a) for a in args]!r}))"]
    done = subprocess.run(command, capture_output=True, text=True, timeout=120)
    return done.returncode, done.stdout, done.stderr


def plan_cell(suite_dir, result):
    """Lists the cell of a result.json a test made (its identity, its run config as the request) in suite.json, as a
    suite that planned it would: the tool counts the results of the cells a suite plans, with their run config."""
    path = suite_dir / "suite.json"
    suite = json.loads(path.read_text())
    ident = {k: v for k, v in result["cell"].items()}
    ident["request"] = result["config"]
    cells = [c for c in suite["cells"] if c["name"] != ident["name"]]
    ident["index"] = next((c["index"] for c in suite["cells"] if c["name"] == ident["name"]), len(suite["cells"]))
    suite["cells"] = sorted(cells + [ident], key=lambda c: c["index"])
    path.write_text(json.dumps(suite))


def row_of(text, first_cells):
    found = rows_of(text, first_cells)
    if len(found) != 1:
        raise AssertionError(f"{len(found)} rows starting {first_cells} in:\n{text}")
    return found[0]


def between(text, start, end):
    """The part of text from the heading `start` to the next `end`."""
    begin = text.index(start)
    stop = text.find(end, begin + len(start))
    return text[begin:stop if stop >= 0 else len(text)]


class Report(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.out = pathlib.Path(cls.tmp.name) / "report"
        cls.code, cls.stdout, cls.stderr = run_report(FIXTURE, cls.out)
        cls.md = (cls.out / "report.md").read_text() if cls.code == 0 else ""

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_runs_and_ends_with_the_report_path(self):
        self.assertEqual(self.code, 0, self.stderr)
        self.assertEqual(self.stdout.strip().splitlines()[-1], f"report: {self.out / 'report.md'}")
        self.assertEqual(row_of(self.stdout, ["gravity", "maps", "5"]), ["gravity", "maps", "5", "10", "2",
                                                                          "0.60 +- 1.27"])
        self.assertEqual(row_of(self.stdout, ["mt10", "mt_bc", "10"])[4:], ["1", "0.80"])

    def test_writes_every_figure_and_its_csv(self):
        for name in FIGURES:
            data = (self.out / f"{name}.png").read_bytes()
            self.assertTrue(data.startswith(b"\x89PNG"), name)
            self.assertGreater(len(data), 10000, name)
            self.assertIn(f"![]({name}.png)", self.md)
        for name in CSVS:
            with (self.out / f"{name}.csv").open() as f:
                self.assertGreater(len(list(csv.reader(f))), 1, name)
        self.assertNotIn("could not be drawn", self.stderr + self.md)

    def test_results_csv_has_one_row_per_finished_cell_and_task(self):
        with (self.out / "results.csv").open() as f:
            reader = csv.DictReader(f)
            self.assertEqual(reader.fieldnames, ["set", "method", "variant", "modules", "demos", "subsample", "seed",
                                                 "task", "score", "success", "success_at_end", "return_mean",
                                                 "return_unclipped_cost", "best_step", "steps",
                                                 "wall_seconds", "compute_seconds", "grid", "cell"])
            rows = list(reader)
        expected = expected_results()
        self.assertEqual(len(rows), len(expected))
        for row, want in zip(rows, expected):
            for key, value in want.items():
                if isinstance(value, float):
                    self.assertAlmostEqual(float(row[key]), value, places=9, msg=(want["cell"], key))
                else:
                    self.assertEqual(row[key], value, (want["cell"], key))
            self.assertGreaterEqual(float(row["wall_seconds"]), 20.0)

    def test_protocol_and_cell_counts(self):
        self.assertIn("1000 training steps, validation BC loss every 250 steps", self.md)
        self.assertIn("10 evaluation episodes per task; seeds 0, 1", self.md)
        self.assertIn("checkpoint = the step of the best validation BC loss", self.md)
        self.assertIn("at any step of its 150 steps", self.md)
        self.assertIn("Cells: 36 finished, 1 missing (not run or not finished), 1 failed, 0 damaged, of 38 in"
                      " suite.json.", self.md)
        self.assertIn("- `gravity/mt_bc_d10_s1` (train): maps: error: loss is nan at step 250", self.md)
        self.assertIn("Missing cells: `mt10/mt_bc_d10_s1`", self.md)

    def test_score_tables(self):
        gravity = between(self.md, "## Set gravity", "### Paired")
        # Task 0.5: 0.8 and 0.6: mean 0.7, CI 12.706 * stdev 0.1414 / sqrt(2) = 1.27.
        self.assertEqual(row_of(gravity, ["maps", "5"]), ["maps", "5", "10", "2", "1000", "0.70 +- 1.27",
                                                          "0.50 +- 1.27", "**0.60 +- 1.27**", "750-1000"])
        # The failed seed: one seed left, no interval.
        self.assertEqual(row_of(gravity, ["mt_bc", "10"]), ["mt_bc", "10", "10", "1", "1000", "0.70",
                                                            "0.80", "**0.75**", "750"])
        mt10 = between(self.md, "## Set mt10", "### Paired")
        self.assertEqual(row_of(mt10, ["maps (no_explore)", "5"])[5:], ["0.35 +- 0.64", "0.25 +- 0.64",
                                                                        "**0.30 +- 0.00**", "750-1000"])
        self.assertEqual(row_of(mt10, ["maps (m5)", "10"])[5:8], ["0.85 +- 0.64", "0.85 +- 0.64", "**0.85 +- 0.64**"])

    def test_paired_differences_from_maps_use_the_same_seeds(self):
        gravity = between(self.md, "## Set gravity", "## Set mt10")
        paired = between(gravity, "### Paired differences", "###")
        # Single BC at 5 demos: 0.4 - 0.7 and 0.5 - 0.5: mean -0.15, CI 12.706 * 0.2121 / sqrt(2) = 1.91. Holm over
        # the base methods' three comparisons with a p (Single BC at 10: p 0.374; MT-BC at 10 has one pair).
        self.assertEqual(row_of(paired, ["single_bc", "maps", "5"])[4:], ["2", "-0.15 +- 1.91", "0.500", "0.749"])
        self.assertEqual(row_of(paired, ["mt_bc", "maps", "5"])[4:], ["2", "-0.15 +- 0.64", "0.205", "0.614"])
        self.assertEqual(row_of(paired, ["mt_bc", "maps", "10"])[4:], ["1", "-0.05", "-", "-"])
        # A control with no MAPS under its variant is paired with base MAPS, in a Holm family of its own:
        # 0.6 - 0.7 and 0.5 - 0.5.
        self.assertEqual(row_of(paired, ["mt_bc (w430)", "maps", "5"])[4:], ["2", "-0.05 +- 0.64", "0.500", "0.500"])
        mt10 = between(self.md, "## Set mt10", "## Fig. 4")
        paired = between(mt10, "### Paired differences", "###")
        self.assertEqual(row_of(paired, ["mt_bc", "maps", "10"])[4:], ["1", "-0.10", "-", "-"])
        # MT-BC under the paper's protocol against MAPS under it (0.4 - 0.5, 0.5 - 0.5), not against base MAPS;
        # MAPS's own variants are not here (they are in "Variants against their base").
        self.assertEqual(row_of(paired, ["mt_bc (paper_protocol)", "maps (paper_protocol)", "5"])[4:],
                         ["2", "-0.05 +- 0.64", "0.500", "0.500"])
        self.assertEqual(rows_of(paired, ["maps (no_explore)"]), [])
        self.assertEqual(rows_of(paired, ["maps (paper_protocol)"]), [])
        self.assertIn("the base methods: 3; w430: 1", gravity)

    def test_holm_over_the_set_joins_every_comparison_in_one_family(self):
        """report.holm "set" (a suite whose variants are methods, zoo-modern.json): the same pairs as above, Holm over
        the set's four comparisons with a p: MT-BC's 0.2047 x 4 = 0.819, then 0.374 x 3 and 0.500 x 2 capped at 1."""
        import report
        suite = suite_results.load_suite(FIXTURE)
        gravity = "\n".join(tables.paired_table(suite.cells_of("gravity"), "set"))
        self.assertEqual(row_of(gravity, ["mt_bc", "maps", "5"])[4:], ["2", "-0.15 +- 0.64", "0.205", "0.819"])
        self.assertEqual(row_of(gravity, ["single_bc", "maps", "5"])[6:], ["0.500", "1.000"])
        self.assertEqual(row_of(gravity, ["mt_bc (w430)", "maps", "5"])[6:], ["0.500", "1.000"])
        self.assertIn("Holm: p adjusted over all 4 comparisons of this table", gravity)
        self.assertEqual(report.holm_families(suite), "variant")  # the fixture's suite config says none
        suite.config["report"] = {"holm": "set"}
        self.assertEqual(report.holm_families(suite), "set")
        no_figures = type("NoFigures", (), {"failed": [], "__call__": lambda self, name, **extra: []})()
        whole = "\n".join(report.report_lines(suite, no_figures))
        paired = between(between(whole, "## Set gravity", "## Set mt10"), "### Paired differences", "###")
        self.assertEqual(row_of(paired, ["mt_bc", "maps", "5"])[7], "0.819")
        with self.assertRaisesRegex(ValueError, "report.holm: expected 'variant' or 'set', got 'family'"):
            tables.paired_table(suite.cells_of("gravity"), "family")

    def test_the_comparisons_the_config_names_are_a_section_of_their_own(self):
        """report.compare ("A - B"): report.md's "Chosen comparisons" per set, A - B paired by seed (MT-BC - Single BC
        at Gravity 5: +0.00 as in the pooling table below, the other way round); none without the key."""
        import report
        suite = suite_results.load_suite(FIXTURE)
        no_figures = type("NoFigures", (), {"failed": [], "__call__": lambda self, name, **extra: []})()
        self.assertNotIn("## Chosen comparisons", "\n".join(report.report_lines(suite, no_figures)))
        suite.config["report"] = {"compare": ["single_bc - mt_bc"]}
        whole = "\n".join(report.report_lines(suite, no_figures))
        chosen = between(whole, "## Chosen comparisons (report.compare)", "## Aggregate statistics")
        row = row_of(between(chosen, "### gravity", "###"), ["single_bc", "mt_bc", "5"])
        # Seeds 0 and 1: Single BC 0.4 and 0.5 against MT-BC 0.5 and 0.4, differences -0.1 and +0.1, so p 1.
        self.assertEqual(row[4:8], ["2", "0.45 +- 0.64", "0.45 +- 0.64", "+0.00 +- 1.27"])
        self.assertRegex(row[8], r"^0\.\d{3} \[0\.\d{3}, [01]\.\d{3}\]$")
        self.assertEqual(row[9:], ["1.000", "1.000"])
        self.assertIn("### mt10", chosen)

    def test_pooling_is_paired_with_single_bc_and_holm_corrected(self):
        gravity = between(self.md, "## Set gravity", "## Set mt10")
        pooling = between(gravity, "### Paired differences from Single BC", "###")
        # MT-BC at 5: seed means 0.5 and 0.4 against Single BC's 0.4 and 0.5: +0.1 and -0.1, CI 12.706 * 0.1414 /
        # sqrt(2) = 1.27. MAPS at 10: p 0.374, the smallest of the 3, so Holm x 3, capped at 1.
        self.assertEqual(row_of(pooling, ["mt_bc", "5"])[3:], ["2", "+0.00 +- 1.27", "1.000", "1.000"])
        self.assertEqual(row_of(pooling, ["maps", "10"])[3:], ["2", "+0.15 +- 1.27", "0.374", "1.000"])
        self.assertEqual(row_of(pooling, ["mt_bc", "10"])[3:], ["1", "+0.00", "-", "-"])
        # Variants (the width control) are not pooled methods; Single BC is not against itself.
        self.assertEqual(rows_of(pooling, ["mt_bc (w430)"]), [])
        self.assertEqual(rows_of(pooling, ["single_bc"]), [])
        self.assertIn("Holm over the 3 comparisons of this table", pooling)

    def test_routing_is_computed_per_seed(self):
        routing = between(self.md, "MAPS, 5 demos, k = 10", "MAPS, 10 demos, k = 10")
        # Seed 0 routes both tasks alike (TV 0), seed 1 each task to its own module (TV 0.4): 0.2 over seeds, where
        # averaging the usage over seeds first would have hidden it.
        self.assertEqual(row_of(routing, ["0.5", "0.50"])[-1], "0.50-0.90")
        self.assertEqual(row_of(routing, ["0.5", "0.20 +- 2.54"]), ["0.5", "0.20 +- 2.54", "0.20 +- 1.27",
                                                                    "0.70 +- 2.54"])

    def test_fig3_shares_against_single_bc(self):
        fig3 = between(self.md, "## Fig. 3", "## Set gravity")
        # MAPS, task means over seeds against Single BC's (gravity 5 demos: 0.7/0.6, 0.5/0.3; 10: 0.9/0.8, 0.8/0.6;
        # mt10 5: 0.7/0.65, 0.6/0.45; 10: 0.95/0.85, 0.75/0.85): 7 better, 1 worse, 6 by > 10% (not 0.7/0.65);
        # paired over seeds, gravity/0.5 and mt10/reach at 10 demos are +0.1 in both seeds (significant), mt10/push
        # at 10 demos -0.1 in both.
        self.assertEqual(row_of(fig3, ["all", "maps"])[2:], ["8", "7 (88%)", "1 (12%)", "0 (0%)", "6 (75%)",
                                                             "2 (25%)", "1 (12%)"])
        self.assertEqual(row_of(fig3, ["all", "mt_bc"])[2:], ["8", "3 (38%)", "5 (62%)", "0 (0%)", "2 (25%)",
                                                              "0 (0%)", "0 (0%)"])
        self.assertEqual(row_of(fig3, ["mt10", "maps"])[2:], ["4", "3 (75%)", "1 (25%)", "0 (0%)", "2 (50%)",
                                                              "1 (25%)", "1 (25%)"])
        with (self.out / "fig3_vs_single_bc.csv").open() as f:
            rows = {(r["set"], r["method"]): r for r in csv.DictReader(f)}
        self.assertEqual({k: rows[("all", "maps")][k] for k in ("settings", "better", "much_better",
                                                                 "significantly_better")},
                         {"settings": "8", "better": "7", "much_better": "6", "significantly_better": "2"})

    def test_ablation_and_module_tables(self):
        fig4 = between(self.md, "## Fig. 4", "## Fig. 5")
        self.assertEqual(row_of(fig4, ["maps (no_explore)", "explore", "10", "5"])[5:],
                         ["2", "0.30 +- 0.00", "-0.35 +- 0.64 (2)", "1.00 +- 0.00", "0.00 +- 0.00", "0.05 +- 0.00"])
        # Pooled over (demos, seed): -0.4, -0.3, -0.4, -0.3: CI 3.182 * 0.0577 / 2 = 0.09.
        self.assertEqual(row_of(fig4, ["maps (no_explore)", "4"]), ["maps (no_explore)", "4", "-0.35 +- 0.09", "0.001", "0.001"])
        fig5 = between(self.md, "## Fig. 5", "## Fig. 6")
        self.assertEqual(row_of(fig5, ["5"]), ["5", "0.55 +- 0.64 (n=2)", "0.85 +- 0.64 (n=2)"])
        self.assertEqual(row_of(fig5, ["10"]), ["10", "0.65 +- 0.64 (n=2)", "0.85 +- 0.64 (n=2)"])
        with (self.out / "fig5_modules_heatmap.csv").open() as f:
            self.assertEqual(len(list(csv.DictReader(f))), 4)

    def test_variants_against_their_own_base(self):
        variants = between(self.md, "## Variants against their base", "## The paper's checkpoint rule")
        # no_explore at 5 demos: 0.3 - 0.7 and 0.3 - 0.6 against MAPS's own seeds.
        self.assertEqual(row_of(variants, ["maps (no_explore)", "5"])[3:7],
                         ["2", "0.65 +- 0.64", "0.30 +- 0.00", "-0.35 +- 0.64"])
        # Its probability of improvement over the base, on the same seeds: every no_explore run scores below every MAPS
        # run on each task of the fixture, so 0, with a degenerate interval.
        self.assertIn("| P(variant > base) [95% CI] | p | p (Holm) |", variants)
        self.assertEqual(row_of(variants, ["maps (no_explore)", "5"])[7], "0.000 [0.000, 0.000]")
        self.assertEqual(len(rows_of(variants, ["maps (m5)"])), 2)
        # Base methods are not variants of anything.
        self.assertEqual(rows_of(variants, ["maps"]) + rows_of(variants, ["mt_bc"]), [])
        self.assertIn("No cells kept checkpoints", between(self.md, "## The paper's checkpoint rule", "## Fig. 6"))

    def test_controls_are_paired_with_base_maps(self):
        controls = between(self.md, "## Controls", "## Variants against their base")
        # The wide MT-BC at 5 demos: (0.6 - 0.7) and (0.5 - 0.5) against MAPS's seeds 0 and 1; Holm over 1.
        self.assertEqual(row_of(controls, ["mt_bc (w430)"])[2:],
                         ["5", "10", "2", "0.60 +- 1.27", "0.55 +- 0.64", "-0.05 +- 0.64", "0.500", "0.500"])
        self.assertIn("one MLP on [state, task], 3 x 430", row_of(controls, ["mt_bc (w430)"])[1])
        # MT10 ran no control: no table there; MAPS's other variants are not controls.
        self.assertNotIn("### mt10", controls)
        self.assertEqual(rows_of(controls, ["maps (m5)"]) + rows_of(controls, ["mt_bc (paper_protocol)"]), [])

    def test_the_papers_claims_have_verdicts(self):
        found = between(self.md, "## The paper's claims", "## Set gravity")
        # Fig. 3's numbers (test_fig3_shares_against_single_bc): 7 of 8 better is not "more than 90%".
        row = rows_of(found, ["3", "MAPS performs better than Single BC more than 90% of the time"])[0]
        self.assertIn("better in 7 of 8 settings (88%", row[4])
        self.assertEqual(row[5], "**partly**")
        # One of the four ablations ran: the explore claim waits for the others.
        row = rows_of(found, ["7", "removing exploration costs the most success on MT10"])[0]
        self.assertEqual(row[5], "**not measured**")
        self.assertIn("Rules: (1) holds:", found)

    def test_compute_sums_each_cells_training_and_evaluation(self):
        # The fixture's costs (make_suite_small.py): MAPS 4 windows x 5 CPU s + 3 s of evaluation, the others 1000
        # steps at 40 steps/s + 3 s, and the one cell without an evaluation time its wall_seconds.
        results = {p.parent.relative_to(FIXTURE / "cells").as_posix(): json.loads(p.read_text())
                   for p in FIXTURE.glob("cells/*/*/result.json")}
        expected = {name: 23.0 if r["cell"]["method"] == "maps" else 28.0 for name, r in results.items()}
        expected["mt10/single_bc_d5_s0"] = results["mt10/single_bc_d5_s0"]["wall_seconds"]
        compute = self.md[self.md.index("## Compute"):]
        self.assertIn(f"In all: {sum(expected.values()) / 3600:.1f} CPU-hours over {len(expected)} finished cells",
                      compute)
        maps_cells = sum(r["cell"]["method"] == "maps" for r in results.values())
        self.assertIn(f"Cells counted: {maps_cells} by training's CPU seconds from curve.csv; {len(results) - maps_cells - 1}"
                      " by training's wall seconds per curve.csv window; 1 by the finishing attempt's wall seconds", compute)
        row = row_of(compute, ["ablation", "mt10", "maps (no_explore)"])
        ablation = [seconds for name, seconds in expected.items() if name.startswith("mt10/maps-no_explore")]
        self.assertEqual(row[3:], [str(len(ablation)), f"{sum(ablation) / 3600:.2f}",
                                   f"{sum(ablation) / len(ablation) / 60:.1f}", f"? ({len(ablation)})"])
        row = row_of(compute, ["comparison", "mt10", "single_bc"])
        single = [seconds for name, seconds in expected.items() if name.startswith("mt10/single_bc_")]
        self.assertEqual(row[4], f"{sum(single) / 3600:.2f}")
        with (self.out / "results.csv").open() as f:
            costs = {row["cell"]: float(row["compute_seconds"]) for row in csv.DictReader(f)}
        self.assertEqual(costs, expected)

    def test_compute_names_the_machines(self):
        # The fixture predates result.json's "cpu": every cell is "not recorded".
        self.assertIn("Machines (the CPU models each cell's training and evaluation ran on, from result.json; a cell"
                      " resumed on another kind names both): none recorded; not recorded (finished before result.json"
                      f" named its CPU): {len(list(FIXTURE.glob('cells/*/*/result.json')))}.",
                      self.md[self.md.index("## Compute"):])
        with tempfile.TemporaryDirectory() as tmp:
            suite_dir = pathlib.Path(tmp) / "suite"
            shutil.copytree(FIXTURE, suite_dir)
            paths = sorted(suite_dir.glob("cells/*/*/result.json"))
            for i, path in enumerate(paths[:3]):
                result = json.loads(path.read_text())
                # Two cells trained and evaluated on one CPU; the third resumed on another kind of machine.
                result["cpu"] = "CPU B" if i == 2 else "CPU A"
                result["training_attempts"] = [{"cpu": "CPU A", "started_utc": "2026-11-27T00:00:00Z"}]
                path.write_text(json.dumps(result))
            cells = suite_results.load_suite(suite_dir).cells
            line = tables.machines_line(cells)
            compute = "\n".join(tables.compute_table(cells))
            machines = [row_of(compute, [c.grid, c.set, c.label])[6] for c in cells
                        if c.folder in {p.parent for p in paths[:3]}]
            self.assertTrue(any(m.startswith("CPU A (") for m in machines), machines)
            self.assertTrue(any("CPU A + CPU B (1)" in m for m in machines), machines)
            self.assertIn("compare rows' costs only where the machines column agrees", compute)
            self.assertNotIn("machines column agrees", "\n".join(tables.compute_table(cells[:1])))
            # A training attempt that names no CPU (a provenance record older than the key, an unreadable file) is
            # an unknown machine, not left out; a result.json older than the key names nothing.
            self.assertEqual(suite_results.cpus_of({"cpu": "CPU B", "training_attempts": [{"started_utc": "x"},
                                                                                         {"error": "unreadable"}]}),
                             ("CPU B", "unknown"))
            self.assertEqual(suite_results.cpus_of({"cpu": "CPU A", "training_attempts": None}), ("CPU A",))
            self.assertEqual(suite_results.cpus_of({"host": "vm"}), ())
        self.assertIn("ran on, from result.json; a cell resumed on another kind names both): CPU A: 2;"
                      f" CPU A + CPU B: 1; not recorded (finished before result.json named its CPU): {len(paths) - 3}.",
                      line)

    def test_captions_say_n_and_the_score(self):
        self.assertIn("n = 1-2 seeds per point, 10 episodes per task, 1000 training steps", self.md)
        self.assertIn("success rate", between(self.md, "![](fig2_scores.png)", "##"))
        self.assertIn("return / expert demo return", between(self.md, "![](fig2_scores.png)", "##"))
        self.assertIn("seed 0", between(self.md, "![](fig6_module_usage.png)", "##"))

    def test_the_fixture_is_what_its_generator_writes(self):
        import make_suite_small
        with tempfile.TemporaryDirectory() as tmp:
            fresh = pathlib.Path(tmp) / "suite-small"
            make_suite_small.write(fresh)
            mismatch = filecmp.dircmp(fresh, FIXTURE)
            stack = [mismatch]
            while stack:
                d = stack.pop()
                self.assertFalse(d.left_only or d.right_only or d.diff_files,
                                 f"{d.left}: rerun tests/experiments/fixtures/make_suite_small.py")
                stack += d.subdirs.values()


class ZooRouting(unittest.TestCase):
    """The fixture plus one cell of a zoo method that routes (MOORE, 4 modules): the usage tables cover it and
    zoo_routing.png draws it beside MAPS; without it (the plain fixture) the figure is not drawn."""

    def test_a_routing_zoo_method_gets_its_tables_and_figure(self):
        with tempfile.TemporaryDirectory() as tmp:
            suite_dir = pathlib.Path(tmp) / "suite"
            shutil.copytree(FIXTURE, suite_dir)
            suite = json.loads((suite_dir / "suite.json").read_text())
            source = next(c for c in suite["cells"] if c["name"] == "mt10/maps_d5_s0")
            cell = json.loads(json.dumps(source))
            cell.update(index=len(suite["cells"]), name="mt10/moore_d5_s0", method="moore")
            cell["request"]["method"] = "moore"
            suite["cells"].append(cell)
            (suite_dir / "suite.json").write_text(json.dumps(suite))
            result = json.loads((suite_dir / "cells" / "mt10" / "maps_d5_s0" / "result.json").read_text())
            result["cell"].update(index=cell["index"], name=cell["name"], method="moore")
            result["config"]["method"] = result["eval"]["method"] = "moore"
            for i, task in enumerate(result["eval"]["tasks"]):
                task["module_usage"] = [0.7, 0.1, 0.1, 0.1] if i == 0 else [0.1, 0.1, 0.1, 0.7]
            moore_dir = suite_dir / "cells" / "mt10" / "moore_d5_s0"
            moore_dir.mkdir()
            (moore_dir / "result.json").write_text(json.dumps(result))
            # A top-k MoE keeping 2 of 4 experts per state: its routing is read against ln 2 and 1/2.
            result["cell"].update(name="mt10/top_k_moe_d5_s0", method="top_k_moe")
            result["config"]["method"] = result["eval"]["method"] = "top_k_moe"
            result["config"]["top_k_moe"] = {"experts": 4, "top_k": 2}
            top_k_dir = suite_dir / "cells" / "mt10" / "top_k_moe_d5_s0"
            top_k_dir.mkdir()
            (top_k_dir / "result.json").write_text(json.dumps(result))
            plan_cell(suite_dir, result)
            # The same method at another count with another k: a note for each k, not the last one alone.
            result["cell"].update(name="mt10/top_k_moe_d10_s0", demos=10)
            result["config"]["top_k_moe"] = {"experts": 4, "top_k": 3}
            result["config"]["data"]["demos_per_task"] = 10
            (suite_dir / "cells" / "mt10" / "top_k_moe_d10_s0").mkdir()
            (suite_dir / "cells" / "mt10" / "top_k_moe_d10_s0" / "result.json").write_text(json.dumps(result))
            plan_cell(suite_dir, result)
            out = pathlib.Path(tmp) / "report"
            code, _, stderr = run_report(suite_dir, out)
            self.assertEqual(code, 0, stderr)
            md = (out / "report.md").read_text()
            self.assertIn("MOORE, 5 demos, k = 1: module usage (share |w_k,i| / sum |w_k|", md)
            # One seed: no range over seeds, no interval, and the wording says so.
            moore_usage = md[md.index("MOORE, 5 demos"):md.index("Task division", md.index("MOORE, 5 demos"))]
            self.assertIn("of seed 0 (the only seed with module usage):", moore_usage)
            self.assertIn("Routing (seed 0 only; uniform over 4 modules: entropy 1.39, top score 0.25):", moore_usage)
            self.assertNotIn("top module, all seeds", moore_usage)
            self.assertNotIn("1 seeds", md)
            self.assertIn("![](zoo_routing.png)", md)
            # The same task-division measure as MAPS's: each task uses one module of its own (share 0.7 >= 1.5/4).
            moore_part = md[md.index("MOORE, 5 demos"):]
            division = moore_part[moore_part.index("Task division per seed (a task uses a module whose share of its"
                                                   " usage is >= 1.5/4"):]
            division = division[:division.index("\n\n", division.index("| seed"))]
            self.assertEqual(row_of(division, ["0"]), ["0", "0", "2", "2", "0 of 2", "1-1"])
            with (out / "zoo_routing.csv").open() as f:
                rows = list(csv.DictReader(f))
            self.assertEqual({r["method"] for r in rows}, {"maps", "moore", "top_k_moe"})
            self.assertIn("The top-k MoE's gate keeps k = 2 experts per state (the others' gate is 0): a state's entropy"
                          " is at most ln 2 = 0.69 and its top score at least 1/2 = 0.50", md)
            self.assertIn("MOORE's and PaCo's usage is the share of |w|", md)
            self.assertIn("compare methods by these counts as shares of their own M", md)
            self.assertEqual(len([r for r in rows if r["method"] == "moore"]), 2 * 4)
            # The summary table: one row per routing method and setting. MOORE's two tasks each lean on a module of
            # their own (0.7 against the mean's 0.4): TV 0.3 each, both modules specific, none shared.
            summary = between(md, "## Routing of every method (the zoo)", "![](zoo_routing.png)")
            moore = row_of(summary, ["mt10", "5", "1", "MOORE"])
            self.assertEqual(moore[4:7], ["1", "4", "0.30"])
            self.assertEqual(moore[-3:], ["0 of 4", "2 of 4", "0 of 2"])
            self.assertEqual(row_of(summary, ["mt10", "5", "1", "MAPS"])[5], "10")
            self.assertIn("- The top-k MoE's gate keeps k = 2 experts per state", summary)
            self.assertIn("- The top-k MoE's gate keeps k = 3 experts per state", summary)
            # Where fewer seeds than the row's have a measure, its cell says over how many.
            self.assertEqual(routing_summary.over_seeds([0.5, 0.7], 3, 1.386), "0.60 +- 1.27 (1.39, 2 of 3 seeds)")
            self.assertEqual(routing_summary.over_seeds([0.5, 0.7], 2, 0.25), "0.60 +- 1.27 (0.25)")
            self.assertEqual(routing_summary.over_seeds([], 2, 0.25), "- (0.25)")
            # Every set's paired differences from MAPS in one section, the zoo's methods among them.
            against = between(md, "## Against MAPS, every set", "\n## ")
            self.assertEqual(row_of(against, ["moore", "maps", "5"])[4], "1")
            self.assertNotIn("more_seeds.py", against)  # no seeds were added after the first ones
            self.assertNotIn("more_seeds.py added", summary)
            # Seeds added where the first seeds' interval included 0 (MOORE's cell planned by an added grid): the
            # sections with its set's p values say they are not nominal; the other set's do not.
            suite["cells"][-1]["grid"] = "comparison_seeds_3_4"
            (suite_dir / "suite.json").write_text(json.dumps(suite))
            code, _, stderr = run_report(suite_dir, out)
            self.assertEqual(code, 0, stderr)
            md = (out / "report.md").read_text()
            against = between(md, "## Against MAPS, every set", "\n## ")
            caveat = "grids comparison_seeds_3_4 were added by more_seeds.py after the first seeds finished"
            self.assertIn(caveat, between(against, "### mt10", "\n## "))
            self.assertNotIn(caveat, between(against, "### gravity", "### mt10"))
            self.assertIn("not as nominal tests", against)
            self.assertIn(caveat, between(md, "## Set mt10", "### Paired differences from Single BC"))
            self.assertNotIn(caveat, between(md, "## Set gravity", "## Set mt10"))
            self.assertIn("its p values and so its verdict are indicative", between(md, "## The paper's claims", "\n## "))
            self.assertIn("more_seeds.py added seeds where a difference from MAPS had an interval including 0",
                          between(md, "## Routing of every method (the zoo)", "![](zoo_routing.png)"))
            # A grid named like an added one but with no finished cell (planned, not run yet) cites nothing.
            suite["cells"][-1]["grid"] = "comparison"
            suite["cells"].append(dict(json.loads(json.dumps(suite["cells"][-1])), index=len(suite["cells"]),
                                       name="mt10/moore_d5_s3", seed=3, grid="comparison_seeds_3"))
            (suite_dir / "suite.json").write_text(json.dumps(suite))
            code, _, stderr = run_report(suite_dir, out)
            self.assertEqual(code, 0, stderr)
            self.assertNotIn("more_seeds.py", between((out / "report.md").read_text(), "## Against MAPS, every set",
                                                       "\n## "))
        # The plain fixture has MAPS alone: no zoo figure.
        with tempfile.TemporaryDirectory() as tmp:
            code, _, stderr = run_report(FIXTURE, pathlib.Path(tmp) / "report")
            self.assertEqual(code, 0, stderr)
            self.assertFalse((pathlib.Path(tmp) / "report" / "zoo_routing.png").exists())
            md = (pathlib.Path(tmp) / "report" / "report.md").read_text()
            self.assertNotIn("## Routing of every method", md)
            self.assertNotIn("## Against MAPS, every set", md)


class CheckpointRule(unittest.TestCase):
    """The fixture with MT10's MAPS at 5 demos evaluated at every kept checkpoint too (best over them: 0.8 in both
    seeds, against best-validation scores of 0.7 and 0.6; the last, 0.5 and 0.7): the paper's rule and the last
    checkpoint beside the headline one."""

    def test_the_papers_rule_is_reported_beside_the_best_validation_one(self):
        with tempfile.TemporaryDirectory() as tmp:
            suite_dir = pathlib.Path(tmp) / "suite"
            shutil.copytree(FIXTURE, suite_dir)
            for seed in (0, 1):
                path = suite_dir / "cells" / "mt10" / f"maps_d5_s{seed}" / "result.json"
                result = json.loads(path.read_text())
                result["config"]["train"]["keep_every"] = 500
                result["eval"]["best_over_checkpoints"] = {"step": 500, "mean_score": 0.8, "file": "step_500.ckpt"}
                result["eval"]["checkpoints"] = [{"step": 500, "mean_score": 0.8, "file": "step_500.ckpt"},
                                                 {"step": 1000, "mean_score": [0.5, 0.7][seed],
                                                  "file": "step_1000.ckpt"}]
                path.write_text(json.dumps(result))
                plan_cell(suite_dir, result)
            for seed, last, best in ((0, 0.6, 0.7), (1, 0.6, 0.6)):  # Single BC, kept likewise
                path = suite_dir / "cells" / "mt10" / f"single_bc_d5_s{seed}" / "result.json"
                result = json.loads(path.read_text())
                result["config"]["train"]["keep_every"] = 500
                result["eval"]["best_over_checkpoints"] = {"step": 500, "mean_score": best, "file": "step_500.ckpt"}
                result["eval"]["checkpoints"] = [{"step": 1000, "mean_score": last, "file": "step_1000.ckpt"}]
                path.write_text(json.dumps(result))
                plan_cell(suite_dir, result)
            out = pathlib.Path(tmp) / "report"
            code, _, stderr = run_report(suite_dir, out)
            self.assertEqual(code, 0, stderr)
            rule = between((out / "report.md").read_text(), "## The paper's checkpoint rule", "## Fig. 6")
            # Single BC - MAPS at each rule: best validation 0.5 - 0.7, 0.6 - 0.6; last 0.6 - 0.5, 0.6 - 0.7; best
            # over checkpoints 0.7 - 0.8, 0.6 - 0.8.
            pairs = between(rule, "Method - MAPS", "## Fig. 6")
            # One row: Holm over a column of one is its p.
            self.assertEqual(row_of(pairs, ["single_bc", "5"]), ["single_bc", "5", "1",
                                                                  "-0.10 +- 1.27 (2), p 0.500, Holm 0.500",
                                                                  "+0.00 +- 1.27 (2), p 1.000, Holm 1.000",
                                                                  "-0.15 +- 0.64 (2), p 0.205, Holm 0.205"])
            # The last checkpoint (step 1000 = steps): 0.5 and 0.7.
            self.assertEqual(row_of(rule, ["maps", "5"]), ["maps", "5", "1", "2", "500", "0.65 +- 0.64",
                                                           "0.60 +- 1.27", "0.80 +- 0.00", "+0.15 +- 0.64"])
            self.assertEqual(rows_of(rule, ["maps", "10"]), [])
            # A variant with no MAPS under it (a method of its own, as zoo-modern's Diffusion Policy) is paired with
            # base MAPS at each rule, as the paired tables pair it: the same differences as Single BC's above.
            # Beside the base Single BC's row, each rule's column is a family of two. A copy scoring 0.1 lower at its
            # best-validation checkpoint (0.4 and 0.5 against MAPS's 0.7 and 0.6: differences -0.3 and -0.1, t = -2 on
            # 1 df, p 0.295) is the smaller p there: Holm doubles it (0.590) and the step-down keeps that running
            # maximum for the base row (0.500 -> 0.590; Bonferroni would give it 1.000). The other two rules' columns
            # hold equal p values: both rows get twice the p, capped at 1.
            cells = suite_results.load_suite(suite_dir).cells_of("mt10")
            for c in [c for c in cells if c.method == "single_bc"]:
                lower = [dataclasses.replace(t, score=t.score - 0.1) for t in c.tasks]
                cells.append(dataclasses.replace(c, variant="dp_like", tasks=lower))
            pairs = tables.checkpoint_rule_pairs(cells)
            self.assertIn("each rule one family: best validation 2, last checkpoint 2, best over checkpoints 2;",
                          pairs[1])
            pairs = "\n".join(pairs)
            self.assertEqual(row_of(pairs, ["single_bc (dp_like)", "5"])[3], "-0.20 +- 1.27 (2), p 0.295, Holm 0.590")
            self.assertEqual(row_of(pairs, ["single_bc", "5"])[3], "-0.10 +- 1.27 (2), p 0.500, Holm 0.590")
            for label in ("single_bc (dp_like)", "single_bc"):
                self.assertEqual(row_of(pairs, [label, "5"])[4:], ["+0.00 +- 1.27 (2), p 1.000, Holm 1.000",
                                                                    "-0.15 +- 0.64 (2), p 0.205, Holm 0.410"])


class SweepCells(unittest.TestCase):
    """Fig. 5's points: base MAPS and the variants that change M alone; other MAPS variants at the base M (uniform
    selector, the paper's inputs, a rerun with denormals flushed) and variants that change M and more are not."""

    def test_only_module_count_variants_join_the_sweep(self):
        import suite_results

        def cell(variant, modules, seed, **changes):
            config = {"method": "maps", "seed": seed, "data": {"demos_per_task": 5},
                      "train": {"steps": 100}, "maps": {"modules": modules, "selector": "learned",
                                                        "selector_losses": {"share": 1, "explore": 0.5}}}
            for section, values in changes.items():
                config[section].update(values)
            task = suite_results.TaskResult("mt10/reach", 0.5, 0.5, 0.5, 0.5)
            return suite_results.Cell(pathlib.Path("."), f"mt10/{variant}_{seed}", "g", "mt10", "maps", variant, 5, 1,
                                      seed, config, 100, 50, 10, 1.0, [task])

        cells = [cell("base", 10, 0), cell("base", 10, 1), cell("m5", 5, 0, train={"flush_denormal": True}),
                 cell("m20", 20, 1), cell("uniform", 10, 0, maps={"selector": "uniform"}),
                 cell("flush", 10, 0, train={"flush_denormal": True}),
                 cell("m5_uniform", 5, 1, maps={"selector": "uniform"})]
        sweep = suite_results.module_sweep_cells(cells)
        self.assertEqual(sorted((c.variant, c.seed) for c in sweep),
                         [("base", 0), ("base", 1), ("m20", 1), ("m5", 0)])
        self.assertEqual(suite_results.module_sweep_cells(cells[:2] + cells[4:6]), [])


class ControlCells(unittest.TestCase):
    """The controls: MAPS at the base M with a selector other than the learned one, and MT-BC wider than its base;
    not MAPS's ablations, module counts or protocol variants, nor MT-BC's variants at its base width."""

    def test_only_the_controls_are_picked(self):
        import suite_results

        def cell(method, variant, seed, **changes):
            config = {"method": method, "seed": seed, "data": {"demos_per_task": 5}, "train": {"steps": 100}}
            if method == "maps":
                config["maps"] = {"modules": 10, "selector": "learned", "selector_losses": {"share": 1, "explore": 0.5}}
            else:
                config["baselines"] = {"hidden": [128, 128, 128]}
            for section, values in changes.items():
                config[section].update(values)
            task = suite_results.TaskResult("gravity/0.5", 0.5, 0.0, 0.0, 1.0)
            return suite_results.Cell(pathlib.Path("."), f"gravity/{method}-{variant}_{seed}", "g", "gravity", method,
                                      variant, 5, 10, seed, config, 100, 50, 10, 1.0, [task])

        cells = [cell("maps", "base", 0), cell("maps", "uniform", 0, maps={"selector": "uniform"}),
                 cell("maps", "task_selector", 0, maps={"selector": "task"}),
                 cell("maps", "m5_uniform", 0, maps={"modules": 5, "selector": "uniform"}),
                 cell("maps", "no_explore", 0, maps={"selector_losses": {"share": 1, "explore": 0}}),
                 cell("mt_bc", "base", 0), cell("mt_bc", "w430", 0, baselines={"hidden": [430, 430, 430]}),
                 cell("mt_bc", "sampled_bc", 0), cell("mt_bc", "narrow", 0, baselines={"hidden": [64, 64, 64]})]
        self.assertEqual(sorted(c.variant for c in suite_results.control_cells(cells)),
                         ["task_selector", "uniform", "w430"])
        # Without base MT-BC cells there is no width to be wider than; without base MAPS, no M to match.
        self.assertEqual(sorted(c.variant for c in suite_results.control_cells(cells[1:5] + cells[6:7])), [])


class VariantsAsMethods(unittest.TestCase):
    """Fig. 2 and the routing tables in a suite whose variants are methods of their own (report.holm "set",
    zoo-modern.json): every variant a line and a bar group of its own (and a routing row and panel where it routes),
    keep-only variants not (their training is the base's); otherwise the base methods only, as before."""

    def test_fig2_draws_every_variant_only_when_variants_are_methods(self):
        import figures
        cells = suite_results.load_suite(FIXTURE).cells
        variants = {c.label for c in cells if c.label != c.method}
        self.assertTrue(variants)
        with tempfile.TemporaryDirectory() as tmp:
            out = pathlib.Path(tmp)
            for as_methods in (False, True):
                figures.fig2_scores(cells, out, variants_are_methods=as_methods)
                figures.fig2_tasks(cells, out, variants_are_methods=as_methods)
                with (out / "fig2_scores.csv").open() as f:
                    drawn = {(r["method"], r["variant"]) for r in csv.DictReader(f)}
                with (out / "fig2_tasks.csv").open() as f:
                    bars = {suite_results.label(r["method"], r["variant"]) for r in csv.DictReader(f)}
                labels = {suite_results.label(m, v) for m, v in drawn}
                if as_methods:
                    self.assertEqual(labels, {c.label for c in cells})
                    self.assertEqual(bars, labels)
                else:
                    self.assertEqual(labels, {c.method for c in cells})
                    self.assertEqual({v for _, v in drawn}, {"base"})
                    self.assertEqual(bars, {c.method for c in cells})
        # A keep-only variant beside its base cells is not a line of its own.
        keep = [c for c in cells if c.label == c.method][0]
        kept = suite_results.Cell(**{**keep.__dict__, "variant": "keep2500", "stands_for_base": False})
        self.assertNotIn(kept, figures.compared_cells([keep, kept], variants_are_methods=True))

    def test_a_variants_style_follows_its_method_or_takes_a_colour_of_its_own(self):
        import figures
        labels = ["maps", "maps (chunk16)", "diffusion_policy (dp_mlp_h16)", "diffusion_policy (dp_maps_h16)"]
        self.assertEqual(figures.methods_of([type("C", (), {"label": label})() for label in labels]),
                         ["maps", "maps (chunk16)", "diffusion_policy (dp_maps_h16)", "diffusion_policy (dp_mlp_h16)"])
        chunked = figures.label_style("maps (chunk16)", labels)
        self.assertEqual((chunked["color"], chunked["linestyle"]), (figures.color("maps"), "--"))
        mlp, denoiser = (figures.label_style(label, labels)["color"] for label in labels[2:])
        self.assertNotEqual(mlp, denoiser)
        self.assertNotIn(figures.color("maps"), (mlp, denoiser))
        # Never a colour twice among variants that need their own, however many (until the palette's end).
        many = [f"diffusion_policy (v{i})" for i in range(12)] + [m for m in figures.COLORS if m != "diffusion_policy"]
        colours = [figures.label_style(label, many)["color"] for label in many[:12]]
        self.assertEqual(len(set(colours)), 12)
        self.assertFalse(set(colours) & set(figures.COLORS.values()))
        self.assertEqual(figures.label_name("diffusion_policy (dp_mlp_h16)"), "Diffusion Policy (dp_mlp_h16)")

    def test_the_denoisers_validation_curves_are_a_figure_of_their_own(self):
        """Diffusion Policy's validation loss (the denoising loss) is drawn per denoiser, mean over seeds at the steps
        every seed logged, apart from the other methods' BC losses; without Diffusion Policy cells, no figure."""
        import figures
        with tempfile.TemporaryDirectory() as tmp:
            root = pathlib.Path(tmp)

            def cell(variant, seed, losses, method="diffusion_policy"):
                folder = root / f"{method}-{variant}_s{seed}"
                folder.mkdir()
                (folder / "curve.csv").write_text("step,validation_bc\n" + "".join(
                    f"{50 * (i + 1)},{loss}\n" for i, loss in enumerate(losses)))
                return suite_results.Cell(folder, f"mt10/{folder.name}", "g", "mt10", method, variant, 2, 1, seed,
                                          {"method": method}, 100, 50, 10, 1.0, [])

            cells = [cell("dp_mlp_h16", 0, [0.4, 0.2]), cell("dp_mlp_h16", 1, [0.2, 0.1, 0.05]),
                     cell("dp_moe_h16", 0, [0.5, 0.3]), cell("base", 0, [0.9, 0.8], method="maps")]
            self.assertEqual([f.file for f in figures.denoising_validation(cells, root)], ["denoising_validation.png"])
            with (root / "denoising_validation.csv").open() as f:
                rows = [(r["label"], r["step"], r["seeds"], round(float(r["validation_denoising"]), 6))
                        for r in csv.DictReader(f)]
            # The MLP's two seeds share steps 50 and 100 (the second's 150 is left out); MAPS is not drawn.
            self.assertEqual(sorted(rows), [("diffusion_policy (dp_mlp_h16)", "100", "2", 0.15),
                                            ("diffusion_policy (dp_mlp_h16)", "50", "2", 0.3),
                                            ("diffusion_policy (dp_moe_h16)", "100", "1", 0.3),
                                            ("diffusion_policy (dp_moe_h16)", "50", "1", 0.5)])
            self.assertEqual(figures.denoising_validation(cells[3:], root), [])

    def test_routing_tables_take_the_variants_that_route(self):
        """The modular denoisers record module usage: with variants as methods they are rows of the routing summary
        and usage tables, named by method and variant, their usage's meaning and the MoE's top-k bounds said."""
        import routing_summary

        def cell(variant, denoiser, seed, usage):
            config = {"method": "diffusion_policy", "seed": seed, "data": {"demos_per_task": 2},
                      "train": {"steps": 100}, "diffusion_policy": {"denoiser": denoiser, "top_k": 2}}
            tasks = [suite_results.TaskResult(f"mt10/{t}", 0.5, 0.5, 0.5, 0.5, usage=u, entropy=0.6, top_score=0.6)
                     for t, u in zip(("reach", "push"), usage)]
            return suite_results.Cell(pathlib.Path("."), f"mt10/{variant}_{seed}", "g", "mt10", "diffusion_policy",
                                      variant, 2, 1, seed, config, 100, 50, 10, 1.0, tasks)

        moe = [cell("dp_moe_h16", "moe", s, [[0.5, 0.5, 0, 0], [0, 0, 0.5, 0.5]]) for s in (0, 1)]
        gated = [cell("dp_maps_h16", "maps", s, [[0.7, 0.1, 0.1, 0.1], [0.1, 0.7, 0.1, 0.1]]) for s in (0, 1)]
        mlp = [cell("dp_mlp_h16", "mlp", 0, [None, None])]
        cells = moe + gated + mlp
        self.assertEqual(tables.routed(cells), {})
        self.assertEqual(sorted(key.label for key in tables.routed(cells, variants_are_methods=True)),
                         ["diffusion_policy (dp_maps_h16)", "diffusion_policy (dp_moe_h16)"])
        summary = "\n".join(routing_summary.routing_summary(cells, variants_are_methods=True))
        self.assertEqual(row_of(summary, ["mt10", "2", "1", "Diffusion Policy (dp_moe_h16)"])[4:6], ["2", "4"])
        self.assertIn("The MoE denoiser's router keeps k = 2 experts per state", summary)
        self.assertEqual(routing_summary.routing_summary(cells), [])
        usage = "\n".join(tables.usage_tables(cells, variants_are_methods=True))
        self.assertIn("Diffusion Policy (dp_maps_h16), 2 demos, k = 1: module usage (mean selector score", usage)
        self.assertIn("Diffusion Policy (dp_moe_h16), 2 demos, k = 1: module usage (mean of each state's kept gates",
                      usage)
        # A keep-only variant of a routing method is not a row of its own.
        keep = [cell("keep2500", "maps", s, [[0.7, 0.1, 0.1, 0.1], [0.1, 0.7, 0.1, 0.1]]) for s in (0, 1)]
        self.assertNotIn("diffusion_policy (keep2500)", {key.label for key in tables.routed(cells + keep, True)})
        import figures
        with tempfile.TemporaryDirectory() as tmp:
            self.assertEqual(figures.zoo_routing(cells, pathlib.Path(tmp)), [])  # nothing routes but variants
            self.assertEqual(len(figures.zoo_routing(cells, pathlib.Path(tmp), variants_are_methods=True)), 1)
            with (pathlib.Path(tmp) / "zoo_routing.csv").open() as f:
                panels = {(r["method"], r["variant"]) for r in csv.DictReader(f)}
            self.assertEqual(panels, {("diffusion_policy", "dp_maps_h16"), ("diffusion_policy", "dp_moe_h16")})

    def test_the_report_passes_report_holm_set_to_the_figures_and_routing_tables(self):
        """report_lines: with report.holm "set" Fig. 2, the per-task bars and the routing figure are drawn with
        variants_are_methods, and the routing summary has the fixture's MAPS variants as rows; without it, not."""
        import report
        suite = suite_results.load_suite(FIXTURE)
        calls = {}

        class Recorder:
            failed = []

            def __call__(self, name, **extra):
                calls[name] = extra.get("variants_are_methods")
                return []

        plain = "\n".join(report.report_lines(suite, Recorder()))
        self.assertEqual({calls[n] for n in ("fig2_scores", "fig2_tasks", "zoo_routing")}, {False})
        suite.config["report"] = {"holm": "set"}
        as_methods = "\n".join(report.report_lines(suite, Recorder()))
        self.assertEqual({calls[n] for n in ("fig2_scores", "fig2_tasks", "zoo_routing")}, {True})
        routed_variants = {c.label for c in suite.cells if c.label != c.method and c.has_usage}
        self.assertTrue(routed_variants)
        routing = between(as_methods, "## Routing of every method (the zoo)", "## Validation")
        for label in routed_variants:
            self.assertIn(f"| {suite_results.display_label(label)} |", routing)
        self.assertNotIn("## Routing of every method (the zoo)", plain)

    def test_every_paired_table_of_a_set_with_added_seeds_is_headed_by_the_caveat(self):
        """Seeds more_seeds.py added on a set make that set's p values indicative wherever they are printed: the
        caveat heads its "Chosen comparisons" and "The paper's checkpoint rule" tables (as it heads its paired
        differences from MAPS), not the other set's."""
        import report
        from unittest import mock
        suite = suite_results.load_suite(FIXTURE)
        added = next(i for i in suite.planned if isinstance(i, dict) and i.get("set") == "mt10")
        added["grid"] = "comparison_seeds_3_4"
        suite.config["report"] = {"compare": ["mt_bc - maps"]}

        class Quiet:
            failed = []

            def __call__(self, name, **extra):
                return []

        with mock.patch.object(report.comparisons, "compare_table", return_value=["| compared |"]), \
                mock.patch.object(report.tables, "checkpoint_rule_table", return_value=["| ruled |"]):
            md = "\n".join(report.report_lines(suite, Quiet()))
        caveat = "grids comparison_seeds_3_4 were added by more_seeds.py"
        for section in ("## Chosen comparisons (report.compare)", "## The paper's checkpoint rule"):
            body = between(md, section, "\n## ")
            self.assertIn(caveat, between(body, "### mt10", "\n## "), section)
            self.assertNotIn(caveat, between(body, "### gravity", "### mt10"), section)


class Statistics(unittest.TestCase):
    def test_ci95_uses_the_t_distribution(self):
        self.assertTrue(math.isnan(suite_stats.ci95([1.0])))
        self.assertAlmostEqual(suite_stats.ci95([0.0, 1.0]), 12.7062047 * math.sqrt(0.5) / math.sqrt(2), places=6)
        values = [float(i % 2) for i in range(40)]
        # Past 30 degrees of freedom too (the C++ evaluator's per-task intervals use the same quantiles).
        self.assertAlmostEqual(suite_stats.ci95(values), 2.0226910 * statistics.stdev(values) / math.sqrt(40), places=6)
        self.assertAlmostEqual(suite_stats.t95(99), 1.9842169, places=6)

    def test_significance_needs_an_interval_off_zero(self):
        self.assertEqual(suite_stats.significance([0.1, 0.1]), 1)
        self.assertEqual(suite_stats.significance([-0.1, -0.1]), -1)
        self.assertEqual(suite_stats.significance([0.3, -0.1]), 0)
        self.assertEqual(suite_stats.significance([0.3]), 0)


class SyncDoc(unittest.TestCase):
    """sync_doc.py: a page's marked blocks take report.md's sections, the discussion around them stays, and a
    block naming a missing section or left open is an error that names it."""
    REPORT = "# Suite report: x\n\n## Cells\n\n| a |\n|---|\n| 1 |\n\n## The paper's claims\n\n| # | claim |\n|---|---|\n| 1 | new |\n\nRules: new.\n"

    def test_replaces_only_the_marked_block(self):
        import sync_doc
        page = ("intro\n<!-- report.md: The paper's claims -->\n| 1 | old |\n<!-- /report.md -->\n"
                "discussion after\n")
        text, refreshed = sync_doc.sync(self.REPORT, page)
        self.assertEqual(refreshed, ["The paper's claims"])
        self.assertEqual(text, "intro\n<!-- report.md: The paper's claims -->\n| # | claim |\n|---|---|\n"
                               "| 1 | new |\n\nRules: new.\n<!-- /report.md -->\ndiscussion after\n")
        self.assertEqual(sync_doc.sync(self.REPORT, text)[0], text)  # idempotent
        # A marker mentioned inside a line of text is not a block.
        mention = ("Blocks look like `<!-- report.md: SECTION -->`.\n<!-- report.md: X --> is how one opens.\n" + page)
        self.assertEqual(sync_doc.sync(self.REPORT, mention)[1], ["The paper's claims"])

    def test_missing_section_and_open_block_are_errors(self):
        import sync_doc
        with self.assertRaisesRegex(ValueError, "block 'Fig. 9' has no section '## Fig. 9'"):
            sync_doc.sync(self.REPORT, "<!-- report.md: Fig. 9 -->\nx\n<!-- /report.md -->\n")
        with self.assertRaisesRegex(ValueError, "1 opening and 0 closing report.md markers, 0 of them in pairs"):
            sync_doc.sync(self.REPORT, "<!-- report.md: Cells -->\nx\n")
        block = "<!-- report.md: Cells -->\nx\n<!-- /report.md -->\n"
        with self.assertRaisesRegex(ValueError, "1 opening and 2 closing"):
            sync_doc.sync(self.REPORT, block + "text\n<!-- /report.md -->\n")
        # Comments that are nearly markers would leave their blocks stale: each is named with its line.
        for near in ("  <!-- report.md: Cells -->", "<!--report.md: Cells-->", "<!-- /report.md-->"):
            with self.assertRaisesRegex(ValueError, "line 4 looks like a block marker"):
                sync_doc.sync(self.REPORT, block + near + "\n")
        # An ordinary comment that mentions report.md is not a marker, nearly or not.
        self.assertEqual(sync_doc.sync(self.REPORT, block + "<!-- report.md tables below are generated -->\n")[1],
                         ["Cells"])

    def test_a_sections_headings_nest_under_the_pages_heading_above_the_block(self):
        import sync_doc
        report = ("## Against MAPS\n\nintro\n\n### gravity\n\n| a |\n\n#### detail\n\n```\n### not a heading\n```\n"
                  "\n### mt10\n\n| b |\n")
        page = "# Page\n\n### Scores\n\ntext\n<!-- report.md: Against MAPS -->\nold\n<!-- /report.md -->\n"
        text, _ = sync_doc.sync(report, page)
        block = text.split("<!-- report.md: Against MAPS -->\n")[1].split("<!-- /report.md -->")[0]
        self.assertEqual([line for line in block.split("\n") if line.startswith("#")],
                         ["#### gravity", "##### detail", "### not a heading", "#### mt10"])
        self.assertEqual(sync_doc.sync(report, text)[0], text)  # idempotent
        # Under a '#' heading the section's '###' rise to '##'; with no heading above, they stay as written.
        self.assertIn("\n## gravity\n", sync_doc.sync(report, page.replace("### Scores", "# Scores"))[0])
        self.assertIn("\n### gravity\n", sync_doc.sync(report, page.split("text\n", 1)[1])[0])
        # Levels stay within markdown's six.
        deep = sync_doc.sync(report, page.replace("### Scores", "###### Scores"))[0]
        self.assertIn("\n###### gravity\n", deep)
        self.assertIn("\n###### detail\n", deep)
        # A block right after another nests under the page's heading, not under the first block's last heading.
        twice = text + "<!-- report.md: Against MAPS -->\nold\n<!-- /report.md -->\n"
        second = sync_doc.sync(report, twice)[0].split("<!-- /report.md -->\n")[1]
        self.assertIn("\n#### gravity\n", second)

    def test_relative_links_are_rewritten_for_the_pages_folder(self):
        import sync_doc
        report = ("## Fig. 5\n\n![](fig5.png) and [cells](cells/x.json), [web](https://a.b/c), [top](#fig-5), "
                  "![abs](/tmp/a.png)\n")
        page = "<!-- report.md: Fig. 5 -->\nold\n<!-- /report.md -->\n"
        text = sync_doc.sync(report, page, "../results/study/report")[0]
        self.assertIn("![](../results/study/report/fig5.png) and [cells](../results/study/report/cells/x.json), "
                      "[web](https://a.b/c), [top](#fig-5), ![abs](/tmp/a.png)", text)
        self.assertEqual(sync_doc.sync(report, text, "../results/study/report")[0], text)  # idempotent
        with tempfile.TemporaryDirectory() as tmp:
            (pathlib.Path(tmp) / "results" / "report").mkdir(parents=True)
            (pathlib.Path(tmp) / "docs").mkdir()
            report_path, page_path = pathlib.Path(tmp, "results", "report", "report.md"), pathlib.Path(tmp, "docs", "p.md")
            report_path.write_text(report)
            page_path.write_text(page)
            done = subprocess.run([sys.executable, str(REPORT_DIR / "sync_doc.py"), str(report_path), str(page_path)],
                                  capture_output=True, text=True)
            self.assertEqual(done.returncode, 0, done.stderr)
            self.assertIn("![](../results/report/fig5.png)", page_path.read_text())

    def test_command_line_rewrites_the_page(self):
        with tempfile.TemporaryDirectory() as tmp:
            report, page = pathlib.Path(tmp, "report.md"), pathlib.Path(tmp, "page.md")
            report.write_text(self.REPORT)
            page.write_text("<!-- report.md: Cells -->\nold\n<!-- /report.md -->\n")
            done = subprocess.run([sys.executable, str(REPORT_DIR / "sync_doc.py"), str(report), str(page)],
                                  capture_output=True, text=True)
            self.assertEqual(done.returncode, 0, done.stderr)
            self.assertIn("| 1 |", page.read_text())
            # A CRLF page keeps its line endings, inside and outside the block.
            page.write_bytes(b"intro\r\n<!-- report.md: Cells -->\r\nold\r\n<!-- /report.md -->\r\nafter\r\n")
            done = subprocess.run([sys.executable, str(REPORT_DIR / "sync_doc.py"), str(report), str(page)],
                                  capture_output=True, text=True)
            self.assertEqual(done.returncode, 0, done.stderr)
            raw = page.read_bytes()
            self.assertTrue(raw.startswith(b"intro\r\n<!-- report.md: Cells -->\r\n| a |\r\n"), raw)
            self.assertNotIn(b"\n", raw.replace(b"\r\n", b""))
            page.write_text("no blocks\n")
            done = subprocess.run([sys.executable, str(REPORT_DIR / "sync_doc.py"), str(report), str(page)],
                                  capture_output=True, text=True)
            self.assertNotEqual(done.returncode, 0)
            self.assertIn("has no blocks for", done.stderr)
            # A block naming a report that is not a file is refused, naming it.
            page.write_text("<!-- report.md: results/nowhere/report/report.md#Cells -->\nold\n<!-- /report.md -->\n")
            done = subprocess.run([sys.executable, str(REPORT_DIR / "sync_doc.py"), str(report), str(page)],
                                  capture_output=True, text=True)
            self.assertNotEqual(done.returncode, 0)
            self.assertIn("names the report results/nowhere/report/report.md, which is not a file", done.stderr)

    def test_blocks_naming_their_report_take_only_that_reports_sections(self):
        """A page showing two suites: its plain blocks are one report's, the blocks naming FILE#SECTION the other's;
        syncing either leaves the other's blocks as they are."""
        import sync_doc
        other = "## Cells\n\n| b |\n|---|\n| 2 |\n"
        page = ("# Page\n\n## First\n\n<!-- report.md: Cells -->\nold\n<!-- /report.md -->\n\n## Second\n\n"
                "<!-- report.md: results/other/report/report.md#Cells -->\nold\n<!-- /report.md -->\n")
        for name in (None, "results/x/report/report.md"):
            text, refreshed = sync_doc.sync(self.REPORT, page, report_name=name)
            self.assertEqual(refreshed, ["Cells"])
            self.assertEqual(text, page.replace("Cells -->\nold", "Cells -->\n| a |\n|---|\n| 1 |", 1))
        text, refreshed = sync_doc.sync(other, page, report_name="results/other/report/report.md")
        self.assertEqual(refreshed, ["results/other/report/report.md#Cells"])
        self.assertEqual(text, page.replace("report.md#Cells -->\nold", "report.md#Cells -->\n| b |\n|---|\n| 2 |"))
        both = sync_doc.sync(self.REPORT, text)[0]
        self.assertEqual(sync_doc.sync(other, both, report_name="results/other/report/report.md")[0], both)
        self.assertEqual(sync_doc.named_reports(page), ["results/other/report/report.md"])
        with self.assertRaisesRegex(ValueError, "block 'results/other/report/report.md#Fig. 9' has no section "
                                                "'## Fig. 9'"):
            sync_doc.sync(other, page.replace("#Cells", "#Fig. 9"), report_name="results/other/report/report.md")
        # A title with '#' that is not FILE.md#SECTION names no report.
        self.assertEqual(sync_doc.named_reports("<!-- report.md: Set #1 -->\nx\n<!-- /report.md -->\n"), [])

    def test_a_report_is_known_by_its_file_however_the_block_spells_it(self):
        """names_report: the same file from the repository's root ("./results/..." too), or a report of another
        checkout whose path ends in the block's FILE; so the unnamed blocks keep their own report's sections."""
        import sync_doc
        here = sync_doc.ROOT / "results" / "zoo-modern" / "report" / "report.md"
        for spelling in ("results/zoo-modern/report/report.md", "./results/zoo-modern/report/report.md",
                         "results/../results/zoo-modern/report/report.md"):
            self.assertTrue(sync_doc.names_report(here)(spelling), spelling)
        self.assertTrue(sync_doc.names_report("/elsewhere/checkout/results/zoo-modern/report/report.md")(
            "./results/zoo-modern/report/report.md"))
        self.assertFalse(sync_doc.names_report(here)("results/zoo/report/report.md"))
        self.assertFalse(sync_doc.names_report("/elsewhere/modern/report/report.md")(
            "results/zoo-modern/report/report.md"))
        with tempfile.TemporaryDirectory() as tmp:
            report = pathlib.Path(tmp, "results", "zoo-modern", "report", "report.md")
            report.parent.mkdir(parents=True)
            report.write_text("## Cells\n\n| b |\n")
            page = pathlib.Path(tmp, "page.md")
            text = ("<!-- report.md: Cells -->\nzoo's\n<!-- /report.md -->\n"
                    "<!-- report.md: ./results/zoo-modern/report/report.md#Cells -->\nold\n<!-- /report.md -->\n")
            page.write_bytes(text.replace("\n", "\r\n").encode())
            done = subprocess.run([sys.executable, str(REPORT_DIR / "sync_doc.py"), str(report), str(page)],
                                  capture_output=True, text=True)
            self.assertEqual(done.returncode, 0, done.stderr)
            self.assertEqual(page.read_bytes().decode(),
                             text.replace("Cells -->\nold", "Cells -->\n| b |").replace("\n", "\r\n"))


class BesideTheStudy(unittest.TestCase):
    """Issue 43: a quick-scale suite's report (the fixture: 1000 steps) says in its first line that it checks the
    pipeline, not the ranking, and puts the study's number beside each of its own, in the main table and the figures.
    The study here is made from the fixture: every cell trained 20000 steps, gravity's MAPS at 10 demos scored 0.4 and
    0.2 (mean over tasks) in its two seeds, and MT10's Single BC ran 5 demos only. A missing study is one line, not an
    error."""

    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.study = pathlib.Path(cls.tmp.name) / "study"
        shutil.copytree(FIXTURE, cls.study)
        for path in sorted(cls.study.glob("cells/*/*/result.json")):
            result = json.loads(path.read_text())
            result["config"]["train"]["steps"] = result["train"]["steps"] = 20000
            if result["cell"]["name"] in ("gravity/maps_d10_s0", "gravity/maps_d10_s1"):
                for task, score in zip(result["eval"]["tasks"], [[0.5, 0.3], [0.3, 0.1]][result["cell"]["seed"]]):
                    task["score"] = score
            path.write_text(json.dumps(result))
            plan_cell(cls.study, result)
            if result["cell"]["name"].startswith("mt10/single_bc_d10_"):
                shutil.rmtree(path.parent)
        cls.out = pathlib.Path(cls.tmp.name) / "report"
        cls.code, cls.stdout, cls.stderr = run_report(FIXTURE, cls.out, study=cls.study)
        cls.md = (cls.out / "report.md").read_text() if cls.code == 0 else ""

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    WARNING = "The quick scale checks the pipeline, not the ranking"

    def test_the_first_line_says_the_quick_scale_checks_the_pipeline(self):
        self.assertEqual(self.code, 0, self.stderr)
        first = self.md.splitlines()[2]
        self.assertIn(f"**{self.WARNING}**: this suite trained 1000 steps, the study 20000", first)
        self.assertIn("see results/study (docs/results.md) for the ranking", first)
        self.assertIn(self.WARNING, self.stdout)
        self.assertNotIn("not beside", self.stdout + self.md)

    def test_the_studys_number_stands_beside_each_of_the_suites(self):
        main = between(self.md, "## Main results", "![](fig2_scores.png)")
        self.assertIn("| study (20000 steps, 10 episodes) |", main)
        # The same set, method and demos: (0.4 + 0.2) / 2, CI 12.706 * 0.1414 / sqrt(2).
        self.assertEqual(row_of(main, ["gravity", "maps", "10"])[5:], ["0.85 +- 0.64", "0.30 +- 1.27 (n=2)"])
        self.assertEqual(row_of(self.stdout, ["gravity", "maps", "10"])[5:], ["0.85 +- 0.64", "0.30 +- 1.27 (n=2)"])
        # A count the study did not run: its nearest, named.
        self.assertEqual(row_of(main, ["mt10", "single_bc", "10"])[5:], ["0.85 +- 0.64", "0.55 +- 0.64 (n=2, at 5"
                                                                         " demos)"])
        self.assertEqual(row_of(main, ["mt10", "maps (no_explore)", "5"])[6], "0.30 +- 0.00 (n=2)")
        self.assertIn("- **The study beside these numbers** (`" + str(self.study) + "`; the same set, method and demos,"
                      " else its nearest count, named): gravity: n = 1-2 seeds per point, 10 episodes per task, 20000"
                      " training steps, demos per task 5, 10; mt10:", self.md)

    def test_the_figures_draw_the_study_beside_the_suite(self):
        with (self.out / "fig2_scores_study.csv").open() as f:
            rows = {(r["set"], r["method"], r["demos"]): r for r in csv.DictReader(f)}
        self.assertAlmostEqual(float(rows[("gravity", "maps", "10")]["mean"]), 0.3)
        self.assertEqual(rows[("gravity", "maps", "10")]["seeds"], "2")
        self.assertNotIn(("mt10", "single_bc", "10"), rows)
        self.assertIn(("mt10", "single_bc", "5"), rows)
        with (self.out / "fig2_scores.csv").open() as f:  # the suite's own numbers stay apart
            self.assertAlmostEqual(float(next(r for r in csv.DictReader(f) if (r["set"], r["method"], r["demos"])
                                              == ("gravity", "maps", "10"))["mean"]), 0.85)
        with (self.out / "fig4_ablations_study.csv").open() as f:
            self.assertIn("maps (no_explore)", {r["variant"] for r in csv.DictReader(f)})
        self.assertIn("Hollow markers on dashed lines: the study's scores", between(self.md, "![](fig2_scores.png)",
                                                                                   "##"))
        self.assertIn("Right, hollow markers on dashed lines", between(self.md, "![](fig4_ablations.png)", "##"))

    def test_a_missing_study_is_one_line_not_an_error(self):
        with tempfile.TemporaryDirectory() as tmp:
            missing = pathlib.Path(tmp) / "no-study"
            code, stdout, stderr = run_report(FIXTURE, pathlib.Path(tmp) / "report", study=missing)
            self.assertEqual(code, 0, stderr)
            self.assertNotIn("Traceback", stderr)
            notes = [line for line in stdout.splitlines() if "not beside" in line]
            self.assertEqual(notes, [f"report: the study's numbers are not beside this quick-scale suite's: no study at"
                                     f" {missing} (no suite.json there)"])
            md = (pathlib.Path(tmp) / "report" / "report.md").read_text()
            self.assertIn(self.WARNING, md.splitlines()[2])
            self.assertIn(f"(The study's numbers are not beside this suite's: no study at {missing}", md)
            self.assertEqual(row_of(md, ["gravity", "maps", "10"])[5:], ["0.85 +- 0.64"])
            self.assertFalse((pathlib.Path(tmp) / "report" / "fig2_scores_study.csv").exists())

    def test_the_installed_scripts_have_no_study_and_say_so(self):
        """Installed under share/maps/experiments/ there is no results/study: the default study is skipped with a note
        (the line test_a_missing_study_is_one_line_not_an_error sees printed)."""
        with tempfile.TemporaryDirectory() as tmp:
            share = pathlib.Path(tmp) / "share" / "maps"
            for folder in ("report", "process"):
                shutil.copytree(ROOT / "experiments" / folder, share / "experiments" / folder,
                                ignore=shutil.ignore_patterns("*.cpp", "*.h", "__pycache__"))
            script = (f"import sys\nsys.path.insert(0, {str(share / 'experiments' / 'report')!r})\n"
                      f"import report, suite_results\nprint(report.__file__)\n"
                      f"beside = report.beside_study(suite_results.load_suite({str(FIXTURE)!r}))\n"
                      "print(beside.quick, len(beside.cells))\nprint(beside.note)")
            done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
            self.assertEqual(done.returncode, 0, done.stderr)
            where, counts, note = done.stdout.splitlines()
            self.assertTrue(where.startswith(str(share)), where)
            self.assertEqual(counts, "True 0")
            self.assertEqual(note, f"no study at {share / 'results' / 'study'} (no suite.json there; outside a checkout"
                                   " the report scripts have no results/, and --study DIR names one)")

    def test_a_suite_at_the_studys_scale_is_not_compared(self):
        import report
        beside = report.beside_study(suite_results.load_suite(self.study), FIXTURE)
        self.assertEqual((beside.quick, beside.longest, beside.steps, beside.cells, beside.note),
                         (False, 20000, 1000, [], ""))
        no_figures = type("NoFigures", (), {"failed": [], "__call__": lambda self, name, **extra: []})()
        lines = report.report_lines(suite_results.load_suite(self.study), no_figures, beside)
        self.assertNotIn(self.WARNING, "\n".join(lines))
        self.assertEqual(row_of("\n".join(lines), ["gravity", "maps", "10"])[5:], ["0.30 +- 1.27"])

    def test_the_committed_study_is_the_default(self):
        """Without --study the numbers are results/study's, read as its own report reads them (its main table)."""
        import report
        committed = report.DEFAULT_STUDY / "report" / "report.md"
        if not committed.is_file():
            self.skipTest(f"no {committed}")
        suite = suite_results.load_suite(FIXTURE)
        beside = report.beside_study(suite)
        self.assertEqual(beside.note, "")
        table = "\n".join(report.main_results_beside(suite.cells, beside))
        theirs = between(committed.read_text(), "## Main results", "\n## ")
        for set_name, method, demos, at in (("gravity", "maps", "10", "10"), ("mt10", "mt_bc", "10", "14")):
            row = row_of(theirs, [set_name, method, at])
            where = "" if demos == at else f", at {at} demos"
            self.assertEqual(row_of(table, [set_name, method, demos])[6], f"{row[5]} (n={row[4]}{where})")

    def test_the_nearest_count_and_the_scale_rule(self):
        import report
        key = suite_results.GroupKey("gravity", "maps", 10, 10)
        study = {key._replace(demos=d): [d] for d in (5, 15, 25)}
        self.assertEqual(report.study_number(key, study), ([15], 15))  # a tie goes to the larger count
        self.assertEqual(report.study_number(key._replace(demos=24), study), ([25], 25))
        self.assertIsNone(report.study_number(key._replace(subsample=1), study))
        self.assertIsNone(report.study_number(key._replace(label="maps (m5)"), study))
        self.assertEqual(report.QUICK_SHARE * report.STUDY_STEPS, 5000)  # medium.json's 5000 steps are quick-scale


class Errors(unittest.TestCase):
    def test_a_damaged_result_is_named_and_skipped(self):
        with tempfile.TemporaryDirectory() as tmp:
            suite = pathlib.Path(tmp) / "suite"
            shutil.copytree(FIXTURE, suite)
            truncated = suite / "cells" / "mt10" / "single_bc_d5_s1" / "result.json"
            truncated.write_text(truncated.read_text()[:200])
            no_eval = suite / "cells" / "gravity" / "maps_d10_s1" / "result.json"
            no_eval.write_text('{"format": "maps-suite-cell/1", "cell": {}}')
            # A stale result: trained with another run config than suite.json lists for the cell.
            stale = suite / "cells" / "mt10" / "maps-m5_d5_s0" / "result.json"
            result = json.loads(stale.read_text())
            result["config"]["train"]["steps"] = 500
            stale.write_text(json.dumps(result))
            # A score that is not a number (Python's json writes NaN) and module usage of another length.
            not_a_number = suite / "cells" / "gravity" / "mt_bc_d5_s1" / "result.json"
            result = json.loads(not_a_number.read_text())
            result["eval"]["tasks"][0]["score"] = float("nan")
            not_a_number.write_text(json.dumps(result))
            short_usage = suite / "cells" / "mt10" / "maps_d10_s1" / "result.json"
            result = json.loads(short_usage.read_text())
            result["eval"]["tasks"][1]["module_usage"] = result["eval"]["tasks"][1]["module_usage"][:-1]
            short_usage.write_text(json.dumps(result))
            code, stdout, stderr = run_report(suite)  # OUT defaults to DIR/report
            self.assertEqual(code, 0, stderr)
            self.assertNotIn("Traceback", stderr)
            self.assertIn(str(truncated), stderr)
            md = (suite / "report" / "report.md").read_text()
            self.assertIn("31 finished, 1 missing (not run or not finished), 1 failed, 5 damaged", md)
            # The reasons are the tool's (`maps suite status --json`), which decides what counts (issue 42).
            self.assertIn(f"- `{not_a_number}`: unreadable ('{not_a_number}' is not valid JSON", md)
            self.assertIn(f"- `{short_usage}`: task mt10/push: module_usage is not a distribution over the same"
                          " modules as mt10/reach's", md)
            self.assertIn(f"- `{truncated}`: unreadable ('{truncated}' is not valid JSON", md)
            self.assertIn(f"- `{no_eval}`: names another cell", md)
            self.assertIn(f"- `{stale}`: was trained with another run config", md)
            self.assertEqual(row_of(stdout, ["mt10", "single_bc", "5"])[4:], ["1", "0.50"])
            with (suite / "report" / "results.csv").open() as f:
                cells = {row["cell"] for row in csv.DictReader(f)}
            self.assertEqual(len(cells), 31)
            self.assertFalse({"mt10/single_bc_d5_s1", "gravity/maps_d10_s1", "mt10/maps-m5_d5_s0",
                              "gravity/mt_bc_d5_s1", "mt10/maps_d10_s1"} & cells)

    def test_report_settings_edited_into_suite_json_are_refused_by_name(self):
        cases = [({"compare": ["maps-mt_bc"]}, 'config.report.compare[0]: expected "A - B", got \'maps-mt_bc\''),
                 ({"compare": "maps - mt_bc"}, 'config.report.compare: expected a list of "A - B" strings'),
                 ({"holm": "family"}, 'config.report.holm: expected "variant" or "set", got \'family\''),
                 (["set"], "config.report: expected an object")]
        for report_config, message in cases:
            with tempfile.TemporaryDirectory() as tmp:
                suite = pathlib.Path(tmp) / "suite"
                shutil.copytree(FIXTURE, suite)
                listed = json.loads((suite / "suite.json").read_text())
                listed.setdefault("config", {})["report"] = report_config
                (suite / "suite.json").write_text(json.dumps(listed))
                code, _, stderr = run_report(suite)
                self.assertEqual(code, 2, stderr)
                self.assertNotIn("Traceback", stderr)
                self.assertIn(f"{suite / 'suite.json'}: {message}", stderr)

    def test_json_nested_too_deep_is_refused_by_name(self):
        """Issue 41: a suite folder's JSON nested past 64 levels of arrays and objects inside each other is refused
        naming the file, as the C++ readers refuse it, rather than ending in a RecursionError traceback (100000
        levels) or being read (65); 64 levels are read. The report, more_seeds.py and compare_suites.py."""
        too_deep = "nests JSON deeper than 64 levels (arrays and objects inside each other)"

        def nest(path, levels):
            # The object itself is level 1, the arrays under one of its keys the levels below it.
            text = json.dumps(json.loads(path.read_text()))
            path.write_text(text[:-1] + ', "nested": ' + "[" * (levels - 1) + "]" * (levels - 1) + "}")

        with tempfile.TemporaryDirectory() as tmp:
            suite = pathlib.Path(tmp) / "suite"
            shutil.copytree(FIXTURE, suite)
            very_deep = suite / "cells" / "mt10" / "single_bc_d5_s1" / "result.json"
            very_deep.write_text("[" * 100000 + "]" * 100000)
            one_too_deep = suite / "cells" / "gravity" / "maps_d10_s1" / "result.json"
            nest(one_too_deep, 65)
            nest(suite / "cells" / "gravity" / "mt_bc_d5_s1" / "result.json", 64)
            failed = suite / "cells" / "gravity" / "mt_bc_d10_s1" / "error.json"
            failed.write_text('{"stage": ' + "[" * 100000 + "]" * 100000 + "}")
            code, stdout, stderr = run_report(suite)
            self.assertEqual(code, 0, stderr)
            self.assertNotIn("Traceback", stderr)
            for path in (very_deep, one_too_deep):
                self.assertIn(f"report: {path}: damaged result, skipped (unreadable ('{path}' {too_deep}", stderr)
            md = (suite / "report" / "report.md").read_text()
            self.assertIn("34 finished, 1 missing (not run or not finished), 1 failed, 2 damaged", md)
            self.assertIn(f"unreadable error.json ('{failed}' {too_deep}", md)

            more_seeds_config = pathlib.Path(tmp) / "deep_config.json"
            more_seeds_config.write_text('{"grids": ' + "[" * 100000 + "]" * 100000 + "}")
            done = subprocess.run([sys.executable, str(REPORT_DIR / "more_seeds.py"), str(suite), str(more_seeds_config)],
                                  capture_output=True, text=True, timeout=120)
            self.assertEqual(done.returncode, 2, done.stderr)
            self.assertIn(f"{more_seeds_config} {too_deep}", done.stderr)
            self.assertNotIn("Traceback", done.stderr)

            done = subprocess.run([sys.executable, str(ROOT / "experiments" / "cluster" / "compare_suites.py"),
                                   str(FIXTURE), str(suite)], capture_output=True, text=True, timeout=120)
            # The tool decides that a too deep result does not count; compare_suites says which and why.
            self.assertEqual(done.returncode, 1, done.stdout + done.stderr)
            self.assertRegex(done.stdout, "DIFFER: cell .* is finished in .* but not in .*; there its result does not "
                             f"count: .*/result.json: unreadable \\('.*/result.json' {re.escape(too_deep)}")
            self.assertNotIn("Traceback", done.stderr)

            suite_json = suite / "suite.json"
            suite_json.write_text("[" * 100000 + "]" * 100000)
            code, stdout, stderr = run_report(suite)
            self.assertEqual(code, 2, stderr)
            self.assertIn(f"{suite_json} {too_deep}", stderr)
            self.assertNotIn("Traceback", stderr)

    def test_a_status_file_that_is_missing_or_no_status_is_named(self):
        """report.py --status FILE (what `maps report` passes): a missing file, damaged JSON or another JSON is
        refused naming the file, and nothing is written."""
        with tempfile.TemporaryDirectory() as tmp:
            tmp = pathlib.Path(tmp)
            for name, text, said in (("missing.json", None, "unreadable"), ("damaged.json", "{", "unreadable"),
                                     ("other.json", '{"format": "maps-suite/1", "cells": []}',
                                      "not a maps-suite-status/1 status")):
                status = tmp / name
                if text is not None:
                    status.write_text(text)
                out = tmp / ("report-" + name)
                code, _, stderr = run_report(FIXTURE, out, "--status", status)
                self.assertEqual(code, 2, stderr)
                self.assertIn(f"{status}", stderr)
                self.assertIn(said, stderr)
                self.assertNotIn("Traceback", stderr)
                self.assertFalse(out.exists())

    def test_a_folder_without_suite_json_says_so(self):
        with tempfile.TemporaryDirectory() as tmp:
            code, stdout, stderr = run_report(tmp)
            self.assertEqual(code, 2)
            self.assertIn(str(pathlib.Path(tmp) / "suite.json"), stderr)
            self.assertNotIn("Traceback", stderr)

    def test_a_suite_with_nothing_finished_says_so(self):
        with tempfile.TemporaryDirectory() as tmp:
            suite = pathlib.Path(tmp)
            shutil.copy(FIXTURE / "suite.json", suite / "suite.json")
            failed = suite / "cells" / "gravity" / "maps_d5_s0"
            failed.mkdir(parents=True)
            (failed / "error.json").write_text('{"stage": "eval", "error": "no checkpoint"}')
            code, stdout, stderr = run_report(suite)
            self.assertEqual(code, 2)
            self.assertIn(f"{suite}: no finished cells", stderr)
            self.assertIn("38 planned, 1 failed", stderr)
            self.assertFalse((suite / "report").exists())

    def test_a_missing_matplotlib_says_what_to_install(self):
        with tempfile.TemporaryDirectory() as tmp:
            code, stdout, stderr = run_report(FIXTURE, tmp, env_prelude="import sys\nsys.modules['matplotlib'] = None")
            self.assertEqual(code, 2)
            self.assertIn("python3-matplotlib", stderr)
            self.assertNotIn("Traceback", stderr)


class CompareSuites(unittest.TestCase):
    """compare_suites.py --whole: every value of every result.json and report/results.csv, times aside (issue 42's
    before/after check of a change that must not alter behaviour)."""

    def compare(self, *args):
        done = subprocess.run([sys.executable, str(ROOT / "experiments" / "cluster" / "compare_suites.py"),
                               *map(str, args)], capture_output=True, text=True, timeout=120)
        return done.returncode, done.stdout + done.stderr

    def test_times_hosts_and_commits_aside_every_value_counts(self):
        with tempfile.TemporaryDirectory() as tmp:
            copy = pathlib.Path(tmp) / "suite"
            shutil.copytree(FIXTURE, copy)
            path = copy / "cells" / "gravity" / "maps_d10_s1" / "result.json"
            result = json.loads(path.read_text())
            result["wall_seconds"] = 1.0
            result["host"] = "elsewhere"
            result["eval"]["seconds"] = 2.0
            path.write_text(json.dumps(result))
            code, out = self.compare("--whole", FIXTURE, copy)
            self.assertEqual(code, 0, out)
            self.assertIn("every value but times, hosts, dates and commits", out)
            result["train"]["best_step"] = result["train"]["best_step"] + 1
            path.write_text(json.dumps(result))
            self.assertEqual(self.compare(FIXTURE, copy)[0], 0)  # the scores alone agree
            code, out = self.compare("--whole", FIXTURE, copy)
            self.assertEqual(code, 1, out)
            self.assertIn("DIFFER: cell gravity/maps_d10_s1: .train.best_step", out)

    def test_results_csv_is_compared_row_by_row_times_aside(self):
        with tempfile.TemporaryDirectory() as tmp:
            a, b = pathlib.Path(tmp) / "a", pathlib.Path(tmp) / "b"
            for root in (a, b):
                shutil.copytree(FIXTURE, root)
                (root / "report").mkdir()
            header = "set,method,seed,score,wall_seconds\n"
            (a / "report" / "results.csv").write_text(header + "mt10,maps,0,0.5,10\n")
            (b / "report" / "results.csv").write_text(header + "mt10,maps,0,0.5,99\n")
            code, out = self.compare("--whole", a, b)
            self.assertEqual(code, 0, out)
            self.assertIn("report/results.csv: 1 rows identical", out)
            (b / "report" / "results.csv").write_text(header + "mt10,maps,0,0.6,10\n")
            code, out = self.compare("--whole", a, b)
            self.assertEqual(code, 1, out)
            self.assertIn("results.csv row 2 (None), score: '0.5' != '0.6'", out)


class CurveStats(unittest.TestCase):
    """experiments/report/curve_stats.py: the curve statistics docs/results.md quotes."""

    def run_tool(self, *args):
        done = subprocess.run([sys.executable, str(REPORT_DIR / "curve_stats.py"), *map(str, args)], capture_output=True,
                              text=True, timeout=120)
        return done.returncode, done.stdout, done.stderr

    def test_ranges_over_seeds_of_the_validation_and_selector_terms(self):
        with tempfile.TemporaryDirectory() as tmp:
            suite = pathlib.Path(tmp) / "suite"
            shutil.copytree(FIXTURE, suite)
            header = "step,bc,share,explore,sparse,smooth,total,validation_bc,steps_per_second\n"
            cells = suite / "cells" / "gravity"
            # Seed 0: best 0.05 at 500, ends at 0.08 (1.6x); explore 0.25 at the end: 10 / 1.25 = 8.0 modules.
            (cells / "maps_d5_s0" / "curve.csv").write_text(
                header + "250,1,0,0.1,0.80,0,1,0.10,40\n500,1,0,0.1,0.70,0,1,0.05,40\n1000,1,0,0.25,0.50,0,1,0.08,40\n")
            # Seed 1: best 0.04 at 250, ends at 0.04 (1.0x); explore 0 at the end: all 10 modules.
            (cells / "maps_d5_s1" / "curve.csv").write_text(
                header + "250,1,0,0.1,0.82,0,1,0.04,40\n1000,1,0,0,0.30,0,1,0.04,40\n")
            (cells / "single_bc_d5_s1" / "curve.csv").unlink()
            code, stdout, stderr = self.run_tool(suite, "--set", "gravity")
            self.assertEqual(code, 0, stderr)
            self.assertEqual(row_of(stdout, ["gravity", "maps", "5"])[3:],
                             ["2", "0.040-0.050", "250-500", "1.0-1.6", "0.040-0.080", "8.0-10.0",
                              "0.800-0.820 -> 0.300-0.500"])
            # A baseline has no selector terms; the cell without a curve is named and left out of its group.
            self.assertEqual(row_of(stdout, ["gravity", "single_bc", "5"])[3], "1")
            self.assertEqual(row_of(stdout, ["gravity", "single_bc", "5"])[-2:], ["-", "-"])
            self.assertIn("left out: gravity/single_bc_d5_s1", stderr)
            self.assertEqual(rows_of(stdout, ["mt10"]), [])
            code, stdout, stderr = self.run_tool(suite, "--set", "gravity", "--seeds", "1")
            self.assertEqual(row_of(stdout, ["gravity", "maps", "5"])[3:5], ["1", "0.040"])

    def test_bad_arguments_are_named(self):
        code, stdout, stderr = self.run_tool(FIXTURE, "--seeds", "0,x")
        self.assertEqual(code, 2)
        self.assertIn("--seeds '0,x': expected comma-separated integers", stderr)
        code, stdout, stderr = self.run_tool(FIXTURE, "--set", "nope")
        self.assertEqual(code, 2)
        self.assertIn("no finished cells", stderr)
        self.assertIn("('gravity', 'maps')", stderr)
        with tempfile.TemporaryDirectory() as tmp:
            code, stdout, stderr = self.run_tool(tmp)
            self.assertEqual(code, 2)
            self.assertIn("suite.json", stderr)
            self.assertNotIn("Traceback", stderr)

class MoreSeeds(unittest.TestCase):
    """experiments/report/more_seeds.py: docs/zoo.md's "5 seeds where the intervals overlap", on the fixture."""
    # The fixture's grids in a config's list form (its suite.json keeps an older form); seeds 0-1 ran.
    CONFIG = {"sets": {"gravity": {"demos": [5, 10]}, "mt10": {"demos": [5, 10]}}, "grids": [
        {"name": "comparison", "sets": ["gravity", "mt10"], "methods": ["maps", "single_bc", "mt_bc"],
         "seeds": [0, 1]},
        {"name": "controls", "sets": ["gravity"], "methods": ["mt_bc"], "variants": ["w430"], "demos": [5],
         "seeds": [0, 1]},
        {"name": "paper_protocol", "sets": ["mt10"], "methods": ["maps", "mt_bc"], "variants": ["paper_protocol"],
         "demos": [5], "seeds": [0, 1]},
        {"name": "five_seeds", "sets": ["mt10"], "methods": ["mt_bc"], "demos": [5], "seeds": [0, 1, 2]}]}

    def run_tool(self, suite, config, *args):
        done = subprocess.run([sys.executable, str(REPORT_DIR / "more_seeds.py"), str(suite), str(config), *args],
                              capture_output=True, text=True, timeout=120)
        return done.returncode, done.stdout, done.stderr

    def assert_a_repeat_adds_nothing(self, suite, config):
        grids = json.loads(config.read_text())["grids"]
        code, stdout, stderr = self.run_tool(suite, config, "--seeds", "2,3", "--write")
        self.assertEqual(code, 0, stderr)
        self.assertIn("no grids to add", stdout)
        self.assertEqual(json.loads(config.read_text())["grids"], grids)

    def test_write_keeps_the_files_indent_so_the_diff_is_the_new_grids(self):
        for indent in (1, 2, 4):
            with tempfile.TemporaryDirectory() as tmp:
                config = pathlib.Path(tmp) / "c.json"
                config.write_text(json.dumps(self.CONFIG, indent=indent) + "\n")
                code, _, stderr = self.run_tool(FIXTURE, config, "--seeds", "2,3", "--write")
                self.assertEqual(code, 0, stderr)
                written = json.loads(config.read_text())
                self.assertGreater(len(written["grids"]), len(self.CONFIG["grids"]))
                self.assertEqual(config.read_text(), json.dumps(written, indent=indent) + "\n", indent)

    def test_overlapping_settings_get_the_new_seeds_with_their_maps(self):
        with tempfile.TemporaryDirectory() as tmp:
            config = pathlib.Path(tmp) / "c.json"
            config.write_text(json.dumps(self.CONFIG))
            code, stdout, stderr = self.run_tool(FIXTURE, config, "--seeds", "2,3")
            self.assertEqual(code, 0, stderr)
            # Paired with MAPS as report.md pairs (test_paired_differences_from_maps_use_the_same_seeds).
            self.assertIn("- comparison, gravity at 5: single_bc - maps -0.15 +- 1.91 (2 pairs): more seeds", stdout)
            self.assertIn("- controls, gravity at 5: mt_bc (w430) - maps -0.05 +- 0.64 (2 pairs): more seeds", stdout)
            self.assertIn("- paper_protocol, mt10 at 5: mt_bc (paper_protocol) - maps (paper_protocol) -0.05 +- 0.64"
                          " (2 pairs): more seeds", stdout)
            # A failed or unfinished cell holds its method back, not the setting's others; a grid that runs seed 2
            # already is not judged.
            self.assertIn("- comparison, gravity at 10: mt_bc: not ready (1 cells not finished (failed or to run), e.g."
                          " gravity/mt_bc_d10_s1)", stdout)
            self.assertIn("- comparison, gravity at 10: single_bc - maps -0.15 +- 1.27 (2 pairs): more seeds", stdout)
            self.assertIn("- comparison, mt10 at 10: mt_bc: not ready (1 cells not finished", stdout)
            self.assertNotIn("five_seeds", stdout)
            self.assertEqual(json.loads(config.read_text()), self.CONFIG)  # not written without --write
            code, stdout, stderr = self.run_tool(FIXTURE, config, "--seeds", "2,3", "--write")
            self.assertEqual(code, 0, stderr)
            grids = {g["name"]: g for g in json.loads(config.read_text())["grids"]}
            # Exactly the cells asked for: at 10 demos MT-BC is not ready, so only Single BC and its MAPS get seeds.
            added = [(g["sets"], g["methods"], g["demos"]) for name, g in grids.items()
                     if name.startswith("comparison_seeds_2_3")]
            self.assertEqual(added, [(["gravity"], ["maps", "single_bc", "mt_bc"], {"gravity": [5]}),
                                     (["gravity"], ["maps", "single_bc"], {"gravity": [10]}),
                                     (["mt10"], ["maps", "single_bc", "mt_bc"], {"mt10": [5]}),
                                     (["mt10"], ["maps", "single_bc"], {"mt10": [10]})])
            self.assertEqual([name for name in grids if name.startswith("comparison_seeds")],
                             [f"comparison_seeds_2_3_{i}" for i in range(1, 5)])
            self.assertEqual(grids["comparison_seeds_2_3_1"]["seeds"], [2, 3])
            # The width control has no MAPS of its own: base MAPS's grid (comparison) runs MAPS there.
            self.assertEqual(grids["controls_seeds_2_3"]["methods"], ["mt_bc"])
            self.assertEqual(grids["controls_seeds_2_3"]["variants"], ["w430"])
            self.assertEqual(grids["paper_protocol_seeds_2_3"]["methods"], ["maps", "mt_bc"])
            self.assertEqual(grids["paper_protocol_seeds_2_3"]["variants"], ["paper_protocol"])
            # A second run adds nothing twice.
            self.assert_a_repeat_adds_nothing(FIXTURE, config)

    def test_a_base_methods_new_seeds_planned_as_a_keep_only_variant_count_as_planned(self):
        planned = {"mt10/maps-keep2500_d2_s3", "mt10/maps-keep2500_d2_s4", "mt10/maps_d14_s3"}
        self.assertTrue(more_seeds.planned_already("mt10", "maps", None, 2, [3, 4], planned))
        self.assertFalse(more_seeds.planned_already("mt10", "maps", None, 2, [3, 4, 5], planned))
        self.assertFalse(more_seeds.planned_already("mt10", "maps", "chunk16", 2, [3, 4], planned))
        self.assertFalse(more_seeds.planned_already("mt10", "maps", None, 14, [3, 4], planned))
        self.assertTrue(more_seeds.planned_already("mt10", "maps", None, 14, [3], planned))

    def test_a_comparison_the_config_names_gets_seeds_where_its_interval_includes_0(self):
        # MAPS at Gravity 5 moved up so that both methods' differences from it are separated (Single BC's -0.90 on
        # both seeds, MT-BC's -0.80 and -0.90), while Single BC - MT-BC (-0.10, 0.00) is not: report.compare's entry
        # alone asks for the new seeds, of its two rows only.
        with tempfile.TemporaryDirectory() as tmp:
            suite_dir = pathlib.Path(tmp) / "suite"
            shutil.copytree(FIXTURE, suite_dir)
            for name, scores in (("maps_d5_s0", [1.4, 1.2]), ("maps_d5_s1", [1.5, 1.3]), ("mt_bc_d5_s1", [0.6, 0.4])):
                path = suite_dir / "cells" / "gravity" / name / "result.json"
                result = json.loads(path.read_text())
                for task, score in zip(result["eval"]["tasks"], scores):
                    task["score"] = score
                result["eval"]["mean_score"] = sum(scores) / len(scores)
                path.write_text(json.dumps(result))
            grid = dict(self.CONFIG["grids"][0], sets=["gravity"], demos=[5])
            config = pathlib.Path(tmp) / "c.json"
            config.write_text(json.dumps(dict(self.CONFIG, grids=[grid])))
            code, stdout, stderr = self.run_tool(suite_dir, config, "--seeds", "2,3")
            self.assertEqual(code, 0, stderr)
            self.assertIn("- comparison, gravity at 5: single_bc - maps -0.90 +- 0.00 (2 pairs): separated, stays",
                          stdout)
            self.assertIn("- comparison, gravity at 5: mt_bc - maps -0.85 +- 0.64 (2 pairs): separated, stays", stdout)
            self.assertIn("no grids to add", stdout)
            config.write_text(json.dumps(dict(self.CONFIG, grids=[grid], report={"compare": ["single_bc - mt_bc"]})))
            code, stdout, stderr = self.run_tool(suite_dir, config, "--seeds", "2,3", "--write")
            self.assertEqual(code, 0, stderr)
            self.assertIn("- compare single_bc - mt_bc, gravity at 5: -0.05 +- 0.64 (2 pairs): more seeds", stdout)
            # Judged wherever the suite ran both rows; a setting no grid of the config runs is said, not added.
            self.assertIn("- compare single_bc - mt_bc, gravity at 10: not ready (1 cells not finished", stdout)
            self.assertIn("- compare single_bc - mt_bc, mt10 at 5: +0.15 +- 1.91 (2 pairs): more seeds", stdout)
            self.assertIn("- single_bc at mt10 5: no grid of the config runs it; add its seeds by hand", stdout)
            added = [g for g in json.loads(config.read_text())["grids"] if g["name"] != "comparison"]
            self.assertEqual([(g["name"], g["methods"], g["demos"], g["seeds"]) for g in added],
                             [("comparison_seeds_2_3", ["single_bc", "mt_bc"], {"gravity": [5]}, [2, 3])])
            self.assert_a_repeat_adds_nothing(suite_dir, config)

    def test_a_later_run_adds_the_settings_that_were_not_ready(self):
        # The first run adds what it can judge; MT-BC at Gravity 10 waits for its failed seed 1. Once that cell has
        # finished (and suite.json plans MAPS's new seeds there, unfinished), a second run judges MT-BC over the
        # grid's seeds 0-1 only and adds its seeds alone, in a grid numbered after the first run's.
        with tempfile.TemporaryDirectory() as tmp:
            config = pathlib.Path(tmp) / "c.json"
            config.write_text(json.dumps(self.CONFIG))
            code, _, stderr = self.run_tool(FIXTURE, config, "--seeds", "2,3", "--write")
            self.assertEqual(code, 0, stderr)
            first = [g["name"] for g in json.loads(config.read_text())["grids"]]
            suite_dir = pathlib.Path(tmp) / "suite"
            shutil.copytree(FIXTURE, suite_dir)
            failed = suite_dir / "cells" / "gravity" / "mt_bc_d10_s1"
            result = json.loads((suite_dir / "cells" / "gravity" / "mt_bc_d10_s0" / "result.json").read_text())
            result["cell"].update(name="gravity/mt_bc_d10_s1", seed=1)
            result["config"]["seed"] = 1
            (failed / "error.json").unlink(missing_ok=True)
            (failed / "result.json").write_text(json.dumps(result))
            suite = json.loads((suite_dir / "suite.json").read_text())
            maps_s2 = json.loads(json.dumps(next(c for c in suite["cells"] if c["name"] == "gravity/maps_d10_s1")))
            maps_s2.update(index=len(suite["cells"]), name="gravity/maps_d10_s2", seed=2,
                           grid="comparison_seeds_2_3_2")
            suite["cells"].append(maps_s2)
            (suite_dir / "suite.json").write_text(json.dumps(suite))
            code, stdout, stderr = self.run_tool(suite_dir, config, "--seeds", "2,3", "--write")
            self.assertEqual(code, 0, stderr)
            self.assertRegex(stdout, r"- comparison, gravity at 10: mt_bc - maps [-+]\d\.\d\d \+- \d+\.\d\d"
                                     r" \(2 pairs\): more seeds")
            grids = json.loads(config.read_text())["grids"]
            self.assertEqual([g["name"] for g in grids[:len(first)]], first)  # the first run's grids unchanged
            self.assertEqual([(g["name"], g["methods"], g["demos"]) for g in grids[len(first):]],
                             [("comparison_seeds_2_3_5", ["mt_bc"], {"gravity": [10]})])
            # Nothing twice: a third run adds nothing.
            self.assert_a_repeat_adds_nothing(suite_dir, config)

    def test_a_variant_waits_for_its_own_maps_rather_than_judging_against_base(self):
        # The paper-protocol grid's MAPS cells not finished yet: MT-BC under that protocol is paired with them once
        # they are, so it waits, and is not judged against base MAPS (a grid of base MAPS would be added every run).
        with tempfile.TemporaryDirectory() as tmp:
            suite_dir = pathlib.Path(tmp) / "suite"
            shutil.copytree(FIXTURE, suite_dir)
            for path in suite_dir.glob("cells/mt10/maps-paper_protocol_d5_s*/result.json"):
                path.unlink()
            config = pathlib.Path(tmp) / "c.json"
            config.write_text(json.dumps(dict(self.CONFIG, grids=[self.CONFIG["grids"][2]])))
            for _ in range(2):
                code, stdout, stderr = self.run_tool(suite_dir, config, "--seeds", "2,3", "--write")
                self.assertEqual(code, 0, stderr)
                self.assertIn("- paper_protocol, mt10 at 5: mt_bc (paper_protocol): not ready (2 cells not finished"
                              " (failed or to run), e.g. mt10/maps-paper_protocol_d5_s0)", stdout)
                self.assertIn("no grids to add", stdout)
            self.assertEqual(len(json.loads(config.read_text())["grids"]), 1)

    def test_a_grids_cells_are_the_ones_its_suite_plans_and_keep_only_variants_pair_as_base(self):
        # Results copied from another suite name that suite's grid: they are judged under the grid that plans them.
        # MT10's base cells become keep500 cells (train.keep_every only): they stand for the base, paired with MAPS.
        with tempfile.TemporaryDirectory() as tmp:
            suite_dir = pathlib.Path(tmp) / "suite"
            shutil.copytree(FIXTURE, suite_dir)
            for path in suite_dir.glob("cells/*/*/result.json"):
                result = json.loads(path.read_text())
                result["cell"]["grid"] = "the_study_grid"
                path.write_text(json.dumps(result))
            suite = json.loads((suite_dir / "suite.json").read_text())
            for cell in suite["cells"]:
                if cell["name"].startswith("mt10/") and cell["variant"] == "base" and cell["grid"] == "comparison":
                    old = suite_dir / "cells" / cell["name"]
                    cell.update(variant="keep500", grid="comparison_mt10")
                    cell["name"] = cell["name"].replace("_d", "-keep500_d", 1)
                    if old.exists():
                        result_path = old / "result.json"
                        if result_path.exists():
                            result = json.loads(result_path.read_text())
                            result["cell"].update(name=cell["name"], variant="keep500")
                            result_path.write_text(json.dumps(result))
                        old.rename(suite_dir / "cells" / cell["name"])
            (suite_dir / "suite.json").write_text(json.dumps(suite))
            beside = suite_dir / "cells" / "gravity" / "maps-keep500_d5_s0"
            beside.mkdir()
            result = json.loads((suite_dir / "cells" / "gravity" / "maps_d5_s0" / "result.json").read_text())
            result["cell"].update(name="gravity/maps-keep500_d5_s0", variant="keep500")
            (beside / "result.json").write_text(json.dumps(result))
            plan_cell(suite_dir, result)
            config = pathlib.Path(tmp) / "c.json"
            comparison = self.CONFIG["grids"][0]
            config.write_text(json.dumps(dict(self.CONFIG, grids=[
                dict(comparison, sets=["gravity"]),
                dict(comparison, name="comparison_mt10", sets=["mt10"], variants=["keep500"])])))
            code, stdout, stderr = self.run_tool(suite_dir, config, "--seeds", "2,3")
            self.assertEqual(code, 0, stderr)
            self.assertIn("- comparison, gravity at 5: single_bc - maps -0.15 +- 1.91 (2 pairs): more seeds", stdout)
            self.assertIn("- comparison_mt10, mt10 at 5: single_bc - maps -0.10 +- 1.27 (2 pairs): more seeds",
                          stdout)
            grids = json.loads(re.search(r"grids to add \(\d+\):\n(.*)", stdout, re.S).group(1))
            # MAPS's new seeds are its keep500 cells, in the grid that runs them.
            mt10 = next(g for g in grids if g["sets"] == ["mt10"] and g["demos"] == {"mt10": [5]})
            self.assertEqual((mt10["name"], mt10["methods"], mt10["variants"]),
                             ("comparison_mt10_seeds_2_3_1", ["maps", "single_bc", "mt_bc"], ["keep500"]))
            loaded = suite_results.load_suite(suite_dir)
            labels = {c.name: c.label for c in loaded.cells}
            self.assertEqual(labels["mt10/maps-keep500_d5_s0"], "maps")
            self.assertEqual(labels["mt10/single_bc-keep500_d5_s1"], "single_bc")
            # Beside a base cell of the same setting and seed, a keep-only cell is a variant as before.
            self.assertEqual(labels["gravity/maps-keep500_d5_s0"], "maps (keep500)")
            out = pathlib.Path(tmp) / "report"
            code, _, stderr = run_report(suite_dir, out)
            self.assertEqual(code, 0, stderr)
            with (out / "fig2_scores.csv").open() as f:
                drawn = {(r["set"], r["method"], r["demos"]) for r in csv.DictReader(f)}
            self.assertIn(("mt10", "maps", "5"), drawn)
            self.assertIn(("mt10", "single_bc", "10"), drawn)

    def test_counts_as_maps_suite_reads_them(self):
        sets = {"sets": {"gravity": {"demos": [5, 25]}, "mt10": {"demos": [2]}}}
        self.assertEqual(more_seeds.grid_demos(sets, {"demos": {"mt10": [14]}}, "mt10"), [14])
        self.assertEqual(more_seeds.grid_demos(sets, {"demos": {"mt10": [14]}}, "gravity"), [5, 25])  # the set's
        self.assertEqual(more_seeds.grid_demos(sets, {"demos": [10]}, "gravity"), [10])
        self.assertEqual(more_seeds.grid_demos(sets, {}, "mt10"), [2])

    def test_bad_input_is_named(self):
        with tempfile.TemporaryDirectory() as tmp:
            config = pathlib.Path(tmp) / "c.json"
            config.write_text("{not json")
            code, stdout, stderr = self.run_tool(FIXTURE, config)
            self.assertEqual(code, 2)
            self.assertIn(f"{config}: unreadable", stderr)
            config.write_text('{"grids": {"a": {}}}')
            code, stdout, stderr = self.run_tool(FIXTURE, config)
            self.assertEqual(code, 2)
            self.assertIn('expected a suite config with a "grids" list', stderr)
            config.write_text(json.dumps(self.CONFIG))
            code, stdout, stderr = self.run_tool(FIXTURE, config, "--seeds", "three")
            self.assertEqual(code, 2)
            self.assertIn("--seeds 'three': expected comma-separated integers", stderr)
            code, stdout, stderr = self.run_tool(tmp, config)
            self.assertEqual(code, 2)
            self.assertIn("suite.json", stderr)
            self.assertNotIn("Traceback", stderr)

if __name__ == "__main__":
    unittest.main()
