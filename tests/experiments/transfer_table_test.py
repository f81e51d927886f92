#!/usr/bin/python3
"""Tests of issue 17's tables (experiments/report/transfer_table.py) on a suite folder written here with chosen scores,
module usage, best steps and curves, so that every number the report prints is known: means and intervals over seeds,
paired differences with Holm, the cost from curve.csv, the module comparison against the neighbour and chance, and the
failed, unfinished and left-out cells. Run by ctest (tests/CMakeLists.txt)."""
import json
import pathlib
import subprocess
import sys
import tempfile
import unittest

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

from markdown_rows import rows_of  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "experiments" / "report" / "transfer_table.py"

TASK = "gravity/0.5"  # held out; transfer_table.NEIGHBOUR names gravity/0.75
TRAINED = {"gravity/0.75": [0.8, 0.1, 0.1], "gravity/1.0": [0.1, 0.8, 0.1], "gravity/1.25": [0.1, 0.1, 0.8]}
# (method, demos, seed) -> (score of the new task, best step, the new task's module usage or None); None: failed.
CELLS = {
    ("transfer", 1, 0): (0.5, 0, [0.7, 0.2, 0.1]),  # kept the start
    ("transfer", 1, 1): (0.6, 400, [0.6, 0.3, 0.1]),
    ("transfer", 1, 2): (0.7, 800, [0.2, 0.7, 0.1]),
    ("transfer", 2, 0): (0.8, 1000, [0.9, 0.05, 0.05]),
    ("transfer", 2, 1): (0.9, 1400, [0.8, 0.1, 0.1]),
    # ("transfer", 2, 2) is planned and has not run.
    ("single_bc", 1, 0): (0.3, 600, None),
    ("single_bc", 1, 1): (0.5, 1000, None),
    ("single_bc", 1, 2): None,
    ("single_bc", 2, 0): (0.5, 2000, None),
    ("single_bc", 2, 1): (0.6, 2000, None),
    ("single_bc", 2, 2): (0.7, 2000, None),
}
NEW_STEPS = 2000  # every new-task cell: validation every 200 steps, 0.5 CPU seconds per window
SOURCE_STEPS = 20000  # every source: validation every 5000 steps, 100 CPU seconds per window, best at 5000


def curve(steps, every, cpu):
    rows = ["step,bc,total,validation_bc,steps_per_second,cpu_seconds"]
    rows += [f"{s},0.1,0.1,0.05,100,{cpu}" for s in range(every, steps + 1, every)]
    return "\n".join(rows) + "\n"


def identity(method, variant, demos, seed, grid):
    folder = f"{method}-{variant}_d{demos}_s{seed}"
    return {"name": f"gravity/{folder}", "grid": grid, "set": "gravity", "method": method, "variant": variant,
            "demos": demos, "subsample": 10, "seed": seed}


def task_entry(task, score, usage):
    entry = {"task": task, "episodes": 10, "score": score, "success_rate": 0.0, "return_mean": 1000.0 * score}
    if usage is not None:
        entry["module_usage"] = usage
    return entry


def run_config(method, data, steps, **more):
    """A run config the tool reads (data.file given; a transfer trains MAPS from its source's checkpoint)."""
    return dict({"method": "maps" if method == "transfer" else method, "data": dict({"file": "data/gravity.h5"}, **data),
                 "train": {"steps": steps}}, **more)


def plan(planned, ident, config):
    """ident, as suite.json lists it: its place and the run config it was asked to run."""
    planned.append(dict(ident, index=len(planned), request=config))


def write_cell(root, ident, config, steps, best_step, tasks, curve_text):
    folder = root / "cells" / ident["name"]
    folder.mkdir(parents=True)
    (folder / "curve.csv").write_text(curve_text)
    result = {"format": "maps-suite-cell/1", "cell": ident, "config": config,
              "train": {"steps": steps, "best_step": best_step, "best_validation_bc": 0.05},
              "eval": {"best_step": best_step, "episodes": 10, "seconds": 1.0, "tasks": tasks,
                       "mean_score": sum(t["score"] for t in tasks) / len(tasks)},
              "wall_seconds": 1.0, "threads": 1, "host": "fixture", "cpu": "Fixture CPU",
              "training_attempts": [{"cpu": "Fixture CPU"}], "finished": "2026-01-01T00:00:00Z"}
    (folder / "result.json").write_text(json.dumps(result))


