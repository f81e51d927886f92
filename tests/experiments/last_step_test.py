#!/usr/bin/python3
"""Tests of the final-checkpoint table (experiments/report/last_step.py): on the committed results/zoo-modern and its
last-checkpoint evaluations it writes the committed report.md; every way an evaluation file can disagree with its
cell (another method, seed, count, checkpoint step or episode count, a value of the wrong type, another
checkpoint's score, a step short of training's end, no "last", a non-finite or inconsistent score, tasks other than
the cell's, a cell the suite lacks, a cell of the base method itself, a file that is not JSON) is refused with the file
named, never used; the probability of improvement is the last step's task scores against MAPS's, by hand; without a
base method the rows stand alone, and another suite's variant is paired by seed with both rules.
Run by ctest (tests/CMakeLists.txt)."""
import contextlib
import copy
import functools
import io
import json
import os
import pathlib
import re
import shutil
import subprocess
import sys
import tempfile
import types
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "experiments" / "report" / "last_step.py"
SUITE = ROOT / "results" / "zoo-modern"
EVALS = SUITE / "last-checkpoint"


sys.path.insert(0, str(SCRIPT.parent))
import last_step  # noqa: E402

# The committed suite is only read here (the tests change copies of the evaluation files): loaded once, not by each of
# the 30-odd runs below (each load runs `maps suite status`; with the interpreter's start and the imports, a run in a
# process of its own took 1.6 s).
last_step.load_suite = functools.lru_cache(last_step.load_suite)


def run_process(evals, *extra):
    """The script as docs/zoo.md runs it: from the repository's root, the suite named relative to it."""
    return subprocess.run(["/usr/bin/python3", str(SCRIPT), str(SUITE.relative_to(ROOT)), str(evals), *extra],
                          capture_output=True, text=True, cwd=ROOT)


def run(evals, *extra):
    """As run_process, but the script's main() in this process, its exit status and printed text captured alike."""
    out, err = io.StringIO(), io.StringIO()
    argv, cwd = sys.argv, os.getcwd()
    try:
        sys.argv = [str(SCRIPT), str(SUITE.relative_to(ROOT)), str(evals), *map(str, extra)]
        os.chdir(ROOT)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            status = last_step.main()
    finally:
        sys.argv = argv
        os.chdir(cwd)
    return types.SimpleNamespace(returncode=status, stdout=out.getvalue(), stderr=err.getvalue())


class LastStepTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.evals = pathlib.Path(self.tmp.name) / "evals"
        shutil.copytree(EVALS, self.evals, ignore=shutil.ignore_patterns("*.md"))
        self.files = sorted(self.evals.glob("*.json"))
        self.assertTrue(self.files, f"no evaluations under {EVALS}")

    def tearDown(self):
        self.tmp.cleanup()

    def test_the_committed_table_is_recomputed(self):
        out = pathlib.Path(self.tmp.name) / "report.md"
        proc = run_process(EVALS, "--out", str(out))
        self.assertEqual(proc.returncode, 0, proc.stderr)
        committed = (SUITE / "report" / "last_step.md").read_text()  # as `maps report results/zoo-modern` wrote it
        self.assertEqual(out.read_text(), committed)
        self.assertIn("| gravity | diffusion_policy (dp_mlp_h1) | 5 | 10 |", proc.stdout)

    def test_the_aggregates_are_the_last_steps_task_scores_against_maps(self):
        """P(maps > last step) by hand for one row: over each task, the share of (MAPS run, last-step run) pairs MAPS
        wins, ties counting a half, averaged over tasks; the IQM is the mean of the middle half of the pooled last-step
        scores (5 seeds x 5 tasks)."""
        proc = run(EVALS)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        row = next(line.split(" | ") for line in proc.stdout.splitlines()
                   if line.startswith("| gravity | diffusion_policy (dp_mlp_h1) | 5 |"))
        last = []  # per seed: {task: score at the last step}
        for path in sorted(EVALS.glob("gravity-diffusion_policy-dp_mlp_h1_d5_s*.json")):
            record = json.loads(path.read_text())
            last.append(dict(zip((t["task"] for t in record["tasks"]), record["last"]["scores"])))
        maps = []
        for path in sorted((SUITE / "cells" / "gravity").glob("maps_d5_s*/result.json")):
            maps.append({t["task"]: t["score"] for t in json.loads(path.read_text())["eval"]["tasks"]})
        shares = []
        for task in last[0]:
            wins = sum((m[task] > l[task]) + 0.5 * (m[task] == l[task]) for m in maps for l in last)
            shares.append(wins / (len(maps) * len(last)))
        self.assertEqual(row[16].split(" [")[0], f"{sum(shares) / len(shares):.3f}")
        pooled = sorted(score for seed in last for score in seed.values())
        quarter = len(pooled) // 4  # 25 scores: the middle 13 after dropping 6 from each end
        middle = pooled[quarter:len(pooled) - quarter]
        self.assertEqual(len(pooled), 25)
        self.assertEqual(row[15].split(" [")[0], f"{sum(middle) / len(middle):.3f}")

    def test_tasks_reordered_with_their_scores_change_nothing(self):
        """A file whose tasks and last.scores are both reordered says the same thing: the table reads tasks by name."""
        record = json.loads(self.files[0].read_text())
        record["tasks"].reverse()
        record["last"]["scores"].reverse()
        self.files[0].write_text(json.dumps(record))
        self.assertEqual(run(self.evals).stdout, run(EVALS).stdout)

    def damaged(self, change):
        """The first file changed by `change` (a function of its JSON); returns the script's run on the folder."""
        path = self.files[0]
        record = json.loads(path.read_text())
        change(record)
        path.write_text(json.dumps(record))
        return run(self.evals), path

    def assert_refused(self, proc, path, message):
        self.assertEqual(proc.returncode, 2, proc.stdout)
        self.assertIn(path.name, proc.stderr)
        self.assertIn(message, proc.stderr)
        self.assertEqual(proc.stdout, "")

    def test_a_file_that_disagrees_with_its_cell_is_refused(self):
        cases = [
            (lambda r: r.update(seed=r["seed"] + 1), "seed is"),
            (lambda r: r.update(method="mt_mh_bc"), "method is 'mt_mh_bc'"),
            (lambda r: r.update(demos_per_task=float(r["demos_per_task"])), "demos_per_task is"),
            (lambda r: r.update(seed=r["seed"] == 1), "seed is"),
            (lambda r: r.update(best_step=r["best_step"] + 250), "best_step is"),
            (lambda r: r.update(episodes=10), "episodes is 10"),
            (lambda r: r.update(subsample=1), "subsample is 1"),
            (lambda r: r.update(mean_score=r["mean_score"] + 0.01), "not the same checkpoint"),
            (lambda r: r.update(mean_score=float("nan")), "expected a finite number"),
            (lambda r: r.pop("last"), "no \"last\" object"),
            (lambda r: r["last"].update(step=r["last"]["step"] - 1), "the cell trained"),
            (lambda r: r["last"].update(step=float(r["last"]["step"])), "the cell trained"),
            (lambda r: r["last"].update(mean_score=float("inf")), "last.mean_score is inf"),
            (lambda r: r["last"].update(mean_score=r["last"]["mean_score"] + 0.5), "not the mean of last.scores"),
            (lambda r: r["last"]["scores"].pop(), "task scores"),
            (lambda r: r["last"]["scores"].__setitem__(0, "0.5"), "last.scores[0]"),
            (lambda r: r["tasks"][0].update(task="gravity/9.9"), "tasks[0] names 'gravity/9.9'"),
            (lambda r: r["tasks"][0].update(task=1), "tasks[0] names 1"),
            (lambda r: r["tasks"][1].update(task=r["tasks"][0]["task"]), "each once"),
            (lambda r: r.pop("tasks"), "tasks is not a list"),
            (lambda r: r["tasks"].pop(), "tasks is not a list"),
            (lambda r: r["tasks"][0].update(score="0.5"), "tasks[0].score"),
            (lambda r: r["tasks"][0].update(score=r["tasks"][0]["score"] + 0.01), "not the same task"),
        ]
        original = self.files[0].read_text()
        for change, message in cases:
            with self.subTest(message=message):
                self.files[0].write_text(original)
                proc, path = self.damaged(change)
                self.assert_refused(proc, path, message)

    def test_a_file_naming_no_cell_or_not_json_is_refused(self):
        stray = self.evals / "gravity-maps_d5_s9.json"
        shutil.copy(self.files[0], stray)
        self.assert_refused(run(self.evals), stray, "no finished cell gravity/maps_d5_s9")
        stray.unlink()
        # The base method's own cells are what every row pairs with, not a row.
        base = self.evals / "gravity-maps_d5_s0.json"
        shutil.copy(self.files[0], base)
        self.assert_refused(run(self.evals), base, "method is 'diffusion_policy'")
        record = json.loads(self.files[0].read_text())
        cell = json.loads((SUITE / "cells/gravity/maps_d5_s0/result.json").read_text())
        record.update(method="maps", seed=0, best_step=cell["eval"]["best_step"], mean_score=cell["eval"]["mean_score"],
                      tasks=[{"task": t["task"], "score": t["score"]} for t in cell["eval"]["tasks"]])
        base.write_text(json.dumps(record))
        self.assert_refused(run(self.evals), base, "a cell of maps, the method every row is paired with")
        base.unlink()
        self.files[0].write_text("{\"mean_score\": ")
        self.assert_refused(run(self.evals), self.files[0], self.files[0].name)
        self.files[0].write_text("[1, 2]")
        self.assert_refused(run_process(self.evals), self.files[0], "expected a JSON object")  # as a user sees it
        empty = pathlib.Path(self.tmp.name) / "empty"
        empty.mkdir()
        proc = run(empty)
        self.assertEqual(proc.returncode, 2)
        self.assertIn("no <set>-<cell>.json files", proc.stderr)

    def test_without_a_base_method_the_rows_are_last_against_best_alone(self):
        proc = run(EVALS, "--base", "none")
        self.assertEqual(proc.returncode, 0, proc.stderr)
        header = next(line for line in proc.stdout.splitlines() if line.startswith("| set |"))
        self.assertNotIn("pairs with", header)
        self.assertEqual(header.count("|"), 12)
        with_base = run(EVALS)
        # The same rows, their first ten columns alike.
        rows = [line.split(" | ")[:9] for line in proc.stdout.splitlines() if line.startswith("| gravity |")]
        self.assertEqual(rows, [line.split(" | ")[:9] for line in with_base.stdout.splitlines()
                                if line.startswith("| gravity |")])
        self.assertTrue(rows)

    def test_another_suites_variant_is_paired_by_seed_with_both_rules(self):
        """GAIL's cells against BC's last step and best-validation checkpoint: by seed, a seed only one ran left out,
        another variant or count not used; the differences and p by hand."""
        rows = [dict(set="mt10", method="maps", demos=2, k=1, seed_list=[0, 1, 2], best=[0.4, 0.56, 0.28],
                     last=[0.52, 0.6, 0.5]),
                dict(set="mt10", method="mt_bc", demos=2, k=1, seed_list=[0], best=[0.6], last=[0.7])]

        def cell(method, variant, demos, seed, score):
            return types.SimpleNamespace(set="mt10", method=method, variant=variant, demos=demos, subsample=1,
                                         seed=seed, mean_score=score)
        other = types.SimpleNamespace(cells=[cell("maps", "gail_mt10", 2, 0, 0.5), cell("maps", "gail_mt10", 2, 1, 0.7),
                                             cell("maps", "gail_mt10", 2, 3, 0.9),  # no BC seed 3
                                             cell("maps", "gail", 2, 2, 0.1),  # another variant
                                             cell("maps", "gail_mt10", 1, 2, 0.1),  # another count
                                             cell("mt_bc", "gail_mt10", 2, 0, 0.65)])
        found = last_step.against_rows(rows, other, "gail_mt10")
        self.assertEqual([(r["method"], r["pairs"]) for r in found], [("maps", 2), ("mt_bc", 1)])
        maps_row = found[0]
        for got, want in zip(maps_row["vs_last"], [0.5 - 0.52, 0.7 - 0.6]):
            self.assertAlmostEqual(got, want)
        for got, want in zip(maps_row["vs_best"], [0.5 - 0.4, 0.7 - 0.56]):
            self.assertAlmostEqual(got, want)
        self.assertEqual(maps_row["vs_last_p"], last_step.paired_p(maps_row["vs_last"]))
        text = last_step.against_table(found, "gail_mt10")
        self.assertIn("| mt10 | mt_bc | 2 | 1 | 1 | 0.65 | 0.70 | 0.60 | -0.05 |", text)


