#!/usr/bin/python3
"""Tests of the aggregate statistics (experiments/report/aggregates.py; issue 46, item 5) against values computed by
hand: the IQM pools runs and tasks and cuts a quarter off each end; the probability of improvement counts ties as 1/2
and is 0.5 for identical methods; the
stratified bootstrap keeps each task's scores within its column; intervals hold the estimate and are the same at every
run; the report's table has a row per method and counts. Run by ctest (tests/CMakeLists.txt)."""
import pathlib
import sys
import unittest

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "experiments" / "report"))

import aggregates  # noqa: E402
from suite_results import Cell, TaskResult  # noqa: E402


def cell(method, seed, scores, demos=5):
    tasks = [TaskResult(f"s/t{i}", s, s, s, s) for i, s in enumerate(scores)]
    return Cell(pathlib.Path("."), f"s/{method}_d{demos}_s{seed}", "grid", "s", method, "base", demos, 1, seed,
                {"method": method}, 1000, 500, 10, 1.0, tasks)


class AggregatesTest(unittest.TestCase):
    def test_iqm_pools_runs_and_tasks_and_cuts_a_quarter_off_each_end(self):
        # 8 values: 2 off each end, the mean of the middle 4.
        m = [[1, 100, 3, 4], [5, 6, -50, 8]]
        self.assertAlmostEqual(aggregates.iqm(m), (3 + 4 + 5 + 6) / 4)
        # 5 values: floor(5 / 4) = 1 off each end.
        self.assertAlmostEqual(aggregates.iqm([[0, 1, 2, 3, 10]]), 2.0)

    def test_probability_of_improvement_counts_ties_as_half(self):
        # X = [1, 2, 3] against Y = [2, 3, 4] on one task, by hand: X > Y in 1 of 9 pairs (3 > 2), ties in 2 (2 = 2,
        # 3 = 3): 1/9 + 2/9 / 2 = 2/9; the other way 6/9 + 1/9 = 7/9 (the two sum to 1).
        x = np.array([[1.0], [2.0], [3.0]])
        y = np.array([[2.0], [3.0], [4.0]])
        self.assertAlmostEqual(aggregates.probability_of_improvement(x, y), 2 / 9)
        self.assertAlmostEqual(aggregates.probability_of_improvement(y, x), 7 / 9)
        self.assertAlmostEqual(aggregates.probability_of_improvement(x, x), 0.5)
        # The mean over tasks: task 0 always better (1), task 1 always worse (0).
        a = np.array([[1.0, 0.0], [1.0, 0.0]])
        b = np.array([[0.0, 1.0], [0.0, 1.0], [0.0, 1.0]])
        self.assertAlmostEqual(aggregates.probability_of_improvement(a, b), 0.5)
        with self.assertRaises(ValueError):
            aggregates.probability_of_improvement(a, np.zeros((2, 3)))

    def test_the_bootstrap_resamples_runs_within_each_task(self):
        m = np.array([[0.0, 10.0, 20.0], [1.0, 11.0, 21.0], [2.0, 12.0, 22.0]])
        samples = aggregates.stratified_resamples(m, 500, np.random.default_rng(0))
        self.assertEqual(samples.shape, (500, 3, 3))
        for task in range(3):
            self.assertTrue(set(np.unique(samples[:, :, task])) <= set(m[:, task]), task)
        # Independently per task: some replicate pairs rows that no run holds together.
        self.assertTrue(np.any(samples[:, :, 1] - samples[:, :, 0] != 10.0))

    def test_intervals_hold_the_estimate_and_repeat(self):
        rng = np.random.default_rng(3)
        x = rng.uniform(0.4, 0.9, size=(5, 10))
        y = rng.uniform(0.2, 0.7, size=(5, 10))
        value, (low, high) = aggregates.iqm_interval(x, replicates=4000)
        self.assertLessEqual(low, value)
        self.assertLessEqual(value, high)
        self.assertEqual(aggregates.iqm_interval(x, replicates=4000), (value, (low, high)))
        poi, (low, high) = aggregates.poi_interval(x, y, replicates=4000)
        self.assertGreater(poi, 0.5)
        self.assertLessEqual(low, poi)
        self.assertLessEqual(poi, high)
        # One run per method: no spread to resample, the interval is the point.
        self.assertEqual(aggregates.poi_interval(x[:1], y[:1], replicates=100)[1], (aggregates.probability_of_improvement(
            x[:1], y[:1]),) * 2)

    def test_the_table_has_a_row_per_method_and_maps_against_the_others(self):
        cells = [cell("maps", s, [0.8, 0.9, 0.7]) for s in range(3)]
        cells += [cell("mt_bc", s, [0.5, 0.6, 0.4]) for s in range(3)]
        cells += [cell("mt_bc", s, [0.5, 0.6], demos=10) for s in range(2)]  # a missing task: left out
        lines = aggregates.aggregate_table(cells)
        rows = [line for line in lines if line.startswith("| maps") or line.startswith("| mt_bc")]
        self.assertEqual(len(rows), 2, lines)
        maps_row = next(r for r in rows if r.startswith("| maps"))
        bc_row = next(r for r in rows if r.startswith("| mt_bc"))
        self.assertIn("0.800 [", maps_row)
        self.assertTrue(maps_row.rstrip().endswith("|  |"), maps_row)  # no P(MAPS > MAPS)
        self.assertIn("1.000 [1.000, 1.000]", bc_row)  # MAPS beats MT-BC on every task and run
        self.assertEqual(aggregates.aggregate_table([]), [])


if __name__ == "__main__":
    unittest.main()
