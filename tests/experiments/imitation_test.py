#!/usr/bin/python3
"""Tests of how fast GAIL learns in the report (experiments/report/imitation.py, speed_table; issue 45), and of what its
iterations cost (Cell.compute_seconds), against values computed by hand: the area is the mean of the training curve
over the budget; a value counts as reached only when a trailing window's mean reaches it (one lucky iteration does
not); the table pairs MAPS with each other method by seed, over the budget both ran, and adjusts by Holm over its rows;
an iteration costs its env steps over its logged speed, and a curve that cannot be timed is not; the score figure's BC
line runs on to the counts only BC ran, and the learning curves' caption counts training episodes, not the
evaluation's; the suite's own GAIL variants (gail, MT10's gail_mt10) share a Holm family and a figure label. Run by
ctest (tests/CMakeLists.txt)."""
import pathlib
import statistics
import sys
import tempfile
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "experiments" / "report"))

import imitation  # noqa: E402
import suite_results  # noqa: E402
import tables  # noqa: E402
from suite_results import Cell, TaskResult  # noqa: E402
from suite_stats import paired_p  # noqa: E402

TASKS = ["s/a", "s/b"]
EXPERT = {"s/a": 1000.0, "s/b": 2000.0}


def gail_cell(root, method, seed, fractions, steps_per_iteration=10000, budget=None):
    """A finished GAIL cell whose curve.csv has, at each iteration, every task's return at the given fraction of its
    expert's return."""
    folder = pathlib.Path(root) / f"{method}_s{seed}"
    folder.mkdir()
    lines = ["iteration,env_steps_per_task," + ",".join(f"return:{t}" for t in TASKS) + ",success"]
    for i, f in enumerate(fractions, start=1):
        lines.append(f"{i},{i * steps_per_iteration}," + ",".join(str(f * EXPERT[t]) for t in TASKS) + ",0")
    (folder / "curve.csv").write_text("\n".join(lines) + "\n")
    tasks = [TaskResult(t, 1.0, 0.0, 0.0, EXPERT[t], scored_by="return", expert_return=EXPERT[t]) for t in TASKS]
    config = {"method": method, "imitation": "gail",
              "gail": {"env_steps_per_task": budget or len(fractions) * steps_per_iteration}}
    return Cell(folder, f"s/{method}-gail_d1_s{seed}", "gail", "s", method, "gail", 1, 10, seed, config,
                len(fractions), len(fractions), 10, 1.0, tasks, trained_env_steps=len(fractions) * steps_per_iteration)