def write_suite(root):
    planned = []
    for seed in range(3):
        ident = identity("maps", "without-0.5", 10, seed, "holdout")
        config = run_config("maps", {"tasks": list(TRAINED)}, SOURCE_STEPS)
        plan(planned, ident, config)
        write_cell(root, ident, config, SOURCE_STEPS, 5000,
                   [task_entry(t, 0.9, u) for t, u in TRAINED.items()], curve(SOURCE_STEPS, 5000, 100))
    for (method, demos, seed), outcome in CELLS.items():
        ident = identity(method, "new-0.5", demos, seed, "new_task_gravity")
        config = run_config(method, {"task_demos": {TASK: demos}}, NEW_STEPS)
        if method == "transfer":
            config["init"] = {"run": f"../maps-without-0.5_d10_s{seed}"}
        plan(planned, ident, config)
        if outcome is None:
            folder = root / "cells" / ident["name"]
            folder.mkdir(parents=True)
            (folder / "error.json").write_text(json.dumps({"stage": "train", "error": "loss is nan at step 250"}))
            continue
        score, best_step, usage = outcome
        write_cell(root, ident, config, NEW_STEPS, best_step, [task_entry(TASK, score, usage)],
                   curve(NEW_STEPS, 200, 0.5))
    plan(planned, identity("transfer", "new-0.5", 2, 2, "new_task_gravity"),
         run_config("transfer", {"task_demos": {TASK: 2}}, NEW_STEPS, init={"run": "../maps-without-0.5_d10_s2"}))
    # Run twice (experiments/suite/run.h, retire_sources_without_checkpoint): source seed 0 and a transfer from it.
    for name, earlier in (("maps-without-0.5_d10_s0", {"best_step": 4000, "best_validation_bc": 0.04, "score": 0.6}),
                          ("transfer-new-0.5_d1_s1", {"best_step": 400, "best_validation_bc": 0.05, "score": 0.2})):
        folder = root / "cells" / "gravity" / name
        result = json.loads((folder / "result.json").read_text())
        result["train"]["best_validation_bc"] = 0.05
        (folder / "result.json").write_text(json.dumps(result))
        result["train"].update(best_step=earlier["best_step"], best_validation_bc=earlier["best_validation_bc"])
        result["eval"]["best_step"] = earlier["best_step"]
        for task in result["eval"]["tasks"]:
            task["score"] = earlier["score"]
        result.update(cpu="Earlier CPU", training_attempts=[{"cpu": "Earlier CPU"}])
        (folder / "replaced" / "2025-12-31T00-00-00Z").mkdir(parents=True)
        (folder / "replaced" / "2025-12-31T00-00-00Z" / "result.json").write_text(json.dumps(result))
        # Earlier results that cannot be compared: one naming another cell, one without the new task's score; and
        # one of a cell not finished again yet.
        if name.startswith("transfer"):
            for stamp, change in (("2025-12-29T00-00-00Z", {"cell": dict(result["cell"], name="gravity/other")}),
                                  ("2025-12-28T00-00-00Z", {"eval": dict(result["eval"], tasks=[
                                      task_entry("gravity/1.0", 0.5, [0.3, 0.3, 0.4])])})):
                (folder / "replaced" / stamp).mkdir(parents=True)
                (folder / "replaced" / stamp / "result.json").write_text(json.dumps(dict(result, **change)))
            unfinished = root / "cells" / "gravity" / "transfer-new-0.5_d2_s2" / "replaced" / "2025-12-27T00-00-00Z"
            unfinished.mkdir(parents=True)
            (unfinished / "result.json").write_text(json.dumps(dict(result, cell=dict(
                result["cell"], name="gravity/transfer-new-0.5_d2_s2"), config=run_config(
                "transfer", {"task_demos": {TASK: 2}}, NEW_STEPS, init={"run": "../maps-without-0.5_d10_s2"}))))
    # One cell ran on another machine: the cost summary gives it a row of its own.
    other = root / "cells" / "gravity" / "single_bc-new-0.5_d2_s2" / "result.json"
    result = json.loads(other.read_text())
    result.update(cpu="Other CPU", training_attempts=[{"cpu": "Other CPU"}])
    other.write_text(json.dumps(result))
    damaged = root / "cells" / "gravity" / "transfer-new-0.5_d2_s0" / "replaced" / "2025-12-30T00-00-00Z"
    damaged.mkdir(parents=True)
    (damaged / "result.json").write_text("{")
    (root / "suite.json").write_text(json.dumps({"format": "maps-suite/1", "config": {}, "cells": planned}))


class TransferTableTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        root = pathlib.Path(cls.tmp.name) / "suite"
        write_suite(root)
        cls.out = pathlib.Path(cls.tmp.name) / "report"
        cls.proc = subprocess.run([sys.executable, str(SCRIPT), str(root), "--out", str(cls.out)],
                                  capture_output=True, text=True)
        cls.md = (cls.out / "transfer.md").read_text() if cls.proc.returncode == 0 else ""

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_runs_and_draws(self):
        self.assertEqual(self.proc.returncode, 0, self.proc.stderr)
        self.assertGreater((self.out / "transfer_scores.png").stat().st_size, 10000)

    def test_scores_are_the_new_tasks_mean_and_t_interval_over_seeds(self):
        self.assertIn("| method | 1 demo | 2 demos |", self.md)
        # 0.5, 0.6, 0.7: t(2) 4.303 x 0.1 / sqrt(3) = 0.25; 0.8, 0.9: t(1) 12.706 x 0.0707 / sqrt(2) = 0.64.
        self.assertEqual(rows_of(self.md, ["MAPS transfer"])[0], ["MAPS transfer", "0.60 +- 0.25 (3)",
                                                                  "0.85 +- 0.64 (2)"])
        self.assertEqual(rows_of(self.md, ["Single BC (new task alone)"])[0],
                         ["Single BC (new task alone)", "0.40 +- 1.27 (2)", "0.60 +- 0.25 (3)"])

    def test_different_seed_sets_are_said(self):
        self.assertIn("At 1 demonstration the methods ran different seeds (MAPS transfer: 0, 1, 2; Single BC (new task "
                      "alone): 0, 1)", self.md)
        self.assertIn("At 2 demonstrations the methods ran different seeds (MAPS transfer: 0, 1; Single BC (new task "
                      "alone): 0, 1, 2)", self.md)

    def test_paired_differences_use_the_seeds_both_ran_with_holm(self):
        rows = rows_of(self.md[:self.md.index("## Across the tasks")], ["MAPS transfer", "Single BC (new task alone)"])
        # 1 demo, seeds 0-1: +0.2, +0.1: t = 3 on 1 df, p = 0.205; 2 demos, seeds 0-1: +0.3 twice: no spread, p 0.
        # Holm over the two: 0 x 2, then max(0, 0.205 x 1).
        self.assertEqual(rows, [["MAPS transfer", "Single BC (new task alone)", "1", "2", "+0.15 +- 0.64", "0.205",
                                 "0.205"],
                                ["MAPS transfer", "Single BC (new task alone)", "2", "2", "+0.30 +- 0.00", "0.000",
                                 "0.000"]])

    def test_across_the_tasks_sums_up_the_paired_differences(self):
        across = self.md[self.md.index("## Across the tasks"):self.md.index("## Training cost across the tasks")]
        # The two differences above: means +0.15 and +0.30 (both above; mean of means 0.225), p 0.205 and 0.000 (one
        # below 0.05, before and after Holm), interval half-widths 0.64 and 0.00 (median 0.32). One set: no "all" row.
        self.assertEqual(rows_of(across, ["MAPS transfer", "Single BC (new task alone)"]),
                         [["MAPS transfer", "Single BC (new task alone)", "gravity (1)", "2", "2", "0", "0", "+0.23",
                           "1", "1", "0.32 (0.00-0.64)"]])
        self.assertIn("- MAPS transfer - Single BC (new task alone), gravity/0.5 at 2: +0.30 +- 0.00, p 0.000 (0.000)",
                      across)
        self.assertNotIn("gravity/0.5 at 1:", across)

    def test_cost_is_the_median_best_step_and_the_curves_cpu_seconds(self):
        # Transfer at 1 demo: best steps 0, 400, 800 (0.5 CPU s per 200 steps: 0, 1, 2 s); 2000 steps: 5 s.
        cost = self.md[self.md.index("Training cost"):self.md.index("MAPS transfer starts")]
        # CPU seconds are a machine's: the section names the CPUs its cells (and transfer's sources) ran on.
        before = self.md[:self.md.index("Training cost")]
        # 10 finished new-task cells and the 3 source runs, each once (a source serves its seed at every count).
        finished = sum(outcome is not None for outcome in CELLS.values())
        self.assertIn(f"names both): Fixture CPU: {finished + 3 - 1}; Other CPU: 1.\n",
                      before[before.rindex("Machines ("):])
        self.assertEqual(rows_of(cost, ["MAPS transfer", "1"])[0],
                         ["MAPS transfer", "1", "400 (0-800)", "1 of 3", "1.0", "5.0"])
        self.assertEqual(rows_of(cost, ["MAPS transfer", "2"])[0],
                         ["MAPS transfer", "2", "1200 (1000-1400)", "0 of 2", "3.0", "5.0"])
        self.assertEqual(rows_of(cost, ["Single BC (new task alone)", "1"])[0],
                         ["Single BC (new task alone)", "1", "800 (600-1000)", "-", "2.0", "5.0"])
        self.assertEqual(rows_of(cost, ["Single BC (new task alone)", "2"])[0],
                         ["Single BC (new task alone)", "2", "2000", "-", "5.0", "5.0"])
        self.assertIn("MAPS transfer starts from a run without 0.5 (3 seeds, the other tasks at 10 demonstrations): "
                      "best step 5000, 100 CPU seconds to it, 400 of training", self.md)

    def test_cost_across_the_tasks_is_per_set_and_method_with_each_source_once(self):
        cost = self.md[self.md.index("## Training cost across the tasks"):self.md.index("## Cells run twice")]
        # Transfer's 5 cells: best steps 0, 400, 800, 1000, 1400 (0, 1, 2, 2.5, 3.5 CPU s); Single BC's 4 finished on
        # the fixture's CPU: 600, 1000, 2000, 2000 (1.5, 2.5, 5, 5 s), and 1 on another (2000: 5 s); every cell trains
        # 2000 steps (5 s); the 3 sources once each, best at 5000 (100 s) of 20000 (400 s).
        self.assertEqual(rows_of(cost, ["gravity"]),
                         [["gravity", "MAPS transfer", "Fixture CPU", "5", "800 (0-1400)", "2.0 (0.0-3.5)", "5.0"],
                          ["gravity", "Single BC (new task alone)", "Fixture CPU", "4", "1500 (600-2000)",
                           "3.8 (1.5-5.0)", "5.0"],
                          ["gravity", "Single BC (new task alone)", "Other CPU", "1", "2000", "5.0", "5.0"],
                          ["gravity", "MAPS without the new task (transfer's source)", "Fixture CPU", "3", "5000",
                           "100", "400"]])

    def test_cost_across_the_tasks_says_what_the_curves_could_not_time(self):
        sys.path.insert(0, str(SCRIPT.parent))
        import transfer_table
        costs = [transfer_table.Cost("mt10", "mt_bc", "A", 100, 1.0, 4.0, True),
                 transfer_table.Cost("mt10", "mt_bc", "A", 300, None, None, True),  # a curve that cannot say
                 transfer_table.Cost("mt10", "mt_bc", "B", 200, 2.0, 8.0, False)]  # timed by wall seconds
        self.assertEqual(rows_of("\n".join(transfer_table.cost_lines(costs)), ["mt10"]),
                         [["mt10", "MT-BC (all tasks)", "A", "2", "200 (100-300)", "1.0 (1 of 2 known)",
                           "4.0 (1 of 2 known)"],
                          ["mt10", "MT-BC (all tasks)", "B", "1", "200", "2.0", "8.0 (1 of 1 wall seconds)"]])
        self.assertEqual(transfer_table.cost_lines([]), [])

    def test_the_suites_compute_counts_every_cell_and_every_earlier_result(self):
        compute = self.md[self.md.index("## Compute"):self.md.index("## Cells run twice")]
        finished, earlier = compute.split("The earlier results of cells run twice")
        # 3 sources at 400 CPU s of training + 1 s evaluation (0.33 h, 6.7 minutes each), 10 finished new-task cells
        # at 5 + 1 s: 1263 s in all. The 4 earlier results that count have no curve: their attempt's 1 wall second
        # each (the damaged one and the one naming another cell do not count: `maps suite status` says so).
        self.assertEqual(rows_of(finished, ["holdout"]),
                         [["holdout", "gravity", "maps (without-0.5)", "3", "0.33", "6.7", "Fixture CPU (3)"]])
        self.assertEqual(rows_of(finished, ["new_task_gravity", "gravity", "single_bc (new-0.5)"]),
                         [["new_task_gravity", "gravity", "single_bc (new-0.5)", "5", "0.01", "0.1",
                           "Fixture CPU (4), Other CPU (1)"]])
        self.assertIn("In all: 0.4 CPU-hours over 13 finished cells", finished)
        self.assertIn("Cells counted: 13 by training's CPU seconds from curve.csv.", finished)
        self.assertIn("In all: 0.0 CPU-hours over 4 finished cells", earlier)
        self.assertIn("Cells counted: 4 by the finishing attempt's wall seconds", earlier)
        self.assertEqual(rows_of(earlier, ["new_task_gravity"]),
                         [["new_task_gravity", "gravity", "transfer (new-0.5)", "3", "0.00", "0.0", "Earlier CPU (3)"]])

    def test_module_summary_leaves_out_seeds_that_kept_the_start_and_gives_chance(self):
        summary = rows_of(self.md, ["MAPS transfer", "1", "2 of 3"])
        # Seed 1: TV 0.2 to 0.75 (nearest), 0.5 and 0.7 to the others, 0.27 to the mean; seed 2: 0.6, nearest 1.0
        # (0.1), others 0.1 and 0.7, 0.37 to the mean. The trained tasks are 0.7 apart.
        self.assertEqual(summary, [["MAPS transfer", "1", "2 of 3", "1 of 2 (chance 1/3)", "0.40", "0.50", "0.32",
                                    "0.70"]])
        self.assertEqual(rows_of(self.md, ["MAPS transfer", "2", "2 of 2"]),
                         [["MAPS transfer", "2", "2 of 2", "2 of 2 (chance 1/3)", "0.05", "0.75", "0.52", "0.70"]])

    def test_module_rows_per_seed_mark_the_start(self):
        self.assertEqual(rows_of(self.md, ["MAPS transfer", "1", "0 (start)"]),
                         [["MAPS transfer", "1", "0 (start)", "m0 (0.70), m1 (0.20), m2 (0.10)",
                           "m0 (0.80), m1 (0.10), m2 (0.10)", "0.10", "0.60-0.70", "0.37", "0.75 (0.10)"]])
        self.assertEqual(rows_of(self.md, ["MAPS transfer", "1", "2"]),
                         [["MAPS transfer", "1", "2", "m1 (0.70), m0 (0.20), m2 (0.10)",
                           "m0 (0.80), m1 (0.10), m2 (0.10)", "0.60", "0.10-0.70", "0.37", "1.0 (0.10)"]])

    def test_cells_run_twice_are_compared_with_their_earlier_results(self):
        self.assertIn("## Cells run twice", self.md)
        self.assertEqual(rows_of(self.md, ["`gravity/maps-without-0.5_d10_s0`"])[0],
                         ["`gravity/maps-without-0.5_d10_s0`", "Earlier CPU; Fixture CPU", "4000 -> 5000",
                          "0.04 -> 0.05", "0.60 -> 0.90"])
        self.assertEqual(rows_of(self.md, ["`gravity/transfer-new-0.5_d1_s1`"])[0],
                         ["`gravity/transfer-new-0.5_d1_s1`", "Earlier CPU; Fixture CPU", "400 -> 400",
                          "0.05 -> 0.05", "0.20 -> 0.60"])
        # |0.05 - 0.04| / 0.04 = 0.25; the score 0.6 -> 0.9.
        self.assertIn("Source runs: 1 run twice; the same best step in 0; the best validation loss moved by a median "
                      "0.25 of itself (at most 0.25); the score by a median 0.300 (at most 0.300).", self.md)
        self.assertIn("Transfers: 1 run twice; the same best step in 1; the new task's score moved by a median 0.400 "
                      "(at most 0.400; mean change +0.400).", self.md)
        # Earlier results that cannot be compared are named with the reason, not dropped nor a crash.
        # What counts is the tool's to say (`maps suite status --json`: "replaced", issue 42).
        self.assertIn("transfer-new-0.5_d2_s0/replaced/2025-12-30T00-00-00Z/result.json`: an earlier result of the "
                      "cell that does not count (unreadable (", self.md)
        self.assertIn("transfer-new-0.5_d1_s1/replaced/2025-12-29T00-00-00Z/result.json`: an earlier result of the "
                      "cell that does not count (names another cell): not compared", self.md)
        self.assertIn("transfer-new-0.5_d1_s1/replaced/2025-12-28T00-00-00Z/result.json`: an earlier result without "
                      "a score for gravity/0.5: not compared", self.md)
        self.assertIn("Not finished again yet (1; their earlier results are not counted above): "
                      "`gravity/transfer-new-0.5_d2_s2` (first finished 2025-12-27T00-00-00Z).", self.md)

    def test_failed_and_unfinished_cells_are_named(self):
        finished = self.md[self.md.index("## Cells not finished"):]
        self.assertIn("- `gravity/single_bc-new-0.5_d1_s2`: train: loss is nan at step 250", finished)
        self.assertIn("- grid new_task_gravity: 1: `gravity/transfer-new-0.5_d2_s2`", finished)


if __name__ == "__main__":
    unittest.main()
