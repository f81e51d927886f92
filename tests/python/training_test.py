#!/usr/bin/python3
"""Selector losses and methods written in Python, trained by the C++ trainer (issue 43, item 2): registration and its
refusals, gradients through a Python loss into MAPS's selector, a Python policy trained and resumed by maps.train,
what the run folder records of the Python code, errors raised in the user's code reaching the caller, and a config's
Python plugin loaded by the tool's embedded interpreter. Run by ctest as training_test.py path/to/maps, with
PYTHONPATH=<build>/python."""
import csv
import hashlib
import json
import pathlib
import subprocess
import sys
import tempfile
import unittest

import numpy as np

import maps

MAPS = None  # the maps tool, from argv
WORK = None  # a temporary folder: a demo file made once for every test

SMALL = {"steps": 40, "validate_every": 20, "checkpoint_every": 20, "validation_states_per_task": 50,
         "states_per_task": 16}


def config(method="maps", **more):
    base = {"method": method, "seed": 0, "data": {"file": str(pathlib.Path(WORK) / "gravity.h5")}, "train": SMALL,
            "maps": {"modules": 3}, "eval": {"episodes": 1, "threads": 1}}
    base.update(more)
    return base


def curve(run):
    with open(pathlib.Path(run) / "curve.csv") as f:
        return list(csv.DictReader(f))


def setUpModule():
    subprocess.run([MAPS, "collect", "--set", "gravity", "--demos", "3", "--out", "gravity.h5", "--threads", "1"],
                   cwd=WORK, check=True, capture_output=True)


class UsageEntropy(maps.SelectorLoss):
    """Minus the entropy of the batch's mean module usage (spreads the states over the modules)."""

    def forward(self, outputs):
        usage = maps.mean(outputs.scores, [0])
        return maps.sum(usage * maps.log(maps.clamp(usage, min=1e-30)))


class Raising(maps.SelectorLoss):
    def forward(self, outputs):
        raise ZeroDivisionError("raised inside a Python selector loss")


class NotATensor(maps.SelectorLoss):
    def forward(self, outputs):
        return 1.0


class Linear(maps.Policy):
    """A linear map of [state, one-hot task] with an L2 term beside the BC loss."""

    def __init__(self, shape, generator):
        super().__init__(shape)
        self.linear = maps.nn.Linear(shape.observation_size + shape.num_tasks, shape.action_size, generator=generator)

    def act(self, observations, tasks):
        onehot = maps.one_hot(list(tasks), self.shape.num_tasks)
        return self.linear(maps.concat([observations, onehot], 1))

    def loss(self, batch):
        return {"bc": self.bc_loss(self.act(batch.observations, batch.tasks), batch),
                "l2": maps.sum(maps.square(self.linear.weight)) * 1e-4}


class BadLoss(Linear):
    def loss(self, batch):
        return "not a loss"


class Registration(unittest.TestCase):
    def test_a_loss_is_known_by_name_after_the_built_ins(self):
        maps.register_selector_loss("py_usage_entropy", UsageEntropy)
        names = maps.selector_loss_names()
        self.assertEqual(names[:4], ["share", "explore", "sparse", "smooth"])
        self.assertIn("py_usage_entropy", names)
        maps.register_selector_loss("py_usage_entropy", UsageEntropy)  # the same class again: nothing happens

    def test_refusals(self):
        with self.assertRaisesRegex(ValueError, "'share'.*taken"):
            maps.register_selector_loss("share", UsageEntropy)
        maps.register_selector_loss("py_taken_once", UsageEntropy)
        with self.assertRaisesRegex(ValueError, "'py_taken_once'.*taken"):
            maps.register_selector_loss("py_taken_once", Raising)
        with self.assertRaisesRegex(ValueError, "lowercase letter"):
            maps.register_selector_loss("Not-Plain", UsageEntropy)
        with self.assertRaisesRegex(TypeError, "subclass of maps.SelectorLoss"):
            maps.register_selector_loss("py_not_a_loss", Linear)
        with self.assertRaisesRegex(TypeError, "subclass of maps.Policy"):
            maps.register_method("py_not_a_policy", UsageEntropy)
        with self.assertRaisesRegex(ValueError, "'mt_bc'.*taken"):
            maps.register_method("mt_bc", Linear)

    def test_a_python_loss_is_gradchecked_in_float64(self):
        rng = np.random.default_rng(1)
        logits = maps.tensor(rng.normal(size=(6, 3)), requires_grad=True)
        loss = UsageEntropy()

        def of_logits(x):
            return loss(maps.SelectorOutputs(maps.softmax(x, 1), [0, 0, 1, 1, 2, 2], 3))

        self.assertTrue(maps.gradcheck(of_logits, [logits]))
        self.assertTrue(maps.gradgradcheck(of_logits, [logits]))
        with self.assertRaisesRegex(ValueError, "one task per row"):
            maps.SelectorOutputs(maps.softmax(logits, 1), [0, 1], 3)


