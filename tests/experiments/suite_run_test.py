#!/usr/bin/python3
"""Tests of `maps suite` (plan, run, status, merge) through the real tool on experiments/suites/tiny.json: the grid's
expansion and order, shards that partition the cells, config errors that name their key, kill -9 of a running suite
then a rerun equal to an uninterrupted run, damaged cells redone rather than trusted, failed cells reported, and the
merge of shards equal to a single run. Run by ctest as: suite_run_test.py path/to/maps (from a scratch folder: the
tiny suite collects its own demo files under data/tiny/ of the working directory)."""
import copy
import csv
import fcntl
import json
import math
import os
import pathlib
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]
TINY = ROOT / "experiments" / "suites" / "tiny.json"
MAPS = None  # set from argv
# MAPS_TEST_QUICK=1 (CI's sanitizer pass, where a training step at the paper's shapes is some 30 times slower): the
# tests that run whole extra suites are left to the Release pass, and the rest run tiny.json with small networks
# (quick_tiny below); they still exercise every subcommand's code under the sanitizers.
QUICK = os.environ.get("MAPS_TEST_QUICK") == "1"
heavy = unittest.skipIf(QUICK, "MAPS_TEST_QUICK: a whole extra suite run, left to the Release pass")
WORK = None  # the scratch working directory (demo files are collected here once)


def maps(*args, check=True):
    proc = subprocess.run([MAPS, *map(str, args)], cwd=WORK, capture_output=True, text=True)
    if check and proc.returncode != 0:
        raise AssertionError(f"maps {' '.join(map(str, args))} exited {proc.returncode}:\n{proc.stdout}\n{proc.stderr}")
    return proc


def slow_down(result_path, factor):
    """Makes a finished cell `factor` times as costly as it was: its evaluation's seconds and its curve's training time
    (cpu_seconds where the curve has them, else steps_per_second)."""
    result = json.loads(result_path.read_text())
    result["eval"]["seconds"] *= factor
    result_path.write_text(json.dumps(result))
    curve = result_path.parent / "curve.csv"
    with curve.open() as f:
        rows = list(csv.DictReader(f))
    with curve.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        for row in rows:
            if "cpu_seconds" in row:
                writer.writerow(dict(row, cpu_seconds=factor * float(row["cpu_seconds"])))
            else:
                writer.writerow(dict(row, steps_per_second=float(row["steps_per_second"]) / factor))
    return rows[0]


def plan(config, *extra):
    return json.loads(maps("suite", "plan", config, "--json", *extra).stdout)


def write_config(folder, config, name="suite.json"):
    path = pathlib.Path(folder) / name
    path.write_text(json.dumps(config))
    return path


def results(out):
    """{cell name: the numbers a rerun must reproduce} for every result.json under out/cells."""
    found = {}
    for path in sorted(pathlib.Path(out, "cells").glob("*/*/result.json")):
        result = json.loads(path.read_text())
        found[result["cell"]["name"]] = {
            "config": result["config"],
            "mean_score": result["eval"]["mean_score"],
            "tasks": [{k: t[k] for k in ("task", "score", "return_mean", "success_rate", "returns")}
                      for t in result["eval"]["tasks"]],
            "best_step": result["train"]["best_step"],
            "best_validation_bc": result["train"]["best_validation_bc"],
        }
    return found


