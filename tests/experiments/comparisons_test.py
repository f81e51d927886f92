#!/usr/bin/python3
"""Tests of the comparisons a suite names (experiments/report/comparisons.py, the suite config's report.compare; issue
46) against values computed by hand: A - B is paired by seed over the seeds both rows ran, at each demos and k where
both ran; the probability of improvement is aggregates.py's over the same runs; Holm adjusts over the set's rows; an
entry that is not "A - B" is refused by name. Run by ctest (tests/CMakeLists.txt)."""
import pathlib
import statistics
import sys
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "experiments" / "report"))

import aggregates  # noqa: E402
import comparisons  # noqa: E402
from suite_results import Cell, TaskResult  # noqa: E402
from suite_stats import holm, paired_p  # noqa: E402

A = "diffusion_policy (dp_maps_h16)"
B = "diffusion_policy (dp_mlp_h16)"


def cell(variant, seed, scores, demos=2):
    tasks = [TaskResult(f"s/t{i}", s, s, s, s) for i, s in enumerate(scores)]
    return Cell(pathlib.Path("."), f"s/diffusion_policy-{variant}_d{demos}_s{seed}", "grid", "s", "diffusion_policy",
                variant, demos, 1, seed, {"method": "diffusion_policy"}, 1000, 500, 10, statistics.mean(scores),
                tasks)


def rows_of(lines):
    return [line.strip("| ").split(" | ") for line in lines if line.startswith("| diffusion_policy")]


class ComparisonsTest(unittest.TestCase):
    def setUp(self):
        # At 2 demos: A ran seeds 0-2, B seeds 0, 1 and 3 -> pairs over seeds 0 and 1. At 14 demos: both seeds 0-2.
        self.a2 = {0: [0.5, 0.7], 1: [0.4, 0.6], 2: [0.9, 0.9]}
        self.b2 = {0: [0.3, 0.5], 1: [0.4, 0.4], 3: [0.0, 0.0]}
        self.a14 = {0: [0.8, 0.8], 1: [0.7, 0.9], 2: [0.6, 1.0]}
        self.b14 = {0: [0.9, 0.9], 1: [0.8, 0.9], 2: [0.9, 0.8]}
        self.cells = ([cell("dp_maps_h16", s, v) for s, v in self.a2.items()]
                      + [cell("dp_mlp_h16", s, v) for s, v in self.b2.items()]
                      + [cell("dp_maps_h16", s, v, demos=14) for s, v in self.a14.items()]
                      + [cell("dp_mlp_h16", s, v, demos=14) for s, v in self.b14.items()])

    def test_pairs_by_seed_at_each_count_with_holm_over_the_rows(self):
        lines = comparisons.compare_table(self.cells, [f"{A} - {B}"])
        self.assertIn("Holm over this set's 2 rows with a p", lines[0])
        rows = rows_of(lines)
        self.assertEqual([r[:5] for r in rows], [[A, B, "2", "1", "2"], [A, B, "14", "1", "3"]])
        diffs2 = [statistics.mean(self.a2[s]) - statistics.mean(self.b2[s]) for s in (0, 1)]
        diffs14 = [statistics.mean(self.a14[s]) - statistics.mean(self.b14[s]) for s in (0, 1, 2)]
        self.assertEqual(rows[0][5].split(" +- ")[0], f"{statistics.mean([0.6, 0.5]):.2f}")  # A over seeds 0 and 1
        self.assertTrue(rows[0][7].startswith(f"{statistics.mean(diffs2):+.2f} +- "), rows[0][7])
        self.assertTrue(rows[1][7].startswith(f"{statistics.mean(diffs14):+.2f} +- "), rows[1][7])
        p = [paired_p(diffs2), paired_p(diffs14)]
        self.assertEqual([r[9] for r in rows], [f"{x:.3f}" for x in p])
        self.assertEqual([r[10] for r in rows], [f"{x:.3f}" for x in holm(p)])
        # P(A > B) over the same runs as the difference (seeds both ran).
        a = aggregates.runs_by_tasks([c for c in self.cells if c.variant == "dp_maps_h16" and c.demos == 2
                                      and c.seed in (0, 1)], ["s/t0", "s/t1"])
        b = aggregates.runs_by_tasks([c for c in self.cells if c.variant == "dp_mlp_h16" and c.demos == 2
                                      and c.seed in (0, 1)], ["s/t0", "s/t1"])
        self.assertEqual(rows[0][8], aggregates.fmt_interval(*aggregates.poi_interval(a, b)))
        # By hand: task 0: A [0.5, 0.4] against B [0.3, 0.4]: 3 wins, 1 tie of 4 -> 3.5 / 4; task 1: [0.7, 0.6]
        # against [0.5, 0.4]: 4 of 4 -> mean 0.9375.
        self.assertTrue(rows[0][8].startswith("0.938 ["), rows[0][8])

    def test_an_entry_without_both_rows_gives_nothing_and_a_bad_one_is_named(self):
        self.assertEqual(comparisons.compare_table(self.cells, [f"{A} - maps"]), [])
        with self.assertRaisesRegex(ValueError, "report.compare: expected \"A - B\", got 'maps-mt_bc'"):
            comparisons.compare_table(self.cells, ["maps-mt_bc"])

    def test_the_order_of_an_entry_is_the_sign(self):
        forward = rows_of(comparisons.compare_table(self.cells, [f"{A} - {B}"]))
        backward = rows_of(comparisons.compare_table(self.cells, [f"{B} - {A}"]))
        for f, b in zip(forward, backward):
            self.assertEqual(float(f[7].split(" +- ")[0]), -float(b[7].split(" +- ")[0]))
            self.assertEqual(f[9], b[9])


if __name__ == "__main__":
    unittest.main()
