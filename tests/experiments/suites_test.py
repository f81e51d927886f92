#!/usr/bin/python3
"""Tests of experiments/suites/{grid_results,aggregate,plot}.py on a small hand-made grid whose numbers are
known: the score table, the paired differences, the labels of widened baselines, the routing table, the plots,
and the errors for an empty or damaged grid. Run by ctest (tests/CMakeLists.txt)."""
import contextlib
import io
import json
import math
import pathlib
import sys
import tempfile
import unittest

SUITES = pathlib.Path(__file__).resolve().parents[2] / "experiments" / "suites"
sys.path.insert(0, str(SUITES))

import aggregate  # noqa: E402
import grid_results  # noqa: E402

TASKS = ["gravity/0.5", "gravity/1.0"]


def write_run(root, name, method, seed, scores, hidden=None, usage=None, entropy=None):
    folder = root / name
    folder.mkdir(parents=True)
    tasks = []
    for i, task in enumerate(TASKS):
        entry = {"task": task, "score": scores[i]}
        if usage is not None:
            entry["module_usage"] = usage[i]
            entry["selector_entropy"] = entropy[i]
            entry["selector_top_score"] = max(usage[i])
        tasks.append(entry)
    result = {"method": method, "seed": seed, "demos_per_task": 5, "subsample": 10, "best_step": 100 * (seed + 1),
              "mean_score": sum(scores) / len(scores), "tasks": tasks}
    (folder / "eval.json").write_text(json.dumps(result))
    config = {"method": method, "train": {"steps": 2000}}
    if hidden is not None:
        config["baselines"] = {"hidden": hidden}
    (folder / "config.json").write_text(json.dumps(config))
    (folder / "curve.csv").write_text("step,bc,total,validation_bc,steps_per_second\n"
                                      f"100,0.5,0.5,{0.4 - 0.01 * seed},10\n200,0.3,0.3,{0.2 - 0.01 * seed},10\n")


def make_grid(root):
    # MAPS: task scores (0.8, 0.6) and (0.6, 0.4): means 0.7 and 0.5. MT-BC: means 0.5 and 0.4, so its paired
    # differences from MAPS are -0.2 and -0.1 (mean -0.15). A widened MT-BC has its own row.
    usage_a = [[0.5, 0.5], [0.5, 0.5]]
    write_run(root, "maps_d5_k10_s0", "maps", 0, [0.8, 0.6], usage=usage_a, entropy=[0.1, 0.2])
    write_run(root, "maps_d5_k10_s1", "maps", 1, [0.6, 0.4], usage=[[0.9, 0.1], [0.1, 0.9]], entropy=[0.3, 0.4])
    write_run(root, "mt_bc_d5_k10_s0", "mt_bc", 0, [0.6, 0.4])
    write_run(root, "mt_bc_d5_k10_s1", "mt_bc", 1, [0.5, 0.3])
    write_run(root, "mt_bc_w64_d5_k10_s0", "mt_bc", 0, [0.9, 0.9], hidden=[64, 64, 64])


def run_aggregate(root):
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        aggregate.main(str(root))
    return out.getvalue()


def row_of(text, first_cells):
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if cells[:len(first_cells)] == first_cells:
            return cells
    raise AssertionError(f"no row starting {first_cells} in:\n{text}")