class LearningSpeedTest(unittest.TestCase):
    def test_the_area_is_the_curves_mean_and_a_window_must_reach(self):
        curve = {10000 * (i + 1): v for i, v in enumerate([0.0, 0.5, 0.8, 1.0, 0.9, 0.95])}
        # 20,000 env steps = two iterations: window means 0.25, 0.65, 0.9 -> reached at the window ending at 40,000.
        area, reached = imitation.learning_speed(curve)
        self.assertAlmostEqual(area, (0.0 + 0.5 + 0.8 + 1.0 + 0.9 + 0.95) / 6)
        self.assertEqual(reached, 40000)
        # Over a budget of 30,000 env steps: three iterations, no window reaches 0.9.
        area, reached = imitation.learning_speed(curve, budget=30000)
        self.assertAlmostEqual(area, (0.0 + 0.5 + 0.8) / 3)
        self.assertIsNone(reached)

    def test_one_lucky_iteration_is_not_reaching(self):
        curve = {10000 * (i + 1): v for i, v in enumerate([0.0, 0.95, 0.2, 0.3, 0.92, 0.91])}
        self.assertEqual(imitation.learning_speed(curve)[1], 60000)
        # Iterations of 5,000 env steps: a window of four.
        curve = {5000 * (i + 1): v for i, v in enumerate([0.9, 0.9, 0.9, 0.8, 1.0, 0.9])}
        self.assertEqual(imitation.learning_speed(curve)[1], 25000)  # (0.9 + 0.9 + 0.8 + 1.0) / 4 = 0.9
        self.assertEqual(imitation.learning_speed({}), (None, None))

    def test_steps_are_a_median_where_a_seed_that_never_reached_counts_as_the_latest(self):
        self.assertEqual(imitation.fmt_steps([None], 10**6), "not reached")
        self.assertEqual(imitation.fmt_steps([150000], 10**6), "0.15")
        self.assertEqual(imitation.fmt_steps([150000, 170000, 160000], 10**6), "0.16 (0.15-0.17)")
        self.assertEqual(imitation.fmt_steps([300000, None, 150000], 10**6), "0.30 (0.15 to >1.00)")
        self.assertEqual(imitation.fmt_steps([None, None, 150000], 10**6), ">1.00 (0.15 to >1.00)")
        self.assertEqual(imitation.fmt_steps([None, None], 10**6), "not reached")
        self.assertEqual(imitation.fmt_steps([200000, 100000], 10**6), "0.15 (0.10-0.20)")
        self.assertEqual(imitation.fmt_steps([200000, None], 10**6), ">1.00 (0.20 to >1.00)")

    def test_the_table_pairs_maps_with_each_method_by_seed_over_the_shared_budget(self):
        with tempfile.TemporaryDirectory() as root:
            # MAPS also ran seed 4, which MT-BC did not: pairs are by seed, not by position.
            maps_curves = {0: [0.2, 0.9, 1.0, 1.0], 1: [0.4, 0.9, 0.95, 1.0], 2: [0.1, 0.6, 1.0, 1.0],
                           4: [0.9, 1.0, 1.0, 1.0]}
            # MT-BC's seed 2 ran one iteration more: compared over the four all ran.
            other_curves = {0: [0.1, 0.3, 0.8, 1.0], 1: [0.0, 0.4, 0.6, 0.7], 2: [0.1, 0.5, 0.9, 1.0, 1.0]}
            cells = [gail_cell(root, "maps", s, c) for s, c in maps_curves.items()]
            cells += [gail_cell(root, "mt_bc", s, c) for s, c in other_curves.items()]
            lines = imitation.speed_table(cells)
        self.assertIn("Holm over the rows with a p within each family (the suite's GAIL runs: 1)", lines[0])
        rows = {line.split(" | ")[1]: line.strip("| ").split(" | ") for line in lines if line.startswith("| s | ")}
        self.assertEqual(set(rows), {"MAPS", "MT-BC"})
        maps_row, other_row = rows["MAPS"], rows["MT-BC"]
        self.assertEqual(other_row[4:6], ["3", "40,000"])
        areas = {s: statistics.mean(c[:4]) for s, c in other_curves.items()}
        maps_areas = {s: statistics.mean(c) for s, c in maps_curves.items()}
        self.assertTrue(other_row[6].startswith(f"{statistics.mean(areas.values()):.2f} +- "), other_row[6])
        # Reached (a window of two iterations of 10,000): MAPS at 30,000 (seeds 0 and 1), 40,000 (seed 2, whose
        # window ending at 30,000 has (0.6 + 1.0) / 2 = 0.8) and 20,000 (seed 4); MT-BC at 40,000 (seeds 0 and 2),
        # never in seed 1 (within the 40,000 both ran).
        self.assertEqual(maps_row[4], "4")
        self.assertEqual(maps_row[7], "0.03 (0.02-0.04)")
        self.assertEqual(other_row[7], "0.04 (0.04 to >0.04)")
        diffs = [maps_areas[s] - areas[s] for s in (0, 1, 2)]
        self.assertEqual(other_row[8], "3")
        self.assertTrue(other_row[9].startswith(f"+{statistics.mean(diffs):.2f} +- "), other_row[9])
        self.assertEqual(other_row[10], f"{paired_p(diffs):.3f}")
        self.assertEqual(maps_row[8:10], ["", ""])

    def test_a_width_control_under_gail_pairs_with_its_own_width_under_bc_and_with_maps_under_gail(self):
        def bc_cell(method, variant, seed, hidden=None, score=0.5):
            config = {"method": method}
            if hidden:
                config["baselines"] = {"hidden": hidden}
            tasks = [TaskResult(t, score, 0.0, 0.0, 500.0) for t in TASKS]
            return Cell(pathlib.Path("."), f"s/{method}-{variant}_d1_s{seed}", "bc", "s", method, variant, 1, 10,
                        seed, config, 100, 100, 10, 1.0, tasks)

        with tempfile.TemporaryDirectory() as root:
            narrow, wide = [128, 128, 128], [430, 430, 430]
            # Each BC row its own score, so that a table shows which one it paired with.
            bc = ([bc_cell("mt_bc", "base", s, narrow, 0.1) for s in (0, 1)]
                  + [bc_cell("mt_bc", "w430", s, wide, 0.3) for s in (0, 1)]
                  + [bc_cell("mt_bc", "paper_protocol", s, narrow, 0.7) for s in (0, 1)]
                  + [bc_cell("maps", "base", s, None, 0.2) for s in (0, 1)])
            gail = []
            for seed in (0, 1):
                gail.append(gail_cell(root, "maps", seed, [0.5, 1.0]))
                gail.append(gail_cell(root, "mt_bc", seed, [0.1, 0.5]))
                gail[-1].config["baselines"] = {"hidden": narrow}
                wide_cell = gail_cell(root, f"mt_bc_w{seed}", seed, [0.2, 0.6])
                wide_cell.method, wide_cell.variant = "mt_bc", "gail_w430"
                wide_cell.config.update(method="mt_bc", baselines={"hidden": wide})
                gail.append(wide_cell)
            settings = imitation.by_objective(bc + gail)
            by_variant = {(s.method, s.variant): runs for s, runs in settings.items()}
            self.assertEqual({c.variant for c in by_variant[("mt_bc", "gail")]["bc"]}, {"base"})
            self.assertEqual({c.variant for c in by_variant[("mt_bc", "gail_w430")]["bc"]}, {"w430"})
            self.assertEqual({c.variant for c in by_variant[("maps", "gail")]["bc"]}, {"base"})
            wide_key = next(s for s in settings if s.variant == "gail_w430")
            self.assertEqual(imitation.maps_setting(settings, wide_key)[0].variant, "gail")
            # MAPS - the wide MT-BC under each objective, and in how fast it learns.
            self.assertIn("| s | MAPS - MT-BC (gail_w430) | 1 | 10 | 2 |", "\n".join(imitation.maps_table(bc + gail)))
            speed = {line.split(" | ")[1]: line.split(" | ") for line in imitation.speed_table(bc + gail)
                     if line.startswith("| s | ")}
            self.assertEqual(speed["MT-BC (gail_w430)"][8], "2")
            self.assertTrue(speed["MT-BC (gail_w430)"][9].startswith("+0.35"), speed["MT-BC (gail_w430)"][9])
            objective = "\n".join(imitation.objective_table(bc + gail))
            self.assertIn("| s | MT-BC (gail_w430) | 1 | 10 | 2 | 0.30 +- 0.00 |", objective)
            self.assertIn("| s | MT-BC | 1 | 10 | 2 | 0.10 +- 0.00 |", objective)
            # MAPS - the wide MT-BC under BC pairs MAPS's BC (0.2) with the wide one's (0.3).
            self.assertIn("| s | MAPS - MT-BC (gail_w430) | 1 | 10 | 2 | -0.10 +- 0.00 |",
                          "\n".join(imitation.maps_table(bc + gail)))
            # Without the base BC cells at this count, an ablation of the same network is not the partner: MT-BC
            # under GAIL pairs with nothing, though its base network is known from another count.
            elsewhere = bc_cell("mt_bc", "base", 0, narrow, 0.1)
            elsewhere.demos = 2
            no_base = [c for c in bc if not (c.method == "mt_bc" and c.variant == "base")] + [elsewhere]
            settings = imitation.by_objective(no_base + gail)
            self.assertEqual(next(r for s, r in settings.items() if (s.method, s.variant) == ("mt_bc", "gail"))["bc"],
                             [])
            self.assertNotIn("| s | MT-BC | 1 |", "\n".join(imitation.objective_table(no_base + gail)))

    def test_gail_on_clamped_inputs_pairs_with_bc_on_the_same_clamp(self):
        def bc_cell(method, variant, seed, clip, score):
            config = {"method": method, "data": {"observation_clip": clip}}
            tasks = [TaskResult(t, score, 0.0, 0.0, 500.0) for t in TASKS]
            return Cell(pathlib.Path("."), f"s/{method}-{variant}_d1_s{seed}", "bc", "s", method, variant, 1, 10,
                        seed, config, 100, 100, 10, 1.0, tasks)

        with tempfile.TemporaryDirectory() as root:
            bc = []
            for method in ("maps", "mt_bc"):
                bc += [bc_cell(method, "base", s, 0, 0.1) for s in (0, 1)]  # the study's, written before the key
                for cell in bc[-2:]:
                    del cell.config["data"]
                bc += [bc_cell(method, "clip10", s, 10, 0.4) for s in (0, 1)]
            gail = []
            for seed in (0, 1):
                for method in ("maps", "mt_bc"):
                    cell = gail_cell(root, f"{method}_c{seed}", seed, [0.5, 1.0])
                    cell.method, cell.variant = method, "gail_clip"
                    cell.config.update(method=method, data={"observation_clip": 10})
                    gail.append(cell)
            settings = imitation.by_objective(bc + gail)
            for method in ("maps", "mt_bc"):
                runs = next(r for s, r in settings.items() if s.method == method)
                self.assertEqual({c.variant for c in runs["bc"]}, {"clip10"}, method)
            self.assertIn("| s | MT-BC (gail_clip) | 1 | 10 | 2 | 0.40 +- 0.00 |",
                          "\n".join(imitation.objective_table(bc + gail)))

    def test_no_curves_no_table(self):
        with tempfile.TemporaryDirectory() as root:
            cell = gail_cell(root, "maps", 0, [0.5])
            (cell.folder / "curve.csv").unlink()
            self.assertEqual(imitation.speed_table([cell]), [])


