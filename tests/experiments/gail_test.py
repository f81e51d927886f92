#!/usr/bin/python3
"""`maps train` with "imitation": "gail" end to end (issue 45): every method the issue names trains from a run config
on a real task set, a finished run reruns as a no-op, a run stopped between iterations resumes, `maps eval` scores the
result, a BC run's parameters start a GAIL run (init.run), and configs that cannot be meant are refused by name. Run
by ctest as: gail_test.py path/to/maps."""
import csv
import json
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
        speed = "env_steps_per_second"
        self.assertEqual([dict(row, **{speed: None}) for row in curve_rows("killed")],
                         [dict(row, **{speed: None}) for row in curve_rows("uninterrupted")])

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


if __name__ == "__main__":
    main(__file__)