class ReportLastStepTest(unittest.TestCase):
    """`maps report DIR` writes DIR/report/last_step.md from DIR/last-checkpoint/, paired as the suite config's
    report.last_step_base and report.last_step_against say; a suite.json edited to say otherwise is refused by key."""

    @classmethod
    def setUpClass(cls):
        import report
        cls.report = report

    def write(self, root, suite):
        with tempfile.TemporaryDirectory() as tmp:
            cwd = os.getcwd()
            try:
                os.chdir(ROOT)
                path = self.report.write_last_step(suite, root, pathlib.Path(tmp))
            finally:
                os.chdir(cwd)
            return path.name, path.read_text()

    def test_the_committed_pages_are_the_reports_own(self):
        for root in ("results/zoo-modern", "results/adversarial/bc-last-cheetah", "results/adversarial/bc-last"):
            with self.subTest(root=root):
                suite = last_step.load_suite(str(ROOT / root))
                name, text = self.write(root, suite)
                self.assertEqual(name, "last_step.md")
                self.assertEqual(text, (ROOT / root / "report" / "last_step.md").read_text())
        # bc-last's config asks for no base method and GAIL's cells beside: both show.
        self.assertIn("## Another objective against both checkpoint rules", text)
        self.assertIn("results/adversarial's gail_mt10 cells", text)
        self.assertNotIn("P(", text.split("## Another")[0].splitlines()[2])

    def test_a_suite_without_evaluations_gets_no_page(self):
        suite = last_step.load_suite(str(ROOT / "results" / "adversarial"))
        self.assertIsNone(self.report.write_last_step(suite, ROOT / "results" / "adversarial",
                                                      pathlib.Path("/nowhere")))

    def test_an_other_suite_that_cannot_be_read_is_an_error_naming_it(self):
        suite = copy.copy(last_step.load_suite(str(ROOT / "results" / "adversarial" / "bc-last")))
        suite.config = dict(suite.config, report={"last_step_base": "none", "last_step_against": ["../nowhere", "x"]})
        with self.assertRaisesRegex(last_step.SuiteError, "nowhere"):
            self.write("results/adversarial/bc-last", suite)
        suite.config = dict(suite.config,
                            report={"last_step_base": "none", "last_step_against": ["..", "gail_nothing"]})
        with self.assertRaisesRegex(last_step.LastStepError, "no finished cells of variant 'gail_nothing'"):
            self.write("results/adversarial/bc-last", suite)

    def test_the_last_steps_routing_is_tabulated_and_a_damaged_one_refused(self):
        """last.routing (maps eval --last for a policy that routes): the routing table's last-step columns are the
        files' means; a routing that lacks a task, is no distribution, or has an entropy past ln M is refused, naming
        the file."""
        root = ROOT / "results" / "adversarial" / "bc-last"
        suite = last_step.load_suite(str(root))
        text = (root / "report" / "last_step.md").read_text()
        self.assertIn("## Routing at the last step", text)
        record = json.loads((root / "last-checkpoint" / "mt10-maps_d1_s0.json").read_text())
        entropies = [r["selector_entropy"] for r in record["last"]["routing"]]
        self.assertEqual(len(entropies), 10)
        cells = {(c.set, c.folder.name): c for c in suite.cells}
        _, _, _, routed = last_step.read_last(root / "last-checkpoint" / "mt10-maps_d1_s0.json", cells)
        self.assertAlmostEqual(routed[0], sum(entropies) / len(entropies))
        damages = [(lambda r: r["last"]["routing"].pop(), "must hold each of the cell's 10 tasks once"),
                   (lambda r: r["last"]["routing"][0]["module_usage"].__setitem__(0, 0.9), "is not a distribution"),
                   (lambda r: r["last"]["routing"][0].__setitem__("selector_entropy", 2.4), "outside [0, ln 10]"),
                   (lambda r: r["last"]["routing"][0].__setitem__("module_usage", [0.5, 0.5]), "not a list of 10"),
                   (lambda r: r["last"]["routing"][0].__setitem__("selector_top_score", float("nan")), "finite")]
        for damage, message in damages:
            with self.subTest(message=message), tempfile.TemporaryDirectory() as tmp:
                bad = copy.deepcopy(record)
                damage(bad)
                path = pathlib.Path(tmp) / "mt10-maps_d1_s0.json"
                path.write_text(json.dumps(bad))
                with self.assertRaisesRegex(last_step.EvalFileError, f"{path}.*{re.escape(message)}"):
                    last_step.read_last(path, cells)

    def test_a_cell_without_recorded_entropies_has_no_routing_row_entry(self):
        """A result.json from before evaluations recorded the selector's entropy and top score: its cell is left out of
        the routing table (neither a crash nor a mean over the tasks that have them), on either side of a pair."""
        def task(name, usage, entropy, top):
            return types.SimpleNamespace(task=name, usage=usage, entropy=entropy, top_score=top)
        whole = [task("a", [0.9, 0.1], 0.3, 0.9), task("b", [0.2, 0.8], 0.4, 0.8)]
        old = [task("a", [0.9, 0.1], None, None), task("b", [0.2, 0.8], 0.4, 0.8)]
        self.assertIsNone(last_step.routing(types.SimpleNamespace(tasks=old)))
        entropy, top, tv = last_step.routing(types.SimpleNamespace(tasks=whole))
        self.assertAlmostEqual(entropy, 0.35)
        self.assertAlmostEqual(top, 0.85)
        self.assertAlmostEqual(tv, 0.35)  # each task 0.35 from the tasks' mean usage (0.55, 0.45)

        def cell(seed, tasks):
            return types.SimpleNamespace(set="mt10", method="maps", variant="gail_mt10", demos=1, subsample=1,
                                         seed=seed, has_usage=True, tasks=tasks)
        bc = (entropy, top, tv - 0.1)
        rows = [dict(set="mt10", method="maps", demos=1, k=1, routing={0: (bc, bc), 1: (bc, bc)})]
        found = last_step.routing_rows(rows, types.SimpleNamespace(cells=[cell(0, whole), cell(1, old)]), "gail_mt10")
        self.assertEqual(len(found[0]["other"]), 1)
        self.assertEqual(len(found[0]["vs_last"]), 1)
        self.assertAlmostEqual(found[0]["vs_last"][0], 0.1)

    def test_bad_settings_are_refused_by_key(self):
        suite = copy.copy(last_step.load_suite(str(ROOT / "results" / "adversarial" / "bc-last")))  # not the cached one
        for key, value in [("last_step_base", ""), ("last_step_base", 3), ("last_step_against", ["..", ""]),
                           ("last_step_against", [".."]), ("last_step_against", "..")]:
            with self.subTest(key=key, value=value):
                suite.config = dict(suite.config, report={key: value})
                with self.assertRaisesRegex(last_step.SuiteError, f"config.report.{key}: expected"):
                    self.report.check_report_config(suite)


if __name__ == "__main__":
    unittest.main()