class Aggregate(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.root = pathlib.Path(self.tmp.name)
        make_grid(self.root)

    def tearDown(self):
        self.tmp.cleanup()

    def test_score_table_means_and_confidence_intervals(self):
        text = run_aggregate(self.root)
        maps = row_of(text, ["maps", "5", "10", "2", "2000"])
        # Task 0: scores 0.8 and 0.6: mean 0.7, CI 12.706 * stdev(0.1414) / sqrt(2) = 1.27.
        self.assertEqual(maps[5], "0.70 +- 1.27")
        self.assertEqual(maps[7], "**0.60 +- 1.27**")
        self.assertEqual(maps[8], "100-200")

    def test_paired_differences_use_the_same_seeds(self):
        text = run_aggregate(self.root)
        paired = text[text.index("Paired difference"):]
        # -0.2 and -0.1: mean -0.15, CI 12.706 * 0.0707 / sqrt(2) = 0.64.
        self.assertEqual(row_of(paired, ["mt_bc", "5", "10", "2"])[4], "-0.15 +- 0.64")
        # One pair only: no interval.
        self.assertEqual(row_of(paired, ["mt_bc_w64", "5", "10", "1"])[4], "+0.20 +- nan")

    def test_a_widened_baseline_is_its_own_row(self):
        text = run_aggregate(self.root)
        self.assertEqual(row_of(text, ["mt_bc_w64", "5", "10", "1"])[7], "**0.90 +- nan**")
        # Cells named by run_grid.sh keep their name; other folders are labelled from the config.
        self.assertEqual(grid_results.label_of("maps_sparse05_d5_k10_s3", "maps", {}, 5, 10, 3), "maps_sparse05")
        self.assertEqual(grid_results.label_of("run7", "mt_bc", {"baselines": {"hidden": [64, 32]}}, 5, 10, 3),
                         "mt_bc (64x32)")
        self.assertEqual(grid_results.label_of("run7", "mt_bc", {"baselines": {"hidden": [128] * 3}}, 5, 10, 3),
                         "mt_bc")

    def test_routing_is_computed_per_seed(self):
        text = run_aggregate(self.root)
        routing = text[text.index("Routing"):]
        # Seed 0: both tasks use the modules alike (TV 0); seed 1: each task its own module (TV 0.4 from the mean
        # usage 0.5/0.5). Averaged over seeds 0.2, where averaging usage first would have hidden it.
        row = row_of(routing, ["gravity/0.5"])
        self.assertTrue(row[1].startswith("0.20 +- "), row)
        self.assertTrue(row[2].startswith("0.20 +- "), row)  # entropy 0.1 and 0.3
        self.assertTrue(row[3].startswith("0.70 +- "), row)  # top scores 0.5 and 0.9

    def test_ci95_uses_the_t_distribution(self):
        self.assertTrue(math.isnan(grid_results.ci95([1.0])))
        self.assertAlmostEqual(grid_results.ci95([0.0, 1.0]), 12.706 * math.sqrt(0.5) / math.sqrt(2))
        self.assertAlmostEqual(grid_results.ci95([float(i % 2) for i in range(40)]),
                               1.96 * grid_results.statistics.stdev([float(i % 2) for i in range(40)]) / math.sqrt(40))


class Errors(unittest.TestCase):
    def test_an_empty_grid_says_what_to_run(self):
        with tempfile.TemporaryDirectory() as tmp:
            with self.assertRaises(SystemExit) as raised:
                grid_results.load_runs(tmp)
            self.assertIn("run_grid.sh", str(raised.exception))

    def test_a_damaged_result_names_its_file(self):
        with tempfile.TemporaryDirectory() as tmp:
            root = pathlib.Path(tmp)
            make_grid(root)
            (root / "mt_bc_d5_k10_s1" / "eval.json").write_text('{"method": "mt_bc", "seed": ')
            with self.assertRaises(SystemExit) as raised:
                grid_results.load_runs(root)
            self.assertIn("mt_bc_d5_k10_s1", str(raised.exception))
            (root / "mt_bc_d5_k10_s1" / "eval.json").write_text('{"method": "mt_bc"}')
            with self.assertRaises(SystemExit) as raised:
                grid_results.load_runs(root)
            self.assertIn("mt_bc_d5_k10_s1", str(raised.exception))


class Plot(unittest.TestCase):
    def test_writes_the_three_pngs(self):
        try:
            import plot
        except SystemExit as missing:  # matplotlib is not installed: scripts/setup.sh installs it
            self.skipTest(str(missing))
        with tempfile.TemporaryDirectory() as tmp:
            root = pathlib.Path(tmp)
            make_grid(root)
            with contextlib.redirect_stdout(io.StringIO()):
                plot.main(str(root), str(root / "plots"))
            for name in ("scores.png", "validation.png", "module_usage.png"):
                data = (root / "plots" / name).read_bytes()
                self.assertTrue(data.startswith(b"\x89PNG"), name)
                self.assertGreater(len(data), 5000, name)


if __name__ == "__main__":
    unittest.main()