def timed_cell(root, method, seed, speeds, steps_per_iteration=2000):
    """A GAIL cell of the two tasks, evaluated in 3 s, whose curve.csv logs one iteration per speed (env steps per
    second, as written)."""
    cell = gail_cell(root, method, seed, [0.5] * len(speeds), steps_per_iteration)
    lines = ["iteration,env_steps_per_task,return:s/a,return:s/b,env_steps_per_second"]
    lines += [f"{i},{i * steps_per_iteration},1,1,{v}" for i, v in enumerate(speeds, start=1)]
    (cell.folder / "curve.csv").write_text("\n".join(lines) + "\n")
    cell.eval_seconds = 3.0
    return cell


class GailComputeTest(unittest.TestCase):
    def test_each_iteration_costs_its_env_steps_over_its_speed(self):
        with tempfile.TemporaryDirectory() as root:
            # Two tasks at 2,000 env steps per task an iteration: 4,000 env steps; 100 + 100 + 200 s.
            cell = timed_cell(root, "maps", 0, [40, 40, 20])
            self.assertAlmostEqual(cell.gail_iteration_seconds(), 400.0)
            self.assertEqual(cell.compute_seconds(), (403.0, "gail"))
            other = timed_cell(root, "mt_bc", 0, [400, 400, 400])  # 30 s
            lines = tables.compute_table([cell, other])
        self.assertIn("Cells counted: 2 by GAIL's iterations from curve.csv", lines[-3])
        self.assertIn(f"In all: {(403 + 33) / 3600:.1f} CPU-hours over 2 finished cells", lines[-3])
        row = [line.strip("| ").split(" | ") for line in lines if line.startswith("| gail | s | maps")][0]
        self.assertEqual(row[3:6], ["1", f"{403 / 3600:.2f}", f"{403 / 60:.1f}"])

    def test_an_iteration_of_a_stopped_process_costs_the_median_as_in_the_tools_status(self):
        with tempfile.TemporaryDirectory() as root:
            # 100, 100, 200 (shared cores: as logged), 100 s, and 8,000 s (stopped): the last counts at the median.
            cell = timed_cell(root, "maps", 0, [40, 40, 20, 40, 0.5])
            self.assertAlmostEqual(cell.gail_iteration_seconds(), 600.0)
            # 25 times the median is still work (2,500 s: other jobs on the cores), 40 times is not.
            self.assertAlmostEqual(timed_cell(root, "mt_bc", 0, [40, 40, 40, 1.6]).gail_iteration_seconds(), 2800.0)
            self.assertAlmostEqual(timed_cell(root, "single_bc", 0, [40, 40, 40, 1.0]).gail_iteration_seconds(),
                                   400.0)
        header = (ROOT / "maps" / "training" / "curve_cost.h").read_text()
        self.assertIn(f"kStoppedFactor = {suite_results.STOPPED_FACTOR};", header)

    def test_a_budget_that_iterations_do_not_divide_is_read_where_the_curve_ends(self):
        """MT10's iterations of 1,500 env steps per task end a 10^6 budget at 1,000,500: the cost is read up to what
        the run trained (train.env_steps_per_task), not the config's budget, which no row ends at."""
        with tempfile.TemporaryDirectory() as root:
            cell = timed_cell(root, "maps", 0, [40, 40, 20])  # 6,000 env steps per task trained
            cell.config["gail"]["env_steps_per_task"] = 5000
            self.assertAlmostEqual(cell.gail_iteration_seconds(), 400.0)
            cell.trained_env_steps = None  # a result.json without it: no curve cost, the attempt's wall seconds
            self.assertEqual(cell.compute_seconds(), (cell.wall_seconds, "attempt"))

    def test_a_curve_with_cpu_seconds_costs_their_sum(self):
        with tempfile.TemporaryDirectory() as root:
            cell = timed_cell(root, "maps", 0, [40, 40, 0.5])  # the last iteration stopped for hours by the wall clock
            lines = (cell.folder / "curve.csv").read_text().splitlines()
            cpu = ["cpu_seconds", "90.5", "101", "99.25"]  # its CPU time did not grow while it was stopped
            (cell.folder / "curve.csv").write_text("\n".join(f"{line},{c}" for line, c in zip(lines, cpu)) + "\n")
            self.assertAlmostEqual(cell.gail_iteration_seconds(), 290.75)
            self.assertEqual(cell.compute_seconds(), (293.75, "gail"))
            # A bad CPU value is no answer (as in `maps suite status`), not a fall back to the speeds.
            (cell.folder / "curve.csv").write_text("\n".join(f"{line},{c}" for line, c in
                                                              zip(lines, cpu[:3] + [""])) + "\n")
            self.assertIsNone(cell.gail_iteration_seconds())

    def test_a_curve_that_cannot_be_timed_falls_back_to_the_attempts_wall_seconds(self):
        with tempfile.TemporaryDirectory() as root:
            cell = timed_cell(root, "maps", 0, [40, 0])  # a speed of 0
            self.assertIsNone(cell.gail_iteration_seconds())
            self.assertEqual(cell.compute_seconds(), (cell.wall_seconds, "attempt"))
            for text in ["iteration,env_steps_per_task,env_steps_per_second\n1,2000,40\n2,2000,40\n",  # no rise
                         "iteration,env_steps_per_task,env_steps_per_second\n1,2000,40\n",  # short of the budget
                         "iteration,env_steps_per_task,env_steps_per_second\n1,2000,nan\n",
                         "iteration,env_steps_per_task\n1,2000\n",  # no speed column
                         "iteration,env_steps_per_task,env_steps_per_second\n"]:  # no iteration
                (cell.folder / "curve.csv").write_text(text)
                self.assertIsNone(cell.gail_iteration_seconds(), text)
            (cell.folder / "curve.csv").unlink()
            self.assertIsNone(cell.gail_iteration_seconds())