class SuiteTest(unittest.TestCase):
    reference = None  # an uninterrupted run of tiny.json, made once

    @classmethod
    def setUpClass(cls):
        cls.reference = pathlib.Path(WORK) / "reference"
        if not (cls.reference / "suite.json").exists():
            maps("suite", "run", TINY, "--out", cls.reference, "--jobs", "2")

    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory(dir=WORK)
        self.dir = pathlib.Path(self.tmp.name)

    def tearDown(self):
        self.tmp.cleanup()

    # --- the grid ---------------------------------------------------------------------------------------------

    def test_expansion_and_order(self):
        names = [c["name"] for c in plan(TINY)["cells"]]
        # Seeds outermost, then sets, methods, variants and demos as the grid lists them; a later grid's cells after.
        self.assertEqual(names, ["gravity/maps_d2_s0", "gravity/mt_bc_d2_s0", "mt10/maps_d2_s0", "mt10/mt_bc_d2_s0",
                                 "gravity/maps_d2_s1", "gravity/mt_bc_d2_s1", "mt10/maps_d2_s1", "mt10/mt_bc_d2_s1",
                                 "mt10/maps-no_share_d2_s0"])
        self.assertEqual([c["index"] for c in plan(TINY)["cells"]], list(range(9)))

    def test_per_set_settings_and_variants_reach_the_run_config(self):
        config = json.loads(TINY.read_text())
        config["grids"].append({"name": "wide", "sets": ["gravity"], "methods": ["maps"], "variants": ["base", "m3"],
                                "demos": {"gravity": [1, 2]}, "seeds": [0]})
        config["variants"]["m3"] = {"maps": {"modules": 3}}
        path = write_config(self.dir, config)
        cells = {c["name"]: c for c in plan(path)["cells"]}
        # gravity/maps_d2_s0 is named by two grids with one run config: one cell, the first grid's.
        self.assertEqual(len(cells), 9 + 3)
        self.assertEqual(cells["gravity/maps_d2_s0"]["grid"], "comparison")
        manifest = self.dir / "out"
        maps("suite", "run", path, "--out", manifest, "--shard", "0/1000")  # cell 0 only, to see the manifest
        requests = {c["name"]: c["request"] for c in json.loads((manifest / "suite.json").read_text())["cells"]}
        self.assertEqual(requests["gravity/maps-m3_d1_s0"]["maps"]["modules"], 3)
        self.assertEqual(requests["gravity/maps_d1_s0"]["maps"]["modules"], 10)
        self.assertEqual(requests["mt10/maps_d2_s0"]["train"]["states_per_task"], 32)
        self.assertEqual(requests["gravity/maps_d2_s0"]["train"]["states_per_task"], 128)
        self.assertEqual(requests["mt10/maps_d2_s0"]["maps"]["selector_losses"],
                         {"share": 1, "explore": 0.1, "sparse": 0.5, "smooth": 1})
        self.assertEqual(requests["mt10/maps-no_share_d2_s0"]["maps"]["selector_losses"],
                         {"share": 0, "explore": 0.1, "sparse": 0.5, "smooth": 1})
        self.assertEqual(requests["gravity/maps_d2_s0"]["data"], {"file": "data/tiny/gravity.h5", "demos_per_task": 2,
                                                                  "subsample": 10, "tasks": [], "holdout": [],
                                                                  "task_demos": {}, "draws": "sequential",
                                                                  "observation_clip": 0.0})

    def test_shards_partition_the_cells(self):
        config = json.loads(TINY.read_text())
        config["grids"][0]["seeds"] = [0, 1, 2, 3]  # 17 cells: no N below divides it evenly
        path = write_config(self.dir, config)
        everything = [c["index"] for c in plan(path)["cells"]]
        self.assertEqual(len(everything), 17)
        for shards in range(1, 8):
            seen = []
            for shard in range(shards):
                part = [c["index"] for c in plan(path, "--shard", f"{shard}/{shards}")["cells"]]
                self.assertTrue(all(i % shards == shard for i in part))
                seen += part
            self.assertEqual(sorted(seen), everything, f"N = {shards}")

    def test_docs_suite_md_lists_every_suite_config_with_its_cell_count(self):
        """docs/suite.md's table of suite configs has a row for each experiments/suites/*.json (but the cost table) whose
        cell count is the one `maps suite plan` makes."""
        doc = (ROOT / "docs" / "suite.md").read_text()
        for config in sorted((ROOT / "experiments" / "suites").glob("*.json")):
            if config.name == "costs.json":
                continue
            row = re.search(r"^\| `experiments/suites/" + re.escape(config.name) + r"` \| (\d+) \|", doc, re.M)
            self.assertIsNotNone(row, f"docs/suite.md's table has no row for {config.name}")
            self.assertEqual(int(row.group(1)), len(plan(config)["cells"]), config.name)

    def test_issue_46s_suites_plan_the_cells_docs_zoo_md_counts(self):
        """The counts docs/zoo.md gives for issue 46's suites are the ones `maps suite plan` makes: zoo-modern.json's
        cells and, of them, the zoo's own (MAPS, MT-MH-BC and Soft Modularization, copied under the zoo's names);
        zoo-modern-steps.json's cells; zoo-modern-every-state.json's cells, all on every state."""
        suites = ROOT / "experiments" / "suites"
        doc = (ROOT / "docs" / "zoo.md").read_text()
        said = re.search(r"zoo-modern\.json` counts (\d+) cells, (\d+) of them the zoo's own", doc)
        self.assertIsNotNone(said, "docs/zoo.md no longer counts zoo-modern.json's cells in the sentence tested here")
        modern = plan(suites / "zoo-modern.json")["cells"]
        self.assertEqual(len(modern), int(said.group(1)))
        zoo_names = {c["name"] for c in plan(suites / "zoo.json")["cells"]}
        copied = [c for c in modern if c["method"] in ("maps", "mt_mh_bc", "soft_modularization")
                  and c["variant"] in ("base", "keep2500")]
        self.assertEqual(len(copied), int(said.group(2)))
        self.assertLessEqual({c["name"] for c in copied}, zoo_names)
        said = re.search(r"zoo-modern-steps\.json` counts (\d+) cells", doc)
        self.assertIsNotNone(said, "docs/zoo.md no longer counts zoo-modern-steps.json's cells")
        steps = plan(suites / "zoo-modern-steps.json")["cells"]
        self.assertEqual(len(steps), int(said.group(1)))
        pilot_names = {c["name"] for c in plan(suites / "zoo-modern-steps-pilot.json")["cells"]}
        self.assertLessEqual(pilot_names, {c["name"] for c in steps})  # the pilot's cells are the long grid's
        self.assertLessEqual({c["name"] for c in steps if c["method"] == "maps"}, {c["name"] for c in modern})
        said = re.search(r"zoo-modern-every-state\.json` counts (\d+) cells", doc)
        self.assertIsNotNone(said, "docs/zoo.md no longer counts zoo-modern-every-state.json's cells")
        every = plan(suites / "zoo-modern-every-state.json")["cells"]
        self.assertEqual((len(every), {c["subsample"] for c in every}), (int(said.group(1)), {1}))

    def test_config_errors_name_what_is_wrong(self):
        base = json.loads(TINY.read_text())
        cases = [
            (lambda c: c.update(typo=1), "unknown key 'typo'"),
            (lambda c: c["grids"][0].update(methods=["mapz"]), 'got "mapz"'),
            (lambda c: c["grids"][0].update(variants=["nope"]), "'nope' is not defined"),
            (lambda c: c["grids"][0].update(sets=["modified"]), "'modified' is not defined"),
            (lambda c: c["grids"][0].update(seeds=[0, 0]), "listed twice"),
            (lambda c: c["grids"][0].update(seeds=[-1]), "grids[0].seeds[0]: expected an integer in [0, "),
            (lambda c: c["defaults"]["train"].update(stepz=1), "unknown key 'stepz'"),
            (lambda c: c["defaults"].update(maps={"selector": "fixed"}), 'maps.selector: expected "learned", "uniform" or "task", got "fixed"'),
            (lambda c: c["sets"]["gravity"]["data"].pop("file"), "\"file\" is required"),
            (lambda c: c["grids"].append(dict(c["grids"][1])), "names two grids"),
            (lambda c: c["variants"].update(base={}), "is not a variant name"),
            (lambda c: c["grids"][0].update(demos={"gravity": [2], "mt11": [1]}), "'mt11' is not a task set"),
            (lambda c: c.update(report=["set"]), ".report: expected an object"),
            (lambda c: c.update(report={"holm_family": "set"}), "unknown key 'holm_family'"),
            (lambda c: c.update(report={"holm": "method"}), 'report.holm: expected "variant" or "set", got "method"'),
            (lambda c: c.update(report={"compare": "maps - mt_bc"}), ".report.compare: expected"),
            (lambda c: c.update(report={"compare": ["maps-mt_bc"]}), 'report.compare[0]: expected "A - B"'),
            (lambda c: c.update(report={"compare": ["maps - mt_bc - maps"]}), 'report.compare[0]: expected "A - B"'),
            (lambda c: c.update(report={"compare": ["maps - mt_bc", "maps - mapz"]}),
             'report.compare[1]: "mapz" is no row of the suite (a method, or "method (variant)", of one of its cells:'
             ' maps, maps (no_share), mt_bc)'),
            (lambda c: c.update(report={"compare": ["maps (no_share) - maps (no_share)"]}),
             'report.compare[0]: expected two different rows, got "maps (no_share)" twice'),
            (lambda c: c.update(report={"compare": ["mt_bc - maps", "maps - mt_bc"]}),
             'report.compare[1]: "maps - mt_bc" is an earlier entry reversed: the same test twice'),
            (lambda c: (c["grids"][1].update(demos=[7]), c.update(report={"compare": ["maps (no_share) - mt_bc"]})),
             'report.compare[0]: "maps (no_share)" and "mt_bc" share no set, demonstration count and k'),
            (lambda c: c.update(report={"last_step_base": ""}), ".report.last_step_base: expected"),
            (lambda c: c.update(report={"last_step_against": [".."]}),
             '.report.last_step_against: expected [] or [SUITE, VARIANT] (two non-empty strings), got [".."]'),
            (lambda c: c.update(report={"last_step_against": ["..", ""]}), ".report.last_step_against: expected []"),
            (lambda c: c.update(report={"last_step_against": ["a", "b", "c"]}),
             ".report.last_step_against: expected [] or [SUITE, VARIANT]"),
        ]
        for mutate, message in cases:
            config = copy.deepcopy(base)
            mutate(config)
            path = write_config(self.dir, config)
            proc = maps("suite", "plan", path, check=False)
            self.assertNotEqual(proc.returncode, 0, message)
            self.assertIn(message, proc.stderr)
            self.assertIn(str(path), proc.stderr)
        config = copy.deepcopy(base)
        config["report"] = {"compare": ["maps (no_share) - maps", "mt_bc - maps"]}
        self.assertEqual(maps("suite", "plan", write_config(self.dir, config), check=False).returncode, 0)
        for bad in ["1/1", "2/2", "x", "-1/3", "1/0"]:
            proc = maps("suite", "plan", TINY, "--shard", bad, check=False)
            self.assertNotEqual(proc.returncode, 0, bad)
            self.assertIn("--shard", proc.stderr)

    def test_the_plan_counts_validation_and_checkpoint_writes_apart_from_the_steps(self):
        costs = json.loads((ROOT / "experiments" / "suites" / "costs.json").read_text())
        for methods in (costs["sets"][s]["methods"] for s in costs["sets"]):
            for m in methods.values():
                m.pop("validation_seconds", None), m.pop("checkpoint_seconds", None)
        before = plan(TINY, "--costs", write_config(self.dir, costs, "old_costs.json"))
        gravity_maps = costs["sets"]["gravity"]["methods"]["maps"]
        gravity_maps.update(validation_seconds=0.5, checkpoint_seconds=0.25)
        after = plan(TINY, "--costs", write_config(self.dir, costs, "costs.json"))
        # A table without the fields (calibrated before they were timed apart) counts neither.
        self.assertEqual(before["cpu_seconds_parts"]["validation"], 0)
        self.assertEqual(before["cpu_seconds_parts"]["checkpoints"], 0)
        parts = after["cpu_seconds_parts"]
        self.assertAlmostEqual(sum(parts.values()), after["cpu_seconds"], places=6)
        self.assertAlmostEqual(parts["steps"], before["cpu_seconds_parts"]["steps"], places=6)
        # tiny.json: two Gravity MAPS cells of 60 steps, validating and checkpointing every 20: 3 validations,
        # 3 last.ckpt and at most 3 best.ckpt writes each.
        self.assertAlmostEqual(parts["checkpoints"], 2 * 6 * 0.25, places=6)
        self.assertGreater(parts["validation"], 0)
        self.assertAlmostEqual(after["cpu_seconds"] - before["cpu_seconds"], parts["validation"] + 3.0, places=6)
        text = maps("suite", "plan", TINY, "--costs", self.dir / "costs.json").stdout
        self.assertRegex(text, r"of which training steps [0-9.]+%, validation [0-9.]+%, checkpoints [0-9.]+% \(at most\)")

    def test_a_method_the_table_has_not_measured_is_estimated_as_maps_and_named(self):
        costs = json.loads((ROOT / "experiments" / "suites" / "costs.json").read_text())
        config = json.loads(TINY.read_text())
        config["grids"] = [{"name": "two", "sets": ["gravity"], "methods": ["maps", "mt_bc"], "seeds": [0]}]
        suite = write_config(self.dir, config, "two_methods.json")
        measured = plan(suite, "--costs", write_config(self.dir, costs, "all_costs.json"))
        self.assertEqual(measured["unmeasured"], [])
        del costs["sets"]["gravity"]["methods"]["mt_bc"]
        table = write_config(self.dir, costs, "no_mt_bc.json")
        estimated = plan(suite, "--costs", table)
        self.assertEqual(estimated["unmeasured"], ["mt_bc on gravity"])
        seconds = {c["method"]: c["estimated_seconds"] for c in estimated["cells"]}
        self.assertAlmostEqual(seconds["mt_bc"], seconds["maps"], places=6)  # the same request but for the method
        text = maps("suite", "plan", suite, "--costs", table).stdout
        self.assertIn("not measured, estimated at MAPS's cost per step and episode", text)
        self.assertIn("mt_bc on gravity", text)

    def test_each_choice_of_a_cost_option_is_priced_at_its_own_entry_and_evaluation_work(self):
        costs = json.loads((ROOT / "experiments" / "suites" / "costs.json").read_text())
        gravity = costs["sets"]["gravity"]["methods"]
        for key in [k for k in gravity if k.startswith("diffusion_policy")]:
            del gravity[key]
        config = json.loads(TINY.read_text())
        config["variants"] = {"mlp1": {"diffusion_policy": {"denoiser": "mlp", "horizon": 1, "execute": 1}},
                              "mlp16": {"diffusion_policy": {"denoiser": "mlp"}},
                              "moe1": {"diffusion_policy": {"denoiser": "moe", "horizon": 1, "execute": 1}}}
        config["grids"] = [{"name": "dp", "sets": ["gravity"], "methods": ["diffusion_policy"],
                            "variants": ["mlp1", "mlp16", "moe1"], "seeds": [0]}]
        suite = write_config(self.dir, config, "dp_suite.json")

        def priced(name):
            result = plan(suite, "--costs", write_config(self.dir, costs, name))
            return result, {c["variant"]: c for c in result["cells"]}

        # No entry of the method: MAPS's costs stand in, named by the entries the cells ask for.
        result, cells = priced("no_dp.json")
        self.assertEqual(result["unmeasured"], ["diffusion_policy/mlp on gravity", "diffusion_policy/moe on gravity"])
        self.assertEqual({c["cost_entry"] for c in cells.values()}, {"maps"})
        # The method's entry without a choice (a table older than the choices) stands in for every choice, and an
        # evaluation step's work scales its episodes: 8 sampling steps an action at H = 1, 8 per 8 actions at H = 16.
        gravity["diffusion_policy"] = dict(gravity["maps"], episode_seconds=0.5, evaluation_work=1.0)
        result, cells = priced("dp.json")
        self.assertEqual(result["unmeasured"], ["diffusion_policy/mlp on gravity (as diffusion_policy)",
                                                "diffusion_policy/moe on gravity (as diffusion_policy)"])
        episodes_times_tasks = config["defaults"]["eval"]["episodes"] * 5
        self.assertAlmostEqual(cells["mlp16"]["estimated_evaluation_seconds"], episodes_times_tasks * 0.5, places=6)
        self.assertAlmostEqual(cells["mlp1"]["estimated_evaluation_seconds"], episodes_times_tasks * 0.5 * 8, places=6)
        # A choice's own entry prices its cells, and the plan names the CPU each entry used was timed on.
        gravity["diffusion_policy/mlp"] = dict(gravity["maps"], episode_seconds=0.25, evaluation_work=2.0,
                                               cpu="A CPU of the test")
        result, cells = priced("dp_mlp.json")
        self.assertEqual(result["unmeasured"], ["diffusion_policy/moe on gravity (as diffusion_policy)"])
        self.assertEqual(cells["mlp1"]["cost_entry"], "diffusion_policy/mlp")
        self.assertAlmostEqual(cells["mlp1"]["estimated_evaluation_seconds"], episodes_times_tasks * 0.25 * 8 / 2,
                               places=6)
        self.assertIn("A CPU of the test", result["measured_on"])
        text = maps("suite", "plan", suite, "--costs", self.dir / "dp_mlp.json").stdout
        self.assertRegex(text, r"measured on (.+ and )?A CPU of the test")
        # A set's entry that is not one is refused naming it.
        proc = maps("suite", "plan", suite, "--costs", write_config(self.dir, dict(costs, sets=dict(costs["sets"],
                    gravity=[])), "bad_set.json"), check=False)
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("sets.gravity is not a set's costs", proc.stderr)
        # The recorded work is a measured value like any other: checked.
        gravity["diffusion_policy/mlp"]["evaluation_work"] = 0
        proc = maps("suite", "plan", suite, "--costs", write_config(self.dir, costs, "bad.json"), check=False)
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("sets.gravity.methods.diffusion_policy/mlp.evaluation_work is 0; expected a finite number > 0",
                      proc.stderr)

    @heavy
    def test_calibrate_times_each_choice_and_gail_where_it_applies_and_keeps_other_entries(self):
        table = self.dir / "costs.json"
        old = json.loads((ROOT / "experiments" / "suites" / "costs.json").read_text())
        old["cpu"] = "The old table's CPU"
        for methods in (old["sets"][s]["methods"] for s in old["sets"]):
            for key in [k for k in methods if k.startswith("diffusion_policy")]:
                del methods[key]
            for entry in methods.values():
                entry.pop("cpu", None)
        write_config(self.dir, old, "costs.json")
        proc = maps("suite", "calibrate", "--out", table, "--work", self.dir / "work", "--suite", TINY, "--sets",
                    "gravity", "--methods", "mt_bc", "diffusion_policy", "--steps", "4", "--episodes", "1",
                    "--gail-env-steps", "100")
        new = json.loads(table.read_text())
        gravity = new["sets"]["gravity"]["methods"]
        denoisers = ["maps", "mlp", "moe", "unet"]
        self.assertEqual(sorted(k for k in gravity if k.startswith("diffusion_policy")),
                         [f"diffusion_policy/{d}" for d in denoisers])
        for key in ["mt_bc"] + [f"diffusion_policy/{d}" for d in denoisers]:
            self.assertEqual(gravity[key]["cpu"], new["cpu"], key)
            self.assertGreater(gravity[key]["step_seconds"], 0, key)
            self.assertGreater(gravity[key]["episode_seconds"], 0, key)
        # Diffusion Policy's chunks do not train by GAIL: said, not a failed calibration; MT-BC's are timed.
        self.assertGreater(gravity["mt_bc"]["gail_env_step_seconds"], 0)
        # The policy's part of an env step (rollout calls and PPO): some of it, not all (physics and discriminator).
        self.assertGreater(gravity["mt_bc"]["gail_policy_env_step_seconds"], 0)
        self.assertLess(gravity["mt_bc"]["gail_policy_env_step_seconds"], gravity["mt_bc"]["gail_env_step_seconds"])
        for d in denoisers:
            self.assertEqual(gravity[f"diffusion_policy/{d}"]["evaluation_work"], 1.0)  # 8 sampling steps per 8
            self.assertNotIn("gail_env_step_seconds", gravity[f"diffusion_policy/{d}"])
            self.assertIn(f"gravity/diffusion_policy-{d}_d2_s0: no GAIL cost (it does not train by GAIL", proc.stdout)
        # Entries not re-measured stay, named by the CPU they were timed on.
        self.assertEqual(gravity["maps"], dict(old["sets"]["gravity"]["methods"]["maps"], cpu="The old table's CPU",
                                               measured=old["measured"]))
        self.assertEqual(new["sets"]["mt10"]["methods"].keys(), old["sets"]["mt10"]["methods"].keys())
        self.assertIn("--methods mt_bc diffusion_policy", new["command"])
        self.assertEqual(new["sets"]["gravity"]["collect_seconds"], old["sets"]["gravity"]["collect_seconds"])
        # A damaged table to merge into is refused before anything is timed.
        (self.dir / "damaged.json").write_text("[]")
        proc = maps("suite", "calibrate", "--out", self.dir / "damaged.json", "--work", self.dir / "work2", "--suite",
                    TINY, check=False)
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("damaged.json: not a cost table", proc.stderr)
        self.assertFalse((self.dir / "work2").exists())
        proc = maps("suite", "calibrate", "--out", table, "--methods", "no_such_method", check=False)
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("no_such_method", proc.stderr)

    def test_gail_cells_are_priced_by_their_env_steps_or_refused_without_a_gail_cost(self):
        costs = json.loads((ROOT / "experiments" / "suites" / "costs.json").read_text())
        for methods in (costs["sets"][s]["methods"] for s in costs["sets"]):
            for m in methods.values():
                for key in ("gail_env_step_seconds", "gail_discriminator_update_seconds", "gail_policy_env_step_seconds"):
                    m.pop(key, None)
        config = json.loads(TINY.read_text())
        config["variants"]["gail"] = {"imitation": "gail", "gail": {"env_steps_per_task": 1000}}
        config["grids"] = [{"name": "gail", "sets": ["gravity"], "methods": ["mt_bc"], "variants": ["gail"],
                            "seeds": [0]}]
        suite = write_config(self.dir, config, "gail_suite.json")
        without = write_config(self.dir, costs, "no_gail_costs.json")
        proc = maps("suite", "plan", suite, "--costs", without, check=False)
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("has no GAIL cost for mt_bc on gravity", proc.stderr)
        self.assertIn("maps suite calibrate --gail-env-steps", proc.stderr)
        gravity = costs["sets"]["gravity"]["methods"]["mt_bc"]
        gravity.update(gail_env_step_seconds=1e-4, gail_discriminator_update_seconds=0.01)
        priced = plan(suite, "--costs", write_config(self.dir, costs, "gail_costs.json"))
        # 1000 env steps on each of Gravity's 5 tasks at 1e-4 s, and the warm-up's 10 iterations of 100 - 5 extra
        # discriminator steps at 0.01 s.
        self.assertAlmostEqual(priced["cpu_seconds_parts"]["steps"], 1000 * 5 * 1e-4 + 10 * 95 * 0.01, places=6)
        # A wider policy: only the policy's part of an env step grows, with the square of the width (3 x 256: 4x);
        # a table without that part prices it as the measured width.
        config["variants"]["gail"]["baselines"] = {"hidden": [256, 256, 256]}
        wide = write_config(self.dir, config, "gail_wide_suite.json")
        unscaled = plan(wide, "--costs", self.dir / "gail_costs.json")
        self.assertAlmostEqual(unscaled["cpu_seconds_parts"]["steps"], 1000 * 5 * 1e-4 + 10 * 95 * 0.01, places=6)
        self.assertEqual(unscaled["gail_size_unpriced"], ["mt_bc on gravity"])  # said, not silent
        self.assertEqual(priced["gail_size_unpriced"], [])
        gravity.update(gail_policy_env_step_seconds=0.4e-4)
        priced = plan(wide, "--costs", write_config(self.dir, costs, "gail_policy_costs.json"))
        self.assertEqual(priced["gail_size_unpriced"], [])
        self.assertAlmostEqual(priced["cpu_seconds_parts"]["steps"],
                               1000 * 5 * (1e-4 + 3 * 0.4e-4) + 10 * 95 * 0.01, places=6)
        # MAPS with 5 modules where the table measured 10: its policy's part halves (a ratio below 1 lowers it).
        costs["sets"]["gravity"]["methods"]["maps"].update(gail_env_step_seconds=3e-4,
                                                           gail_policy_env_step_seconds=2e-4,
                                                           gail_discriminator_update_seconds=0.01, modules=10)
        config["variants"]["gail"] = {"imitation": "gail", "gail": {"env_steps_per_task": 1000}, "maps": {"modules": 5}}
        config["grids"] = [{"name": "gail", "sets": ["gravity"], "methods": ["maps"], "variants": ["gail"],
                            "seeds": [0]}]
        maps_suite = write_config(self.dir, config, "gail_maps_suite.json")
        priced = plan(maps_suite, "--costs", write_config(self.dir, costs, "gail_maps_costs.json"))
        self.assertAlmostEqual(priced["cpu_seconds_parts"]["steps"],
                               1000 * 5 * (3e-4 - 0.5 * 2e-4) + 10 * 95 * 0.01, places=6)

    def test_the_precision_option_sets_every_cells_precision_and_its_step_cost(self):
        costs = json.loads((ROOT / "experiments" / "suites" / "costs.json").read_text())
        for methods in (costs["sets"][s]["methods"] for s in costs["sets"]):
            for m in methods.values():
                m.pop("step_seconds_bf16", None)
        without = write_config(self.dir, costs, "float32_costs.json")
        proc = maps("suite", "plan", TINY, "--precision", "bf16", "--costs", without, check=False)
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn(f"{without} has no bf16 step cost for maps on gravity", proc.stderr)
        self.assertIn("re-measure on a CPU with AVX512-BF16", proc.stderr)
        for methods in (costs["sets"][s]["methods"] for s in costs["sets"]):
            for m in methods.values():
                m["step_seconds_bf16"] = m["step_seconds"] / 2
        both = write_config(self.dir, costs, "costs.json")
        float32 = plan(TINY, "--costs", both)
        bf16 = plan(TINY, "--precision", "bf16", "--costs", both)
        self.assertAlmostEqual(bf16["cpu_seconds_parts"]["steps"], float32["cpu_seconds_parts"]["steps"] / 2, places=6)
        self.assertEqual(bf16["cpu_seconds_parts"]["evaluation"], float32["cpu_seconds_parts"]["evaluation"])
        self.assertEqual(plan(TINY, "--precision", "float32", "--costs", both)["cpu_seconds"], float32["cpu_seconds"])
        proc = maps("suite", "plan", TINY, "--precision", "fp16", check=False)
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("--precision", proc.stderr)
        # A run: every cell's request says bf16 where the CPU has it; elsewhere the run is refused before any cell.
        has_bf16 = "avx512_bf16" in pathlib.Path("/proc/cpuinfo").read_text().split()
        out = self.dir / "bf16"
        proc = maps("suite", "run", TINY, "--out", out, "--precision", "bf16", "--shard", "0/1000", check=False)
        if has_bf16:
            self.assertEqual(proc.returncode, 0, proc.stderr)
            cells = json.loads((out / "suite.json").read_text())["cells"]
            self.assertEqual({c["request"]["train"]["precision"] for c in cells}, {"bf16"})
            result = json.loads((out / "cells" / cells[0]["name"] / "result.json").read_text())
            self.assertEqual(result["config"]["train"]["precision"], "bf16")
            # The folder is now the bf16 suite's: the float32 one is another config.
            proc = maps("suite", "run", TINY, "--out", out, "--shard", "0/1000", check=False)
            self.assertNotEqual(proc.returncode, 0)
        else:
            self.assertNotEqual(proc.returncode, 0)
            self.assertIn('train.precision "bf16" needs a CPU with AVX512-BF16', proc.stderr)
            self.assertFalse((out / "cells").exists())

    def test_a_damaged_cost_table_is_refused_naming_the_value(self):
        good = json.loads((ROOT / "experiments" / "suites" / "costs.json").read_text())
        where = "sets.gravity.methods.maps."
        cases = [("step_seconds", -0.01, "expected a finite number > 0"),
                 ("step_seconds", 0, "expected a finite number > 0"),
                 ("episode_seconds", "fast", "expected a finite number > 0"),
                 ("overhead_seconds", -1, "expected a finite number >= 0"),
                 ("modules", 0, "expected a finite number > 0"),
                 ("states_per_task", None, "expected a finite number > 0"),
                 ("validation_seconds", -2, "expected a finite number >= 0"),
                 ("checkpoint_seconds", [1], "expected a finite number >= 0"),
                 ("step_seconds", "drop", "is missing")]
        for key, value, message in cases:
            costs = copy.deepcopy(good)
            entry = costs["sets"]["gravity"]["methods"]["maps"]
            if value == "drop":
                entry.pop(key)
            else:
                entry[key] = value
            path = write_config(self.dir, costs, "costs.json")
            proc = maps("suite", "plan", TINY, "--costs", path, check=False)
            self.assertNotEqual(proc.returncode, 0, (key, value))
            self.assertIn(f"{path}: {where}{key}", proc.stderr)
            self.assertIn(message, proc.stderr)

    # --- running ----------------------------------------------------------------------------------------------

    def test_status_counts_each_grid(self):
        fixture = ROOT / "tests" / "experiments" / "fixtures" / "suite-small"
        status = maps("suite", "status", fixture).stdout
        # In the suite's order; the failed cell and the unfinished one are the comparison grid's.
        grids = [line.split("|")[1].strip() for line in status.splitlines() if line.startswith("| ") and
                 not line.startswith("| grid")]
        self.assertEqual(grids, ["comparison", "controls", "ablation", "modules", "paper_protocol"])
        self.assertIn("| comparison | 24 | 22 | 0 | 1 | 0 | 1 | 0 |", status)
        self.assertIn("| ablation | 4 | 4 | 0 | 0 | 0 | 0 | 0 |", status)

    def test_cells_the_config_no_longer_makes_are_dropped_not_left(self):
        out = self.dir / "dropped"
        shutil.copytree(self.reference, out)
        # The ablations grid leaves the config; its one cell had not finished (its result removed), so it will not
        # run again: dropped, not left, and out of the estimate.
        (out / "cells" / "mt10" / "maps-no_share_d2_s0" / "result.json").unlink()
        config = json.loads(TINY.read_text())
        config["grids"] = [g for g in config["grids"] if g["name"] != "ablations"]
        proc = maps("suite", "run", write_config(self.dir, config, "no_ablations.json"), "--out", out)
        self.assertIn("8 finished before, 0 to run", proc.stdout)
        status = maps("suite", "status", out).stdout
        self.assertIn("9 cells: 8 done, 0 running, 0 failed, 0 started (resumable), 0 left, 1 dropped", status)
        self.assertIn("| ablations | 1 | 0 | 0 | 0 | 0 | 0 | 1 |", status)
        self.assertNotIn("estimated CPU time left", status)
        # The report counts it apart from the missing cells: a grid taken out is not work left.
        maps("report", out, "--no-study")
        md = (out / "report" / "report.md").read_text()
        self.assertIn("Cells: 8 finished, 0 missing (not run or not finished), 0 failed, 0 damaged, 1 dropped (no"
                      " longer in the suite config, never finished), of 9 in suite.json.", md)
        self.assertNotIn("Missing cells", md)

    def test_status_scales_the_estimate_by_the_finished_cells_pace(self):
        out = self.dir / "pace"
        shutil.copytree(self.reference, out)
        results = sorted((out / "cells").glob("*/*/result.json"))
        for path in results[:2]:
            path.unlink()

        def pace(status):
            line = next((l for l in status.splitlines() if l.startswith("at the finished cells' pace: ")), None)
            self.assertIsNotNone(line, status)
            self.assertIn(f"({len(results) - 2} finished cells took ", line)
            return float(line.split(" took ")[1].split("x")[0])

        first = pace(maps("suite", "status", out).stdout)
        self.assertIn("; 0 timed by their last attempt's wall time)", maps("suite", "status", out).stdout)
        # The cost is training's from curve.csv (every attempt) plus evaluation, not the finishing attempt's wall time
        # (a resumed cell's last attempt, a paused one's pauses).
        for path in results[2:]:
            result = json.loads(path.read_text())
            result["wall_seconds"] *= 5
            path.write_text(json.dumps(result))
        self.assertAlmostEqual(pace(maps("suite", "status", out).stdout), first, delta=0.011)
        for path in results[2:]:
            self.assertIn("cpu_seconds", slow_down(path, 2))
        self.assertAlmostEqual(pace(maps("suite", "status", out).stdout), 2 * first, delta=0.011)
        # A cell whose curve cannot say (removed) is timed by its wall time, and the line counts it.
        (results[2].parent / "curve.csv").unlink()
        self.assertIn("; 1 timed by their last attempt's wall time)", maps("suite", "status", out).stdout)
        for path in results[2:-2]:
            path.unlink()
        self.assertNotIn("finished cells' pace", maps("suite", "status", out).stdout)  # 2 cells say too little

    def test_status_estimate_leaves_out_the_trained_part_and_paces_each_kind_of_cell(self):
        out = self.dir / "kinds"
        shutil.copytree(ROOT / "tests" / "experiments" / "fixtures" / "suite-small", out)

        def status():
            text = maps("suite", "status", out).stdout
            numbers = json.loads(maps("suite", "status", out, "--json").stdout)
            return text, numbers["cpu_seconds_left"], numbers["cpu_seconds_left_at_pace"]

        def kinds(text):
            found = re.search(r"at their own pace: gravity mt_bc (\d+\.\d\d)x \(1 left\), "
                              r"mt10 mt_bc (\d+\.\d\d)x \(1 left\)\)$", text, re.M)
            self.assertIsNotNone(found, text)
            return float(found.group(1)), float(found.group(2))

        # mt10/mt_bc_d10_s1 is left with a curve to step 500 of 1000 (an attempt without a checkpoint: it starts
        # over, and counts whole).
        cell = out / "cells" / "mt10" / "mt_bc_d10_s1"
        text, left, paced = status()
        gravity_pace, mt10_pace = kinds(text)
        curve = (cell / "curve.csv").read_text()
        # Running (its lock held) at step 500, then at 1000: half of its training part, then all of it, is done.
        with open(cell / ".lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
            text, half, _ = status()
            self.assertIn("running  mt10/mt_bc_d10_s1: step 500 of 1000", text)
            (cell / "curve.csv").write_text(curve + "1000" + curve.splitlines()[-1][len("500"):] + "\n")
            text, full, _ = status()
            self.assertIn("running  mt10/mt_bc_d10_s1: step 1000 of 1000", text)
            # A line being written (no newline yet) is not read.
            with (cell / "curve.csv").open("a") as f:
                f.write("1250,0.0")
            self.assertIn("running  mt10/mt_bc_d10_s1: step 1000 of 1000", status()[0])
        (cell / "curve.csv").write_text(curve)
        training = left - full
        self.assertGreater(training, 0)
        self.assertAlmostEqual(left - half, training / 2, delta=1e-6 * left)
        # Finished, it leaves the estimate: its whole cost is more than its training, as its evaluation (which a
        # cell at its last step has still to run) and overhead remain.
        request = next(c for c in json.loads((out / "suite.json").read_text())["cells"]
                       if c["name"] == "mt10/mt_bc_d10_s1")
        result = json.loads((out / "cells" / "mt10" / "mt_bc_d10_s0" / "result.json").read_text())
        result["cell"] = {k: v for k, v in request.items() if k != "request"}
        result["config"] = request["request"]
        (cell / "result.json").write_text(json.dumps(result))
        text, done, _ = status()
        self.assertNotIn("mt10/mt_bc_d10_s1", text)
        self.assertLess(done, full)
        whole = left - done
        (cell / "result.json").unlink()
        # Each cell left is scaled by the finished cells of its set and method: three times slower mt10 MT-BC cells
        # (training from the curve and evaluation) triple that kind's pace and leave gravity's as it was; the time at
        # the finished cells' pace grows by the mt10 cell's estimate times the change in its pace.
        for result_path in (out / "cells" / "mt10").glob("mt_bc*/result.json"):
            slow_down(result_path, 3)
        text, again, slower = status()
        self.assertEqual(again, left)
        self.assertEqual(kinds(text)[0], gravity_pace)
        self.assertAlmostEqual(kinds(text)[1], 3 * mt10_pace, delta=0.02)
        self.assertAlmostEqual(slower - paced, 2 * mt10_pace * whole, delta=0.01 * slower)

    def test_a_rerun_of_a_finished_suite_does_nothing(self):
        proc = maps("suite", "run", TINY, "--out", self.reference)
        self.assertIn("9 finished before, 0 to run", proc.stdout)
        status = json.loads(maps("suite", "status", self.reference, "--json").stdout)
        self.assertEqual(status["counts"], {"done": 9})

    def test_kill_9_then_rerun_equals_an_uninterrupted_run(self):
        out = self.dir / "killed"
        for delay in (1.0, 2.5):  # killed twice, at different points
            proc = subprocess.Popen([MAPS, "suite", "run", TINY, "--out", out, "--jobs", "2"], cwd=WORK,
                                    stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            time.sleep(delay)
            proc.send_signal(signal.SIGKILL)
            proc.wait()
        time.sleep(0.2)  # the children die with their parent (PR_SET_PDEATHSIG)
        leftovers = subprocess.run(["pgrep", "-f", f"--out {out}/cells"], capture_output=True, text=True).stdout
        self.assertEqual(leftovers.strip(), "", "cell processes outlived the killed suite")
        status = json.loads(maps("suite", "status", out, "--json").stdout)
        self.assertLess(status["counts"].get("done", 0), 9, "the kill came after the suite had finished")
        maps("suite", "run", TINY, "--out", out, "--jobs", "2")
        self.assertEqual(results(out), results(self.reference))
        for path in out.glob("cells/*/*"):
            self.assertFalse(list(path.glob("*.tmp")), f"temporary files left in {path}")
        # result.json names the machine, and every training process of the cell (kept without provenance.json):
        # one each uninterrupted, more where a kill made a cell resume.
        attempts = {"reference": [], "killed": []}
        for folder, counts in ((self.reference, attempts["reference"]), (out, attempts["killed"])):
            for path in sorted(folder.glob("cells/*/*/result.json")):
                result = json.loads(path.read_text())
                self.assertTrue(result["cpu"])
                self.assertIn(result["float32_gemm_kernel"], ("maps AVX-512", "maps AVX2", "Eigen"))
                for attempt in result["training_attempts"]:
                    self.assertEqual(attempt["cpu"], result["cpu"])
                    self.assertRegex(attempt["started_utc"], r"^\d{4}-\d\d-\d\dT")
                    self.assertLess(attempt["start_step"], attempt["steps"], "an attempt that trained nothing")
                starts = [attempt["start_step"] for attempt in result["training_attempts"]]
                self.assertEqual(starts, sorted(starts), path)
                self.assertEqual(starts[0], 0, path)
                counts.append(len(result["training_attempts"]))
        self.assertEqual(attempts["reference"], [1] * 9)
        self.assertTrue(all(n >= 1 for n in attempts["killed"]), attempts)
        self.assertGreater(sum(attempts["killed"]), 9, "no cell recorded its resumed training")

    def test_damaged_cells_are_redone_not_trusted(self):
        out = self.dir / "damaged"
        subprocess.run(["cp", "-r", str(self.reference), str(out)], check=True)
        cells = out / "cells"
        (cells / "gravity/maps_d2_s0/result.json").write_text('{"format": "maps-suite-cell/1", "cell": {"na')
        wrong = json.loads((cells / "mt10/mt_bc_d2_s0/result.json").read_text())
        wrong["config"]["train"]["steps"] = 5  # a result of another run config
        (cells / "mt10/mt_bc_d2_s0/result.json").write_text(json.dumps(wrong))
        (cells / "mt10/maps_d2_s1/result.json").unlink()  # a half-done cell whose checkpoint is damaged
        (cells / "mt10/maps_d2_s1/eval.json").unlink()
        (cells / "mt10/maps_d2_s1/last.ckpt").write_bytes(b"MAPSCKPT garbage")
        (cells / "mt10/maps_d2_s1/best.ckpt").write_bytes(b"")
        # A valid result.json is the cell's whole record (its run config included): damage beside it is not redone.
        (cells / "gravity/mt_bc_d2_s1/config.json").write_text("{")
        self.assertRegex(maps("suite", "status", out).stdout,
                         r"started  mt10/maps_d2_s1: its last checkpoint cannot be read, so it cannot resume: .+")
        proc = maps("suite", "run", TINY, "--out", out)
        self.assertIn("6 finished before, 3 to run", proc.stdout)
        self.assertIn("gravity/maps_d2_s0", proc.stdout)
        self.assertIn("mt10/mt_bc_d2_s0: " + str(cells / "mt10/mt_bc_d2_s0/result.json") +
                      ": was trained with another run config (train.steps: 5 in its config, 60 in the suite's);"
                      " redoing the cell", proc.stdout)
        self.assertIn("mt10/maps_d2_s1: resuming failed", proc.stdout)
        self.assertIn("redoing the cell from nothing", proc.stdout)
        self.assertEqual(results(out), results(self.reference))

    @heavy
    def test_a_failed_cell_is_reported_and_the_rest_finish(self):
        config = json.loads(TINY.read_text())
        config["grids"] = [{"name": "bad", "sets": ["mt10"], "methods": ["mt_bc"], "demos": [2, 400], "seeds": [0]}]
        path = write_config(self.dir, config)
        out = self.dir / "failing"
        proc = maps("suite", "run", path, "--out", out, check=False)
        self.assertEqual(proc.returncode, 1)
        self.assertIn("mt10/mt_bc_d400_s0: FAILED: training failed", proc.stdout)
        status = maps("suite", "status", out)
        self.assertIn("failed  mt10/mt_bc_d400_s0: train:", status.stdout)
        self.assertIn("1 done, 0 running, 1 failed", status.stdout)
        error = json.loads((out / "cells/mt10/mt_bc_d400_s0/error.json").read_text())
        self.assertEqual(error["stage"], "train")
        self.assertIn("400", error["error"])

    @heavy
    def test_a_failure_that_is_not_damage_keeps_the_checkpoints(self):
        out = self.dir / "eval-fails"
        subprocess.run(["cp", "-r", str(self.reference), str(out)], check=True)
        cell = out / "cells/mt10/maps_d2_s0"
        for name in ("result.json", "eval.json"):
            (cell / name).unlink()
        (cell / "eval.json").mkdir()  # maps eval cannot write its result: it fails, naming no checkpoint
        proc = maps("suite", "run", TINY, "--out", out, check=False)
        self.assertEqual(proc.returncode, 1)
        self.assertIn("mt10/maps_d2_s0: FAILED: evaluation failed", proc.stdout)
        self.assertNotIn("redoing the cell from nothing", proc.stdout)
        self.assertTrue((cell / "last.ckpt").exists() and (cell / "best.ckpt").exists())
        self.assertEqual(json.loads((cell / "error.json").read_text())["stage"], "eval")
        (cell / "eval.json").rmdir()
        # Without its error record the cell is a resumable one, at last.ckpt's step (its training finished).
        (cell / "error.json").unlink()
        steps = json.loads((cell / "config.json").read_text())["train"]["steps"]
        self.assertIn(f"started  mt10/maps_d2_s0: resumable at its last checkpoint, step {steps} of {steps}",
                      maps("suite", "status", out).stdout)
        proc = maps("suite", "run", TINY, "--out", out)
        self.assertIn("8 finished before, 1 to run", proc.stdout)
        self.assertIn("resumed from", (cell / "train.log").read_text())
        self.assertFalse((cell / "error.json").exists())
        self.assertEqual(results(out), results(self.reference))

    @heavy
    def test_a_cell_locked_by_another_process_is_skipped(self):
        out = self.dir / "locked"
        maps("suite", "run", TINY, "--out", out, "--shard", "99999/100000")
        lock_dir = out / "cells/gravity/maps_d2_s0"
        lock_dir.mkdir(parents=True)
        holder = open(lock_dir / ".lock", "w")
        fcntl.flock(holder, fcntl.LOCK_EX)  # what a suite running the cell holds
        try:
            status = json.loads(maps("suite", "status", out, "--json").stdout)
            self.assertEqual(status["counts"], {"running": 1, "left": 8})
            proc = maps("suite", "run", TINY, "--out", out, "--shard", "0/9", check=False)
            self.assertEqual(proc.returncode, 3)
            self.assertIn("gravity/maps_d2_s0: running in another process", proc.stdout)
        finally:
            holder.close()
        proc = maps("suite", "run", TINY, "--out", out, "--shard", "0/9")
        self.assertIn("1 to run", proc.stdout)

    def test_a_suite_folder_of_another_config_is_refused(self):
        out = self.dir / "other"
        maps("suite", "run", TINY, "--out", out, "--shard", "0/1000")
        config = json.loads(TINY.read_text())
        config["defaults"]["train"]["steps"] = 61
        path = write_config(self.dir, config)
        proc = maps("suite", "run", path, "--out", out, check=False)
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("has another run config", proc.stderr)
        self.assertIn("(train.steps: 60 in the folder's, 61 in the config's)", proc.stderr)
        # More seeds: the suite grows, the finished cell stays.
        config = json.loads(TINY.read_text())
        config["grids"][0]["seeds"] = [0, 1, 2]
        path = write_config(self.dir, config)
        proc = maps("suite", "run", path, "--out", out, "--shard", "0/1000")
        self.assertIn("1 finished before", proc.stdout)

    @heavy
    def test_merged_shards_equal_a_single_run(self):
        shards = []
        for shard in range(3):
            folder = self.dir / f"shard-{shard}"
            maps("suite", "run", TINY, "--out", folder, "--shard", f"{shard}/3", "--jobs", "2")
            shards.append(folder)
            names = set(results(folder))
            self.assertEqual(names, {c["name"] for c in plan(TINY, "--shard", f"{shard}/3")["cells"]})
        # The shard folders read as one: every cell done, though each folder holds a third of them.
        self.assertEqual(json.loads(maps("suite", "status", *shards, "--json").stdout)["counts"], {"done": 9})
        self.assertEqual(json.loads(maps("suite", "status", shards[0], "--json").stdout)["counts"],
                         {"done": 3, "left": 6})
        merged = self.dir / "merged"
        proc = maps("suite", "merge", "--out", merged, *shards)
        self.assertIn("9 of 9 cells finished", proc.stdout)
        self.assertEqual(results(merged), results(self.reference))
        self.assertFalse(list(merged.glob("cells/*/*/last.ckpt")), "a finished cell's resume checkpoint was copied")
        self.assertTrue(list(merged.glob("cells/*/*/best.ckpt")))
        self.assertFalse(list(merged.glob(".merging*")), "the staging folder was left")
        # Merging again is a no-op; a shard whose numbers differ is refused.
        maps("suite", "merge", "--out", merged, *shards)
        bad = self.dir / "shard-0" / "cells/gravity/maps_d2_s0/result.json"
        result = json.loads(bad.read_text())
        result["eval"]["mean_score"] += 0.5
        bad.write_text(json.dumps(result))
        proc = maps("suite", "merge", "--out", merged, *shards, check=False)
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("gravity/maps_d2_s0 has different results", proc.stderr)
        proc = maps("suite", "merge", "--out", self.dir / "m2", self.reference, self.dir / "failing", check=False)
        self.assertNotEqual(proc.returncode, 0)

    @heavy
    def test_import_of_an_old_grid(self):
        """experiments/report/import_grid.py: run_grid.sh's folders become cells equal to the suite's own runs."""
        config = json.loads(TINY.read_text())
        config["sets"].pop("mt10")
        config["grids"] = [config["grids"][0]]
        config["grids"][0]["sets"] = ["gravity"]
        path = write_config(self.dir, config)
        old = self.dir / "old-grid"
        for cell in (self.reference / "cells/gravity").iterdir():
            method, rest = cell.name.split("_d")  # e.g. maps, 2_s0
            demos, seed = rest.split("_s")
            folder = old / f"{method}_d{demos}_k10_s{seed}"
            folder.mkdir(parents=True)
            for name in ("train.json", "eval.json", "curve.csv"):
                (folder / name).write_bytes((cell / name).read_bytes())
            run_config = json.loads((cell / "config.json").read_text())
            del run_config["baselines"]  # what configs written before that key existed look like
            (folder / "config.json").write_text(json.dumps(run_config))
        out = self.dir / "imported"
        maps("suite", "run", path, "--out", out, "--shard", "99999/100000")  # suite.json only
        script = ROOT / "experiments/report/import_grid.py"
        proc = subprocess.run([sys.executable, script, old, out], capture_output=True, text=True)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        self.assertEqual(results(out), {k: v for k, v in results(self.reference).items() if k.startswith("gravity/")})
        self.assertIn("0 to run", maps("suite", "run", path, "--out", out).stdout)  # trusted as finished
        # A run whose config is not its cell's is refused, naming the folder.
        bad = old / "maps_d2_k10_s0/config.json"
        bad.write_text(bad.read_text().replace('"steps": 60', '"steps": 61'))
        proc = subprocess.run([sys.executable, script, old, out], capture_output=True, text=True)
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("maps_d2_k10_s0: its config.json is not the run config of cell gravity/maps_d2_s0", proc.stderr)

    def test_render_of_a_cell_with_one_module(self):
        """maps render --run (Fig. 6 right): a strip of frames of a trained MAPS cell forced onto one module."""
        cell = self.reference / "cells/mt10/maps_d2_s0"
        out = self.dir / "strip.png"
        proc = maps("render", "--run", cell, "--task", "mt10/drawer-close", "--module", "1", "--frames", "3",
                    "--width", "64", "--height", "48", "--out", out, check=False)
        if "this build has no renderer" in proc.stderr:
            self.skipTest("built without the renderer")
        self.assertEqual(proc.returncode, 0, proc.stderr)
        self.assertIn("every score on module 1", proc.stdout)
        header = out.read_bytes()[:24]
        self.assertEqual(header[:8], b"\x89PNG\r\n\x1a\n")
        self.assertEqual((int.from_bytes(header[16:20], "big"), int.from_bytes(header[20:24], "big")), (3 * 64, 48))
        for args, message in [(["--module", "10"], "has modules 0 to 9"),
                              (["--task", "gravity/1.0"], "is not a task of"),
                              (["--frames", "13"], "expected 1 to 12 frames")]:
            base = {"--task": "mt10/reach", "--module": "0", "--frames": "2"}
            base.update(dict(zip(args[::2], args[1::2])))
            flat = [x for pair in base.items() for x in pair]
            proc = maps("render", "--run", cell, *flat, "--out", out, check=False)
            self.assertNotEqual(proc.returncode, 0, args)
            self.assertIn(message, proc.stderr)
        proc = maps("render", "--run", self.reference / "cells/mt10/mt_bc_d2_s0", "--task", "mt10/reach", "--module",
                    "0", "--out", out, check=False)
        self.assertIn("only MAPS has modules", proc.stderr)

    @heavy
    def test_kept_checkpoints_are_all_evaluated(self):
        """train.keep_every keeps step_<N>.ckpt; the suite's eval then scores each (the paper's checkpoint rule)."""
        config = json.loads(TINY.read_text())
        config["defaults"]["train"]["keep_every"] = 20
        config["grids"] = [{"name": "kept", "sets": ["mt10"], "methods": ["maps", "maml"], "seeds": [0]}]
        path = write_config(self.dir, config)
        out = self.dir / "kept"
        maps("suite", "run", path, "--out", out, "--jobs", "2")
        for method in ("maps", "maml"):
            cell = out / f"cells/mt10/{method}_d2_s0"
            self.assertEqual(sorted(p.name for p in cell.glob("step_*.ckpt")),
                             ["step_20.ckpt", "step_40.ckpt", "step_60.ckpt"])
            evaluation = json.loads((cell / "result.json").read_text())["eval"]
            self.assertEqual([c["step"] for c in evaluation["checkpoints"]], [20, 40, 60])
            best = evaluation["best_over_checkpoints"]
            self.assertGreaterEqual(best["mean_score"], evaluation["mean_score"])
            self.assertEqual(best["mean_score"],
                             max([evaluation["mean_score"]] + [c["mean_score"] for c in evaluation["checkpoints"]]))
            # The kept checkpoint at the best-validation step scores what best.ckpt scored.
            same = [c for c in evaluation["checkpoints"] if c["step"] == evaluation["best_step"]]
            if same:
                self.assertEqual(same[0]["mean_score"], evaluation["mean_score"])
        proc = maps("eval", "--run", self.reference / "cells/mt10/maps_d2_s0", "--checkpoints", check=False)
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("kept no step_<N>.ckpt", proc.stderr)

    @heavy
    def test_last_step_is_evaluated(self):
        """maps eval --last scores the policy after the last training step from last.ckpt (the trainer's state), with
        train.ema_power its average of the weights: the same policy as the kept checkpoint of that step (tensor by
        tensor: final_policy_test.cpp), so the same score; a run without last.ckpt, whose last.ckpt is no training
        state or disagrees with the config on the average, is named before any evaluation."""
        config = json.loads(TINY.read_text())
        config["defaults"]["train"]["keep_every"] = 60
        # One episode per task and a small denoiser sampled in 2 steps: three evaluations of a chunk per env step were
        # half this file's time with tiny.json's 2 episodes and the width matched to MAPS's parameter count.
        config["defaults"]["eval"]["episodes"] = 1
        config["variants"] = {"ema": {"train": {"ema_power": 0.75},
                                      "diffusion_policy": {"denoiser": "mlp", "horizon": 1, "execute": 1, "width": 32,
                                                           "inference_steps": 2}}}
        config["grids"] = [{"name": "last", "sets": ["gravity"], "methods": ["mt_bc", "maps"], "seeds": [0]},
                           {"name": "ema", "sets": ["gravity"], "methods": ["diffusion_policy"], "variants": ["ema"],
                            "seeds": [0]}]
        path = write_config(self.dir, config)
        out = self.dir / "last"
        maps("suite", "run", path, "--out", out, "--jobs", "2")
        for name in ("mt_bc_d2_s0", "diffusion_policy-ema_d2_s0"):
            cell = out / "cells/gravity" / name
            maps("eval", "--run", cell, "--checkpoints", "--last")
            evaluation = json.loads((cell / "eval.json").read_text())
            kept = evaluation["checkpoints"]
            self.assertEqual([c["step"] for c in kept], [60])
            self.assertEqual(evaluation["last"]["step"], 60)
            self.assertEqual(evaluation["last"]["mean_score"], kept[0]["mean_score"], name)
            self.assertEqual(evaluation["last"]["scores"], kept[0]["scores"], name)
            self.assertNotIn("routing", evaluation["last"])  # neither routes
        # A policy that routes: its last step's routing per task, beside best.ckpt's in tasks[].
        cell = out / "cells/gravity/maps_d2_s0"
        maps("eval", "--run", cell, "--last")
        evaluation = json.loads((cell / "eval.json").read_text())
        routing = evaluation["last"]["routing"]
        self.assertEqual([r["task"] for r in routing], [t["task"] for t in evaluation["tasks"]])
        modules = len(evaluation["tasks"][0]["module_usage"])
        for r in routing:
            self.assertEqual(len(r["module_usage"]), modules)
            self.assertAlmostEqual(sum(r["module_usage"]), 1.0, places=5)
            self.assertTrue(0.0 <= r["selector_entropy"] <= math.log(modules) + 1e-9, r)
            self.assertTrue(1.0 / modules - 1e-9 <= r["selector_top_score"] <= 1.0, r)
        # last.ckpt and the run config must agree on the average (else which weights are "the last" is unclear).
        cell = out / "cells/gravity/diffusion_policy-ema_d2_s0"
        bare = self.dir / "bare"
        shutil.copytree(cell, bare)
        config_file = bare / "config.json"
        run_config = json.loads(config_file.read_text())
        run_config["train"]["ema_power"] = 0
        config_file.write_text(json.dumps(run_config))
        proc = maps("eval", "--run", bare, "--last", check=False)
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("holds an average of the weights", proc.stderr)
        self.assertNotIn("maps eval:", proc.stdout)  # refused before best.ckpt's evaluation
        # Checked before any evaluation: no last.ckpt, or a policy checkpoint in its place.
        broken = self.dir / "broken"
        shutil.copytree(out / "cells/gravity/mt_bc_d2_s0", broken)
        (broken / "last.ckpt").unlink()
        proc = maps("eval", "--run", broken, "--last", check=False)
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("has no last.ckpt", proc.stderr)
        self.assertNotIn("maps eval:", proc.stdout)
        shutil.copy(broken / "best.ckpt", broken / "last.ckpt")
        proc = maps("eval", "--run", broken, "--last", check=False)
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("last.ckpt is not a training state", proc.stderr)
        self.assertNotIn("maps eval:", proc.stdout)

    @heavy
    def test_maps_on_raw_clipped_observations(self):
        """maps.observations "raw_clipped" (the paper's code's inputs): its statistics travel in the checkpoints, so
        an evaluation of best.ckpt by a fresh process scores what the suite's did."""
        config = json.loads(TINY.read_text())
        config["variants"]["raw"] = {"maps": {"observations": "raw_clipped"}}
        config["grids"] = [{"name": "raw", "sets": ["gravity"], "methods": ["maps"], "variants": ["raw"], "seeds": [0]}]
        path = write_config(self.dir, config)
        out = self.dir / "raw"
        maps("suite", "run", path, "--out", out)
        cell = out / "cells/gravity/maps-raw_d2_s0"
        first = json.loads((cell / "result.json").read_text())
        self.assertEqual(first["config"]["maps"]["observations"], "raw_clipped")
        maps("eval", "--run", cell)
        again = json.loads((cell / "eval.json").read_text())
        self.assertEqual(again["mean_score"], first["eval"]["mean_score"])
        self.assertEqual([t["returns"] for t in again["tasks"]], [t["returns"] for t in first["eval"]["tasks"]])
        standardized = json.loads((self.reference / "cells/gravity/maps_d2_s0/result.json").read_text())
        self.assertNotEqual([t["returns"] for t in again["tasks"]],
                            [t["returns"] for t in standardized["eval"]["tasks"]])

    def test_each_module_probe(self):
        """maps eval --each-module (Fig. 6): every task scored with the selector and forced onto each module, and
        experiments/report/fig6_probe.py's table and strips from it; a damaged probe file is named, not trusted."""
        cell = self.dir / "cell"
        shutil.copytree(self.reference / "cells/mt10/maps_d2_s0", cell)
        own = (cell / "eval.json").read_bytes()
        maps("eval", "--run", cell, "--each-module", "--episodes", "2", "--threads", "1")
        self.assertEqual((cell / "eval.json").read_bytes(), own)
        probe = json.loads((cell / "eval_modules.json").read_text())
        self.assertEqual(probe["format"], "maps-eval-modules/1")
        self.assertEqual(len(probe["tasks"]), 10)
        self.assertEqual([m["module"] for m in probe["modules"]], list(range(10)))
        reference = json.loads((cell / "result.json").read_text())["eval"]
        for entry in [probe["selector"]] + probe["modules"]:
            self.assertEqual(len(entry["scores"]), 10)
            self.assertAlmostEqual(entry["mean_score"], sum(entry["scores"]) / 10)
        # The selector's row is the cell's own policy: its first two episodes per task as in the suite's evaluation.
        for k, t in enumerate(reference["tasks"]):
            self.assertEqual(probe["tasks"][k], t["task"])
        proc = maps("eval", "--run", self.reference / "cells/mt10/mt_bc_d2_s0", "--each-module", check=False)
        self.assertIn("only MAPS has modules", proc.stderr)

        script = ROOT / "experiments" / "report" / "fig6_probe.py"
        out = self.dir / "fig6"
        proc = subprocess.run([sys.executable, script, cell, "--out", out, "--tasks", "reach", "--maps", MAPS],
                              cwd=WORK, capture_output=True, text=True)
        if "this build has no renderer" not in proc.stderr:
            self.assertEqual(proc.returncode, 0, proc.stderr)
            text = (out / "modules.md").read_text()
            self.assertIn("| reach |", text)
            self.assertTrue((out / "reach_selector.png").exists())
        (cell / "eval_modules.json").write_text('{"format": "maps-eval-modules/1", "tasks": ["mt10/reach"]')
        proc = subprocess.run([sys.executable, script, cell, "--out", out, "--maps", MAPS], cwd=WORK,
                              capture_output=True, text=True)
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("eval_modules.json: not a readable module probe", proc.stderr)

    def test_paper_protocol_options(self):
        """The paper's options (train.bc_loss "sampled", maps.observations "raw_clipped", kept checkpoints, MAML's
        checkpoint judged after fine-tuning) run through the suite, and a fresh process's evaluation of best.ckpt
        (which holds the learned log-std) scores what the suite's did."""
        config = json.loads(TINY.read_text())
        config["variants"]["paper"] = {"maps": {"observations": "raw_clipped"},
                                       "train": {"bc_loss": "sampled", "keep_every": 30}}
        config["variants"]["adapted"] = {"maml": {"validate": "adapted"}}
        config["grids"] = [
            {"name": "paper", "sets": ["mt10"], "methods": ["maps", "mt_bc"], "variants": ["paper"], "seeds": [0]},
            {"name": "maml", "sets": ["mt10"], "methods": ["maml"], "variants": ["adapted"], "seeds": [0]}]
        path = write_config(self.dir, config)
        out = self.dir / "paper"
        maps("suite", "run", path, "--out", out, "--jobs", "2")
        for name in ("maps-paper_d2_s0", "mt_bc-paper_d2_s0", "maml-adapted_d2_s0"):
            cell = out / "cells/mt10" / name
            first = json.loads((cell / "result.json").read_text())
            if name.startswith("maml"):
                self.assertEqual(first["config"]["maml"]["validate"], "adapted")
            else:
                self.assertEqual(first["config"]["train"]["bc_loss"], "sampled")
                self.assertIn("best_over_checkpoints", first["eval"])
            maps("eval", "--run", cell)
            again = json.loads((cell / "eval.json").read_text())
            self.assertEqual(again["mean_score"], first["eval"]["mean_score"], name)

    def test_status_of_a_folder_that_is_not_a_suite(self):
        proc = maps("suite", "status", self.dir, check=False)
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("has no suite.json", proc.stderr)


def quick_tiny(folder):
    """tiny.json with MAPS's networks small (M = 10 modules still) and fewer validation states: the same cells and
    per-set settings (the tests check those), a fraction of the arithmetic. MT-BC keeps its sizes: a MAPS run refuses
    baselines.hidden, and one MLP is cheap."""
    config = json.loads(TINY.read_text())
    defaults = config.setdefault("defaults", {})
    defaults.setdefault("maps", {}).update({"module_hidden": [32], "selector_hidden": [16]})
    defaults.setdefault("train", {})["validation_states_per_task"] = 40
    return write_config(folder, config, "tiny_quick.json")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    MAPS = str(pathlib.Path(sys.argv.pop(1)).resolve())
    with tempfile.TemporaryDirectory(prefix="maps-suite-test-") as scratch:
        WORK = scratch
        if QUICK:
            TINY = quick_tiny(scratch)
        unittest.main()
