#!/usr/bin/python3
"""`maps train` with "imitation": "gail" end to end (issue 45): every method the issue names trains from a run config
on a real task set, a finished run reruns as a no-op, a run stopped between iterations resumes, `maps eval` scores the
result, a BC run's parameters start a GAIL run (init.run), configs that cannot be meant are refused by name, and a
suite of both objectives runs and is reported with GAIL paired against BC. Run by ctest as: gail_test.py path/to/maps."""
import csv
import json
import math
import pathlib
import subprocess
import time
import unittest

import maps_tool
from maps_tool import main, run, work

GAIL = {"env_steps_per_task": 2000, "rollout_episodes": 1, "epochs": 2, "minibatch_per_task": 250,
        "discriminator_updates": 2}


def write_config(name, **changes):
    config = {"method": "maps", "data": {"file": "gravity.h5", "demos_per_task": 2, "subsample": 20,
                                         "tasks": ["gravity/0.5", "gravity/1.0"]},
              "maps": {"modules": 3, "module_hidden": [32], "selector_hidden": [16]},
              "imitation": "gail", "gail": dict(GAIL),
              "train": {"validation_states_per_task": 100},
              "eval": {"episodes": 2, "threads": 1}}
    for key, value in changes.items():
        section, _, inner = key.partition(".")
        if inner:
            config.setdefault(section, {})[inner] = value
        else:
            config[section] = value
    path = work() / f"{name}.json"
    path.write_text(json.dumps(config))
    return path


def curve_rows(folder):
    with open(work() / folder / "curve.csv") as f:
        return list(csv.DictReader(f))