class FiguresTest(unittest.TestCase):
    def test_bc_runs_on_to_the_counts_only_bc_ran_and_the_curves_name_their_training_episodes(self):
        import csv
        import imitation_figures

        def bc_cell(method, demos, seed, score):
            tasks = [TaskResult(t, score, 0.0, 0.0, 500.0) for t in TASKS]
            return Cell(pathlib.Path("."), f"s/{method}_d{demos}_s{seed}", "bc", "s", method, "base", demos, 10, seed,
                        {"method": method}, 100, 100, 10, 1.0, tasks)

        with tempfile.TemporaryDirectory() as root:
            gail = [gail_cell(root, "maps", seed, [0.5, 1.0]) for seed in (0, 1)]
            for c in gail:
                c.config["gail"]["rollout_episodes"] = 3
            # BC at the GAIL count (1) and at 10, where no GAIL cell ran. Not BC's line: an ablation at 10, MAPS with
            # other modules at 10 (another network) and MAPS at 10 on other subsampling.
            bc = [bc_cell("maps", 1, s, 0.2) for s in (0, 1)] + [bc_cell("maps", 10, s, 0.8) for s in (0, 1)]
            ablation = bc_cell("maps", 10, 0, 0.1)
            ablation.variant, ablation.name = "no_share", "s/maps-no_share_d10_s0"
            other_network = bc_cell("maps", 10, 1, 0.3)
            other_network.config["maps"] = {"modules": 4}
            other_k = bc_cell("maps", 10, 0, 0.4)
            other_k.subsample = 1
            out = pathlib.Path(root) / "report"
            out.mkdir()

            def scores_csv():
                with open(out / "imitation_scores.csv") as f:
                    return sorted((r["objective"], r["demos"], r["seeds"], round(float(r["mean"]), 3))
                                  for r in csv.DictReader(f))

            imitation_figures.imitation_scores(bc + [ablation, other_network, other_k] + gail, out)
            self.assertEqual(scores_csv(), [("bc", "1", "2", 0.2), ("bc", "10", "2", 0.8), ("gail", "1", "2", 1.0)])
            # A second GAIL variant of the same network at another count: its BC points are the same line's, drawn
            # once (the line already runs through 10).
            pilot = [gail_cell(root, f"maps_pilot{seed}", seed, [0.5, 1.0]) for seed in (0, 1)]
            for c in pilot:
                c.method, c.variant, c.demos = "maps", "pilot_b", 10
                c.config["method"] = "maps"
            imitation_figures.imitation_scores(bc + gail + pilot, out)
            self.assertEqual(scores_csv(), [("bc", "1", "2", 0.2), ("bc", "10", "2", 0.8), ("gail", "1", "2", 1.0),
                                            ("pilot_b", "10", "2", 1.0)])
            figures = imitation_figures.gail_curves(gail + bc, out)
            self.assertIn("n = 2 seeds per point, 3 training episodes per task per iteration (2 iterations)",
                          figures[0].caption)
            self.assertNotIn("100 episodes", figures[0].caption)

    def test_the_suites_own_gail_variants_share_a_holm_family_a_line_style_and_a_legend_entry(self):
        """MT10's GAIL runs are a variant of their own (gail_mt10: other rollout settings) but the suite's comparison,
        as "gail" is on the cheetah sets: one Holm family, one figure label per method (variant_name, which the
        figures' legends are built from), the captions saying which variant ran where; any other variant (a pilot)
        keeps its name."""
        import imitation_figures

        with tempfile.TemporaryDirectory() as root:
            cells = []
            for set_name, variant in (("s", "gail"), ("t", "gail_mt10")):
                folder = pathlib.Path(root) / set_name
                folder.mkdir()
                for method, curve in (("maps", [0.5, 1.0]), ("mt_bc", [0.2, 0.9])):
                    for seed in (0, 1, 2):
                        c = gail_cell(folder, method, seed, [v + 0.01 * seed for v in curve])
                        c.set, c.variant, c.name = set_name, variant, f"{set_name}/{method}-{variant}_d1_s{seed}"
                        cells.append(c)
            speed = imitation.speed_table(cells)
            self.assertIn("within each family (the suite's GAIL runs: 2)", speed[0])
            self.assertIn("| t | MT-BC (gail_mt10) | 1 | 10 | 3 |", "\n".join(speed))
            self.assertIn("a control's rows (a GAIL variant other than the suite's own, gail and gail_mt10)",
                          imitation.maps_table(cells)[0])
            self.assertEqual(imitation_figures.variant_name("maps", "gail_mt10"), "MAPS")
            self.assertEqual(imitation_figures.variant_name("maps", "pilot_b"), "MAPS (pilot_b)")
            out = pathlib.Path(root) / "report"
            out.mkdir()
            note = "The suite's GAIL runs (one style and legend entry): gail on s, gail_mt10 on t."
            self.assertIn(note, imitation_figures.gail_curves(cells, out)[0].caption)
            self.assertIn(note, imitation_figures.imitation_scores(cells, out)[0].caption)
            # Each set's settings fill the rows from the top: t's k = 1 beside s's k = 10, not a row of its own.
            keys = [("s", 1, 10, "bc"), ("s", 1, 10, "gail"), ("s", 5, 10, "gail"), ("t", 1, 1, "bc"),
                    ("t", 2, 1, "bc")]
            self.assertEqual(imitation_figures.panel_rows(keys, ["s", "t"]),
                             {"s": [(1, 10), (5, 10)], "t": [(1, 1), (2, 1)]})
            # One main variant: nothing to say.
            one = [c for c in cells if c.set == "s"]
            self.assertNotIn("The suite's GAIL runs", imitation_figures.gail_curves(one, out)[0].caption)


if __name__ == "__main__":
    unittest.main()
