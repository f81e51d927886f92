#!/usr/bin/python3
"""A plugin's task set through the tool (issue 43): `maps collect --plugin P --set <its set>` makes a demo file from
the experts the plugin gives, a run config naming the plugin trains the plugin's method on it and `maps eval` scores
it; without the plugin, the set is refused by name. Run by ctest as
plugin_task_set_test.py path/to/maps path/to/libmaps_test_plugin.so."""
import json
import pathlib
import subprocess
import sys
import tempfile
import unittest

MAPS = None
PLUGIN = None


def maps(*args, cwd):
    return subprocess.run([MAPS, *map(str, args)], cwd=cwd, capture_output=True, text=True)


class PluginTaskSet(unittest.TestCase):
    def test_collect_train_and_evaluate_on_a_plugins_task_set(self):
        with tempfile.TemporaryDirectory(prefix="maps_plugin_set_") as work:
            collect = maps("collect", "--plugin", PLUGIN, "--set", "plugin_cheetah", "--demos", "3", "--out", "d.h5",
                           "--threads", "1", cwd=work)
            self.assertEqual(collect.returncode, 0, collect.stderr)
            self.assertIn("plugin_cheetah/g1_1", collect.stdout)
            config = {"plugins": [PLUGIN], "method": "plugin_linear", "data": {"file": "d.h5"},
                      "train": {"steps": 40, "validate_every": 20, "checkpoint_every": 20,
                                "validation_states_per_task": 50},
                      "eval": {"episodes": 1, "threads": 1}}
            pathlib.Path(work, "run.json").write_text(json.dumps(config))
            train = maps("train", "--config", "run.json", "--out", "run", cwd=work)
            self.assertEqual(train.returncode, 0, train.stderr)
            evaluate = maps("eval", "--run", "run", cwd=work)
            self.assertEqual(evaluate.returncode, 0, evaluate.stderr)
            tasks = json.loads(pathlib.Path(work, "run", "eval.json").read_text())["tasks"]
            self.assertEqual([t["task"] for t in tasks], ["plugin_cheetah/g0_9", "plugin_cheetah/g1_1"])
            self.assertEqual({t["scored_by"] for t in tasks}, {"return"})
            [record] = json.loads(pathlib.Path(work, "run", "provenance.json").read_text())
            self.assertIn("task set plugin_cheetah", record["plugins"][0]["registered"])

    def test_without_its_plugin_the_set_is_refused_by_name(self):
        with tempfile.TemporaryDirectory(prefix="maps_plugin_set_") as work:
            proc = maps("collect", "--set", "plugin_cheetah", "--demos", "3", "--out", "d.h5", cwd=work)
            self.assertEqual(proc.returncode, 2, proc.stderr)  # a usage error: the command line names no plugin
            self.assertIn("plugin_cheetah", proc.stderr)
            proc = maps("collect", "--plugin", PLUGIN, "--set", "no_such_set", "--demos", "3", "--out", "d.h5",
                        cwd=work)
            self.assertNotEqual(proc.returncode, 0)
            self.assertIn("unknown task set 'no_such_set'", proc.stderr)
            self.assertIn("plugin_cheetah", proc.stderr)  # listed among the valid ones once loaded
            self.assertFalse(pathlib.Path(work, "d.h5").exists())


if __name__ == "__main__":
    PLUGIN = str(pathlib.Path(sys.argv.pop(2)).resolve())
    MAPS = str(pathlib.Path(sys.argv.pop(1)).resolve())
    unittest.main()
