#!/usr/bin/python3
"""GAIL learns a real task (issue 45): a single-task run on gravity/1.0 from 5 of the expert's demonstrations
(subsampled every 20 steps) at the documented defaults reaches at least 0.8 of the expert's return, scored as the study
scores it (`maps eval`, 20 episodes from the evaluation seeds), within 500,000 env steps. Measured on an AMD EPYC
(Zen 5): 0.930 +- 0.016 after 500,000 env steps (2026-12-05, about a minute on one core) and 0.872 +- 0.010 after
1,000,000 (2026-12-03, the budget until CI needed the minute back), on this test's own 8 collected demonstrations
(docs/adversarial.md). Run by ctest as: gail_learns_test.py path/to/maps."""
import json
import sys
import unittest

from maps_tool import main, run, work

ENV_STEPS = 500_000
FRACTION = 0.8


class GailLearns(unittest.TestCase):
    def test_one_gravity_task_reaches_most_of_the_experts_return(self):
        run("collect", "--set", "gravity", "--demos", "8", "--out", "gravity.h5", "--threads", "2")
        config = work() / "gail.json"
        config.write_text(json.dumps({
            "method": "mt_bc", "seed": 0,
            "data": {"file": "gravity.h5", "demos_per_task": 5, "subsample": 20, "tasks": ["gravity/1.0"]},
            "imitation": "gail", "gail": {"env_steps_per_task": ENV_STEPS, "rollout_episodes": 2},
            "eval": {"episodes": 20, "threads": 1}}))
        run("train", "--config", config, "--out", "run", timeout=1800)
        run("eval", "--run", "run")
        evaluation = json.loads((work() / "run" / "eval.json").read_text())
        (task,) = evaluation["tasks"]
        self.assertEqual(task["task"], "gravity/1.0")
        print(f"gravity/1.0 by GAIL: score {task['score']:.3f} +- {task['score_ci95']:.3f} after {ENV_STEPS} env steps",
              file=sys.stderr)
        self.assertGreaterEqual(task["score"], FRACTION,
                                f"GAIL reached {task['score']:.3f} of the expert's return in {ENV_STEPS} env steps")


if __name__ == "__main__":
    main(__file__)