class Gail(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        run("collect", "--set", "gravity", "--demos", "3", "--out", "gravity.h5", "--threads", "1")

    def test_every_method_of_the_issue_trains_and_is_evaluated(self):
        for method in ("maps", "mt_bc", "mt_mh_bc", "single_bc"):
            with self.subTest(method=method):
                changes = {} if method == "maps" else {"maps": {}}
                config = write_config(method, method=method, **changes)
                proc = run("train", "--config", config, "--out", method)
                self.assertIn("GAIL, 2000 env steps per task", proc.stdout)
                self.assertIn("done: GAIL, 2 iterations", proc.stdout)
                summary = json.loads((work() / method / "train.json").read_text())
                self.assertEqual(summary["imitation"], "gail")
                self.assertEqual(summary["env_steps_per_task"], 2000)
                self.assertEqual(summary["iterations"], 2)
                for part in ("physics_seconds", "rollout_policy_seconds", "discriminator_seconds", "ppo_seconds"):
                    self.assertGreater(summary[part], 0.0, part)
                rows = curve_rows(method)
                self.assertEqual([row["iteration"] for row in rows], ["1", "2"])
                self.assertIn("return:gravity/1.0", rows[0])
                if method == "maps":
                    self.assertIn("share", rows[0])
                run("eval", "--run", method)
                evaluation = json.loads((work() / method / "eval.json").read_text())
                self.assertEqual(len(evaluation["tasks"]), 2)

    def test_a_finished_run_reruns_as_a_no_op_and_a_stopped_one_resumes(self):
        config = write_config("resume")
        run("train", "--config", config, "--out", "whole")
        last = (work() / "whole" / "last.ckpt").read_bytes()
        proc = run("train", "--config", config, "--out", "whole")
        self.assertIn("done: GAIL, 2 iterations", proc.stdout)
        self.assertEqual((work() / "whole" / "last.ckpt").read_bytes(), last)
        # Killed (SIGKILL) once its first iterations are written, then run again: the same bytes as a run never
        # stopped.
        longer = write_config("longer", gail=dict(GAIL, env_steps_per_task=8000))
        run("train", "--config", longer, "--out", "uninterrupted")
        proc = subprocess.Popen([maps_tool.MAPS, "train", "--config", str(longer), "--out", "killed"], cwd=work(),
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        curve = work() / "killed" / "curve.csv"
        deadline = time.time() + 120
        while proc.poll() is None and time.time() < deadline:
            if curve.exists() and len(curve.read_text().splitlines()) >= 3:  # the header and two iterations
                proc.kill()
                break
            time.sleep(0.005)
        proc.wait()
        stopped_at = len(curve_rows("killed"))
        self.assertLess(stopped_at, 8, "the run ended before it was killed")
        run("train", "--config", longer, "--out", "killed")
        for name in ("last.ckpt", "best.ckpt"):
            self.assertEqual((work() / "killed" / name).read_bytes(), (work() / "uninterrupted" / name).read_bytes(),
                             f"{name} (killed after {stopped_at} iterations)")
        timing = {"env_steps_per_second": None, "cpu_seconds": None}  # measured, not computed
        self.assertEqual([dict(row, **timing) for row in curve_rows("killed")],
                         [dict(row, **timing) for row in curve_rows("uninterrupted")])
        for name in ("killed", "uninterrupted"):  # the resumed curve keeps every column
            self.assertEqual(list(curve_rows(name)[0])[-2:], ["env_steps_per_second", "cpu_seconds"], name)

    def test_a_bc_run_starts_a_gail_run(self):
        bc = write_config("bc", imitation="bc", gail={}, train={"steps": 30, "validate_every": 10,
                                                               "checkpoint_every": 10,
                                                               "validation_states_per_task": 100})
        run("train", "--config", bc, "--out", "bc")
        config = write_config("from_bc", init={"run": str(work() / "bc")})
        proc = run("train", "--config", config, "--out", "from_bc")
        self.assertIn("starting from", proc.stdout)

    def test_configs_that_cannot_be_meant_are_refused_by_name(self):
        cases = [
            (write_config("maml", method="maml", maps={}), "config imitation"),
            (write_config("bc_with_gail_keys", imitation="bc"), "config gail.env_steps_per_task: set, but imitation"),
            (write_config("bf16", train={"precision": "bf16"}), "config train.precision"),
            (write_config("clip", gail=dict(GAIL, clip=0)), "gail.clip"),
            (write_config("conditioning", gail=dict(GAIL, discriminator_conditioning="task")),
             "gail.discriminator_conditioning"),
        ]
        for config, message in cases:
            with self.subTest(message=message):
                proc = run("train", "--config", config, "--out", config.stem, check=False)
                self.assertNotEqual(proc.returncode, 0)
                self.assertIn(message, proc.stderr)
        # A BC run's folder is not resumed as a GAIL run.
        bc = write_config("bc_folder", imitation="bc", gail={}, train={"steps": 10, "validate_every": 10,
                                                                      "checkpoint_every": 10,
                                                                      "validation_states_per_task": 100})
        run("train", "--config", bc, "--out", "bc_folder")
        proc = run("train", "--config", write_config("gail_into_bc"), "--out", "bc_folder", check=False)
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("holds a run of another config", proc.stderr)

    def test_a_suite_runs_both_objectives_and_the_report_pairs_gail_with_bc(self):
        bc_train = {"steps": 20, "validate_every": 10, "checkpoint_every": 10, "validation_states_per_task": 100}
        suite = {
            "description": "GAIL against BC, tiny",
            "defaults": {"train": bc_train, "eval": {"episodes": 2, "threads": 1}},
            "sets": {"gravity": {"data": {"file": str(work() / "gravity.h5"), "collect_demos": 3, "subsample": 20},
                                 "demos": [1, 2],
                                 "config": {"data": {"tasks": ["gravity/0.5", "gravity/1.0"]},
                                            "maps": {"modules": 3, "module_hidden": [32], "selector_hidden": [16]}}}},
            "variants": {"gail": {"imitation": "gail", "gail": dict(GAIL)}},
            "grids": [{"name": "bc", "sets": ["gravity"], "methods": ["maps", "mt_bc"], "seeds": [0, 1]},
                      {"name": "gail", "sets": ["gravity"], "methods": ["maps", "mt_bc"], "variants": ["gail"],
                       "seeds": [0, 1]}]}
        path = work() / "adversarial.json"
        path.write_text(json.dumps(suite))
        run("suite", "run", path, "--out", "adversarial", "--jobs", "2", timeout=1200)
        report = work() / "adversarial" / "report"
        proc = subprocess.run([maps_tool.MAPS, "report", str(work() / "adversarial")], cwd=work(),
                              capture_output=True, text=True, timeout=600)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        text = (report / "report.md").read_text()
        self.assertIn("## Imitation objective: GAIL against BC", text)
        self.assertIn("GAIL: 2,000 env steps per task, checkpoint last", text)
        # Every (method, demos) setting paired over both seeds, and the difference is the mean of the per-seed
        # differences of the cells' own scores.
        scores = {}
        for result in (work() / "adversarial" / "cells" / "gravity").glob("*/result.json"):
            cell = json.loads(result.read_text())
            key = (cell["cell"]["method"], cell["config"]["imitation"], cell["cell"]["demos"], cell["cell"]["seed"])
            scores[key] = cell["eval"]["mean_score"]
        self.assertEqual(len(scores), 16)
        scores_table = text.split("## Imitation objective: GAIL against BC")[1].split("### MAPS against the others")[0]
        rows = [line for line in scores_table.splitlines()
                if line.startswith("| gravity | ") and " | 20 | 2 | " in line]
        for method, shown in (("maps", "MAPS"), ("mt_bc", "MT-BC")):
            for demos in (1, 2):
                row = [r for r in rows if r.startswith(f"| gravity | {shown} | {demos} | 20 | 2 |")]
                self.assertEqual(len(row), 1, (method, demos, rows))
                diffs = [scores[(method, "gail", demos, s)] - scores[(method, "bc", demos, s)] for s in (0, 1)]
                difference = row[0].split(" | ")[7]
                self.assertAlmostEqual(float(difference.split(" +- ")[0]), sum(diffs) / 2, delta=0.006)
        self.assertRegex(text, r"GAIL above BC after Holm in \d of 4 settings, below in \d\.")
        self.assertIn("### MAPS against the others under each objective", text)
        self.assertIn("| gravity | MAPS - MT-BC | 1 | 20 | 2 |", text)
        self.assertIn("### How fast each method learns under GAIL", text)
        # MT-BC's row pairs both seeds with MAPS's; MAPS's own row has no pairs.
        self.assertRegex(text, r"\| gravity \| MT-BC \| 1 \| 20 \| 2 \| 2,000 \| [-0-9.]+ \+- [0-9.]+ \| .* \| 2 \| ")
        self.assertRegex(text, r"\| gravity \| MAPS \| 1 \| 20 \| 2 \| 2,000 \| ")
        self.assertIn("### MAPS's routing under each objective", text)
        self.assertRegex(text, r"\| gravity \| 1 \| 20 \| GAIL \| 2 \| ")
        for figure in ("imitation_scores", "gail_curves", "gail_module_usage"):
            self.assertGreater((report / f"{figure}.png").stat().st_size, 1000, figure)
            with open(report / f"{figure}.csv") as f:
                self.assertTrue(list(csv.DictReader(f)), figure)
        with open(report / "gail_module_usage.csv") as f:
            usage = list(csv.DictReader(f))
        # MAPS under each objective at both counts, one seed: 2 tasks x 3 modules a panel.
        self.assertEqual(sorted({(r["objective"], r["demos"]) for r in usage}),
                         [("bc", "1"), ("bc", "2"), ("gail", "1"), ("gail", "2")])
        self.assertEqual(len(usage), 4 * 2 * 3)
        self.assertIn("![](gail_module_usage.png)", text)
        with open(report / "gail_curves.csv") as f:
            curve = list(csv.DictReader(f))
        # Two iterations of 1000 env steps per task, each point over both seeds.
        self.assertEqual(sorted({int(r["env_steps_per_task"]) for r in curve}), [1000, 2000])
        self.assertTrue(all(r["seeds"] == "2" and math.isfinite(float(r["mean"])) for r in curve))


if __name__ == "__main__":
    main(__file__)