class Train(unittest.TestCase):
    def test_a_python_loss_trains_maps_and_moves_its_selector(self):
        out = pathlib.Path(WORK) / "entropy"
        maps.train(config(maps={"modules": 3, "selector_losses": {"share": 1, "py_usage_entropy": 5.0}}), out,
                   selector_losses={"py_usage_entropy": UsageEntropy})
        rows = curve(out)
        self.assertIn("py_usage_entropy", rows[0])
        self.assertEqual(json.loads((out / "config.json").read_text())["maps"]["selector_losses"],
                         {"share": 1.0, "py_usage_entropy": 5.0})
        # Its gradient reaches the selector: without it the same seed trains another selector.
        without = pathlib.Path(WORK) / "without"
        maps.train(config(maps={"modules": 3, "selector_losses": {"share": 1}}), without)
        entropy = maps.load_run(out).policy.state_dict()
        other = maps.load_run(without).policy.state_dict()
        selector = [name for name in entropy if name.startswith("selector")]
        self.assertTrue(selector)
        self.assertTrue(any(not np.array_equal(entropy[n].numpy(), other[n].numpy()) for n in selector))
        # Provenance names the class's file and its digest.
        [record] = json.loads((out / "provenance.json").read_text())
        source = str(pathlib.Path(__file__).resolve())
        [entry] = [p for p in record["plugins"] if p["path"] == source]
        self.assertEqual(entry["sha256"], hashlib.sha256(pathlib.Path(source).read_bytes()).hexdigest())
        self.assertIn("selector loss py_usage_entropy (__main__.UsageEntropy)", entry["registered"])

    def test_a_python_policy_trains_resumes_and_extends(self):
        out = pathlib.Path(WORK) / "linear"
        maps.train(config(method="py_linear"), out, policy=Linear)
        rows = curve(out)
        self.assertEqual(len(rows), 2)
        self.assertIn("l2", rows[0])
        self.assertLess(float(rows[-1]["validation_bc"]), float(rows[0]["validation_bc"]) * 1.5)
        maps.train(config(method="py_linear"), out, policy=Linear)  # finished: nothing more to do
        self.assertEqual(len(curve(out)), 2)
        maps.train(config(method="py_linear"), out, policy=Linear, overrides=["train.steps=60"])
        self.assertEqual([int(r["step"]) for r in curve(out)], [20, 40, 60])
        run = maps.load_run(out)
        self.assertEqual(run.method, "py_linear")
        self.assertEqual(run.act(np.zeros((2, run.observation_size)), [0, 1]).shape, (2, run.action_size))

    def test_errors_in_the_users_code_reach_the_caller(self):
        maps.register_selector_loss("py_raising", Raising)
        with self.assertRaisesRegex(ZeroDivisionError, "inside a Python selector loss"):
            maps.train(config(maps={"modules": 3, "selector_losses": {"py_raising": 1}}), pathlib.Path(WORK) / "r")
        maps.register_selector_loss("py_not_a_tensor", NotATensor)
        with self.assertRaises(RuntimeError):
            maps.train(config(maps={"modules": 3, "selector_losses": {"py_not_a_tensor": 1}}),
                       pathlib.Path(WORK) / "n")
        with self.assertRaisesRegex(TypeError, "loss\\(batch\\) returned"):
            maps.train(config(method="py_bad_loss"), pathlib.Path(WORK) / "b", policy=BadLoss)
        with self.assertRaisesRegex(ValueError, "unknown selector loss 'py_never_registered'"):
            maps.train(config(maps={"selector_losses": {"py_never_registered": 1}}), pathlib.Path(WORK) / "u")


PLUGIN = '''
import maps


class Spread(maps.SelectorLoss):
    def forward(self, outputs):
        usage = maps.mean(outputs.scores, [0])
        return maps.sum(maps.square(usage))


maps.register_selector_loss("py_file_spread", Spread)
'''


class PythonPluginInTheTool(unittest.TestCase):
    def test_the_tool_trains_evaluates_and_records_a_python_plugin(self):
        folder = pathlib.Path(WORK) / "plugin"
        folder.mkdir()
        (folder / "spread.py").write_text(PLUGIN)
        run_config = config(plugins=["spread.py"], maps={"modules": 3, "selector_losses": {"py_file_spread": 1}})
        (folder / "run.json").write_text(json.dumps(run_config))
        out = folder / "run"
        subprocess.run([MAPS, "train", "--config", folder / "run.json", "--out", out], check=True,
                       capture_output=True)
        subprocess.run([MAPS, "eval", "--run", out], check=True, capture_output=True)
        self.assertIn("py_file_spread", curve(out)[0])
        self.assertEqual(json.loads((out / "config.json").read_text())["plugins"], [str(folder / "spread.py")])
        records = json.loads((out / "provenance.json").read_text())
        for record in records:
            [entry] = record["plugins"]
            self.assertEqual(entry["path"], str(folder / "spread.py"))
            self.assertEqual(entry["built_against"], "python")
            self.assertEqual(entry["sha256"], hashlib.sha256(PLUGIN.encode()).hexdigest())
        self.assertEqual(records[0]["plugins"][0]["registered"], ["selector loss py_file_spread"])
        # The same run config trained from Python gives the same curve (one trainer, one loss).
        again = folder / "again"
        maps.train(folder / "run.json", again)
        self.assertEqual([r["validation_bc"] for r in curve(out)], [r["validation_bc"] for r in curve(again)])

    def test_a_missing_or_failing_python_plugin_is_named(self):
        folder = pathlib.Path(WORK) / "bad_plugin"
        folder.mkdir()
        (folder / "broken.py").write_text("import no_such_module_here\n")
        for plugin, message in (("missing.py", "missing.py' does not exist"),
                                ("broken.py", "broken.py' failed: .*No module named 'no_such_module_here'")):
            (folder / "run.json").write_text(json.dumps(config(plugins=[plugin])))
            proc = subprocess.run([MAPS, "train", "--config", folder / "run.json", "--out", folder / "run"],
                                  capture_output=True, text=True)
            self.assertNotEqual(proc.returncode, 0)
            self.assertRegex(proc.stderr, message)
            self.assertFalse((folder / "run" / "config.json").exists())


if __name__ == "__main__":
    MAPS = str(pathlib.Path(sys.argv.pop(1)).resolve())
    with tempfile.TemporaryDirectory(prefix="maps_training_test_") as WORK:
        unittest.main()
