#!/usr/bin/python3
"""`maps transfer` end to end (issue 17): a MAPS run trained without a task learns it from two demonstrations with
its modules frozen, the result is an ordinary run folder that `maps eval` scores on the new task, and transfers
that cannot be meant are refused by name. Run by ctest as: transfer_test.py path/to/maps."""
import fcntl
import json
import pathlib
import shutil
import struct
import subprocess
import unittest

from maps_tool import main, run, work

ROOT = pathlib.Path(__file__).resolve().parents[2]


def checkpoint_config(path):
    """The JSON config string a checkpoint stores (nn/serialize.h: magic, version, reserved, payload size, then the
    payload's config size and bytes)."""
    data = pathlib.Path(path).read_bytes()
    assert data[:8] == b"MAPSCKPT", path
    (size,) = struct.unpack_from("<Q", data, 24)
    return json.loads(data[32:32 + size])


class Transfer(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        run("collect", "--set", "mt10", "--demos", "4", "--out", "mt10.h5", "--threads", "1")
        config = work() / "config.json"
        config.write_text(json.dumps({"method": "maps", "data": {"file": "mt10.h5", "demos_per_task": 2},
                                      "maps": {"modules": 4},
                                      "train": {"steps": 60, "validate_every": 20, "checkpoint_every": 20,
                                                "validation_states_per_task": 50},
                                      "eval": {"episodes": 2, "threads": 1}}))
        cls.config = config
        run("train", "--config", config, "--out", "without_reach", "--set", 'data.holdout=["mt10/reach"]')
        run("train", "--config", config, "--out", "all_tasks")

    def test_a_held_out_task_is_learned_from_its_demos_and_evaluated(self):
        proc = run("transfer", "--run", "without_reach", "--task", "mt10/reach", "--demos", "2", "--out", "reach",
                   "--steps", "40")
        self.assertIn("starting from", proc.stdout)
        folder = work() / "reach"
        request = json.loads((folder / "request.json").read_text())
        self.assertEqual(request["data"]["tasks"], ["mt10/reach"])
        self.assertEqual(request["data"]["task_demos"], {"mt10/reach": 2})
        self.assertEqual(request["train"]["freeze"], ["modules"])
        # One task's batches: the explore term would spread the new task over every module, so it is off; the
        # other terms keep the source's weights.
        source = json.loads((work() / "without_reach" / "config.json").read_text())
        self.assertEqual(request["maps"]["selector_losses"],
                         dict(source["maps"]["selector_losses"], explore=0.0))
        self.assertEqual(pathlib.Path(request["init"]["run"]), (work() / "without_reach").resolve())
        # Standardised as the source was (its frozen modules were trained on those inputs), not with reach's states.
        source_stats = checkpoint_config(work() / "without_reach" / "best.ckpt")["standardizer"]
        own_stats = checkpoint_config(work() / "all_tasks" / "best.ckpt")["standardizer"]
        self.assertEqual(checkpoint_config(folder / "best.ckpt")["standardizer"], source_stats)
        self.assertNotEqual(own_stats, source_stats)
        run("eval", "--run", folder)
        evaluation = json.loads((folder / "eval.json").read_text())
        self.assertEqual([t["task"] for t in evaluation["tasks"]], ["mt10/reach"])
        self.assertEqual(len(evaluation["tasks"][0]["module_usage"]), 4)
        self.assertEqual(evaluation["tasks"][0]["demos"], 2)  # the new task's count, not the source's
        # Resuming the finished transfer changes nothing and does not start from the source again.
        again = run("transfer", "--run", "without_reach", "--task", "mt10/reach", "--demos", "2", "--out", "reach",
                    "--steps", "40")
        self.assertNotIn("starting from", again.stdout)

    def test_modules_fine_tuned_slower(self):
        run("transfer", "--run", "without_reach", "--task", "mt10/reach", "--demos", "2", "--out", "reach_tuned",
            "--steps", "20", "--freeze", "none", "--module-lr-scale", "0.1")
        request = json.loads((work() / "reach_tuned" / "request.json").read_text())
        self.assertEqual((request["train"]["freeze"], request["train"]["lr_scale"]), ([], {"modules": 0.1}))

    def test_transfers_that_cannot_be_meant_are_refused(self):
        def refused(code, needle, source, task="mt10/reach", demos="2", *extra):
            proc = run("transfer", "--run", source, "--task", task, "--demos", demos, "--out", "refused", *extra,
                       check=False)
            self.assertEqual(proc.returncode, code, proc.stderr)
            self.assertIn(needle, proc.stderr)

        refused(1, "was trained on mt10/reach", "all_tasks")
        refused(1, "is not a task of", "without_reach", "gravity/0.5")
        refused(2, "frozen", "without_reach", "mt10/reach", "2", "--module-lr-scale", "0.1")
        refused(1, "mt10/reach has 3 training demos (mask/train), 5 requested", "without_reach", "mt10/reach", "5")
        run("train", "--config", self.config, "--out", "baseline", "--set", "method=mt_bc",
            "--set", 'data.holdout=["mt10/reach"]')
        refused(1, "mt_bc run", "baseline")
        # A source that itself started from another run may have seen the task through it.
        run("train", "--config", self.config, "--out", "started_from", "--set", 'data.holdout=["mt10/reach"]',
            "--set", f"init.run={work() / 'without_reach'}", "--set", "train.steps=1")
        refused(1, "started from another run", "started_from")
        # maps train started from a run it cannot start from: refused naming init.run, leaving no config.json, so
        # the corrected command runs in the same folder.
        source = work() / "without_reach"
        proc = run("train", "--config", self.config, "--out", "mismatch", "--set", f"init.run={source}",
                   "--set", 'data.holdout=["mt10/reach"]', "--set", "maps.modules=2", "--set", "train.steps=2",
                   check=False)
        self.assertEqual(proc.returncode, 1, proc.stderr)
        self.assertIn(f"init.run {source}: cannot start from it: initialize_from: parameter modules0", proc.stderr)
        self.assertFalse((work() / "mismatch" / "config.json").exists())
        run("train", "--config", self.config, "--out", "mismatch", "--set", f"init.run={source}",
            "--set", 'data.holdout=["mt10/reach"]', "--set", "train.steps=2")
        # Into the source itself; a damaged source config, named as the source's.
        proc = run("transfer", "--run", "without_reach", "--task", "mt10/reach", "--demos", "2", "--out",
                   "without_reach", check=False)
        self.assertEqual(proc.returncode, 2, proc.stderr)
        self.assertIn("is the source run (--run)", proc.stderr)
        damaged = work() / "damaged_source"
        damaged.mkdir()
        (damaged / "config.json").write_text("[]")
        refused(1, "damaged_source/config.json': config: expected a JSON object", "damaged_source")
        # A transfer refused by its folder (another transfer there) leaves that folder's request.json as it was.
        run("transfer", "--run", "without_reach", "--task", "mt10/reach", "--demos", "1", "--out", "kept",
            "--steps", "4")
        before = (work() / "kept" / "request.json").read_text()
        proc = run("transfer", "--run", "without_reach", "--task", "mt10/reach", "--demos", "2", "--out", "kept",
                   "--steps", "4", check=False)
        self.assertEqual(proc.returncode, 1, proc.stderr)
        self.assertIn("differs in data.task_demos.mt10/reach", proc.stderr)
        self.assertEqual((work() / "kept" / "request.json").read_text(), before)

    def test_a_suite_grid_that_cannot_be_meant_is_refused(self):
        fixture = pathlib.Path(__file__).resolve().parent / "fixtures" / "transfer-tiny.json"
        for change, needle in [
                (lambda g: g.update(source_variant="wide"), "grids[2].source_variant: 'wide' is not defined under"),
                (lambda g: g.update(source_variant=3), "source_variant: expected a non-empty string"),
                (lambda g: g.update(methods=["mt_bc"]), "freeze: only with method transfer"),
                (lambda g: [g.update(methods=["mt_bc"]), g.pop("freeze"), g.pop("module_lr_scale")],
                 "source_variant: only with method transfer"),
                (lambda g: g.update(module_lr_scale=0.1, freeze=["modules"]), "the modules are frozen"),
                (lambda g: g.update(freeze=["modulez"]), 'freeze[0]: expected "modules" or "head", got "modulez"'),
                (lambda g: g.update(freeze=["modules", "selector"]), 'freeze[1]: expected "modules" or "head", got "selector"'),
                (lambda g: None, "'tuned' has a run config")]:
            config = json.loads(fixture.read_text())
            change(config["grids"][-1])
            if "run config" in needle:
                config["variants"]["tuned"] = {"train": {"steps": 10}}
            path = work() / "refused-suite.json"
            path.write_text(json.dumps(config))
            proc = run("suite", "plan", path, check=False)
            self.assertNotEqual(proc.returncode, 0, needle)
            self.assertIn(needle, proc.stderr)

    def test_a_suite_runs_transfer_cells_after_their_sources(self):
        fixture = pathlib.Path(__file__).resolve().parent / "fixtures" / "transfer-tiny.json"
        plan = json.loads(run("suite", "plan", fixture, "--json").stdout)
        names = [cell["name"] for cell in plan["cells"]]
        self.assertEqual(names[0], "mt10/maps-without-reach_d2_s0")
        self.assertIn("mt10/transfer-new-reach_d1_s0", names)
        self.assertIn("mt10/transfer-tuned-new-reach_d1_s0", names)
        proc = run("suite", "run", fixture, "--out", "suite", "--jobs", "2")
        self.assertIn("6 cells done, 0 failed", proc.stdout)
        cells = work() / "suite" / "cells" / "mt10"
        request = json.loads((cells / "transfer-new-reach_d1_s0" / "request.json").read_text())
        self.assertEqual(request["init"]["run"], "../maps-without-reach_d2_s0")
        self.assertEqual((request["data"]["tasks"], request["data"]["task_demos"]), (["mt10/reach"], {"mt10/reach": 1}))
        self.assertIn("starting from", (cells / "transfer-new-reach_d1_s0" / "train.log").read_text())
        # The fine-tuned grid starts from the base source too (source_variant), its modules training at a tenth.
        tuned = json.loads((cells / "transfer-tuned-new-reach_d1_s0" / "request.json").read_text())
        self.assertEqual(tuned["init"]["run"], "../maps-without-reach_d2_s0")
        self.assertEqual((tuned["train"]["freeze"], tuned["train"]["lr_scale"]), ([], {"modules": 0.1}))
        baseline = json.loads((cells / "mt_bc-new-reach_d2_s0" / "request.json").read_text())
        self.assertEqual((baseline["data"]["demos_per_task"], baseline["data"]["task_demos"]), (2, {"mt10/reach": 2}))
        # Judged on the new task, as the transfer and Single BC runs are; every cell draws each task's demos from a
        # stream of its own (the fixture's data.draws), so the other tasks' demos are the source's.
        self.assertEqual(baseline["train"]["validation_tasks"], ["mt10/reach"])
        self.assertEqual(request["train"]["validation_tasks"], [])
        source = json.loads((cells / "maps-without-reach_d2_s0" / "result.json").read_text())
        trained = json.loads((cells / "mt_bc-new-reach_d1_s0" / "result.json").read_text())
        others = {t: s for t, s in trained["train"]["training_demo_seeds"].items() if t != "mt10/reach"}
        self.assertEqual(others, source["train"]["training_demo_seeds"])
        table = subprocess.run(["/usr/bin/python3", str(ROOT / "experiments" / "report" / "transfer_table.py"),
                                work() / "suite"], capture_output=True, text=True)
        self.assertEqual(table.returncode, 0, table.stderr)
        report = (work() / "suite" / "report" / "transfer.md").read_text()
        self.assertIn("## mt10/reach", report)
        self.assertRegex(report, r"\| MAPS transfer \| [0-9.]+ \(1\) \| [0-9.]+ \(1\) \|")
        self.assertRegex(report, r"\| MAPS transfer \(tuned\) \| [0-9.]+ \(1\) \| - \|")
        # Each transfer is paired with the other methods (its own Holm family), and the tuned one with the frozen.
        self.assertRegex(report, r"\| MAPS transfer \(tuned\) \| MT-BC \(all tasks\) \| 1 \| 1 \| [-+][0-9.]+ \|")
        self.assertRegex(report, r"\| MAPS transfer \| MT-BC \(all tasks\) \| 2 \| 1 \| [-+][0-9.]+ \|")
        self.assertRegex(report, r"\| MAPS transfer \(tuned\) \| MAPS transfer \| 1 \| 1 \| [-+][0-9.]+ \| - \| "
                                 r"\(not adjusted\) \|")
        # The cost from the curves: seconds to the best step and of training, numbers for every cell; the source
        # run's beside.
        self.assertRegex(report, r"\| MAPS transfer \| 1 \| \d+ \| [01] of 1 \| [0-9.]+ \| [0-9.]+ \|")
        self.assertRegex(report, r"\| MT-BC \(all tasks\) \| 1 \| \d+ \| - \| [0-9.]+ \| [0-9.]+ \|")
        self.assertRegex(report, r"MAPS transfer starts from a run without reach \(1 seeds, the other tasks at 2 "
                                 r"demonstrations\): best step \d+, [0-9.]+ CPU seconds to it, [0-9.]+ of training")
        self.assertTrue((work() / "suite" / "report" / "transfer_scores.png").stat().st_size > 10000)
        for cell in ("transfer-new-reach_d2_s0", "mt_bc-new-reach_d2_s0"):
            result = json.loads((cells / cell / "result.json").read_text())
            self.assertEqual([t["task"] for t in result["eval"]["tasks"]], ["mt10/reach"], cell)
        # A damaged result is named in transfer.md and on stderr, not dropped silently; --out that is a file is refused.
        damaged = work() / "suite-damaged"
        shutil.copytree(work() / "suite", damaged)
        broken = damaged / "cells" / "mt10" / "mt_bc-new-reach_d1_s0" / "result.json"
        broken.write_text(broken.read_text()[:100])
        table = subprocess.run(["/usr/bin/python3", str(ROOT / "experiments" / "report" / "transfer_table.py"),
                                damaged], capture_output=True, text=True)
        self.assertEqual(table.returncode, 0, table.stderr)
        self.assertIn(f"left out {broken}", table.stderr)
        self.assertIn(f"- `{broken}`: unreadable ('{broken}' is not valid JSON",
                      (damaged / "report" / "transfer.md").read_text())
        table = subprocess.run(["/usr/bin/python3", str(ROOT / "experiments" / "report" / "transfer_table.py"),
                                damaged, "--out", broken], capture_output=True, text=True)
        self.assertNotEqual(table.returncode, 0)
        self.assertIn("cannot make the folder", table.stderr)
        self.assertNotIn("Traceback", table.stderr)
        # A rerun after the source had failed: while one job redoes the source, its transfer cells wait for it
        # instead of failing on the earlier attempt's error.json.
        rerun = work() / "suite-rerun"
        shutil.copytree(work() / "suite", rerun)
        source_dir = rerun / "cells" / "mt10" / "maps-without-reach_d2_s0"
        (source_dir / "result.json").unlink()
        (source_dir / "error.json").write_text(json.dumps({"stage": "train", "error": "an earlier attempt failed"}))
        for cell in (rerun / "cells" / "mt10").iterdir():
            if cell.name.startswith("transfer-"):
                (cell / "result.json").unlink()
        proc = run("suite", "run", fixture, "--out", rerun, "--jobs", "2")
        self.assertIn("4 cells done, 0 failed", proc.stdout)
        self.assertFalse((source_dir / "error.json").exists())
        # A clone of committed results holds each cell's result.json and curve.csv, no checkpoint: with a transfer
        # cell left to run, the source runs again and so does every finished cell that started from it (all of a
        # seed's transfers start from one run of the source); their results so far move to replaced/. On this machine
        # the reruns reproduce the first results.
        clone = work() / "suite-clone"
        (clone / "cells" / "mt10").mkdir(parents=True)
        shutil.copy(work() / "suite" / "suite.json", clone / "suite.json")
        for cell in (work() / "suite" / "cells" / "mt10").iterdir():
            (clone / "cells" / "mt10" / cell.name).mkdir()
            for name in ("result.json", "curve.csv"):
                shutil.copy(cell / name, clone / "cells" / "mt10" / cell.name / name)
        # The cell left holds what an attempt from the earlier source run left behind: it starts again from nothing.
        unfinished = clone / "cells" / "mt10" / "transfer-new-reach_d2_s0"
        (unfinished / "result.json").unlink()
        (unfinished / "last.ckpt").write_text("an attempt from the earlier source run")
        # While another process holds a cell of the group, the group is left to it: nothing is retired, and the run
        # says so and exits 3, as for any cell another process holds.
        with open(unfinished / ".lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
            proc = run("suite", "run", fixture, "--out", clone, check=False)
        self.assertEqual(proc.returncode, 3, proc.stdout + proc.stderr)
        self.assertIn("another process holds", proc.stdout)
        self.assertIn("0 to run on 1 jobs x 1 threads, 4 left to another process", proc.stdout)
        self.assertFalse((clone / "cells" / "mt10" / "maps-without-reach_d2_s0" / "replaced").exists())
        self.assertTrue((unfinished / "last.ckpt").exists())
        # Status counts them as work left before the run does it.
        proc = run("suite", "status", clone, "--all")
        self.assertIn("3 of the done cells run again", proc.stdout)
        self.assertRegex(proc.stdout, r"done  mt10/transfer-new-reach_d1_s0: .*runs again")
        self.assertNotRegex(proc.stdout, r"done  mt10/mt_bc-new-reach_d1_s0: .*runs again")
        proc = run("suite", "run", fixture, "--out", clone, "--jobs", "2")
        self.assertIn("mt10/maps-without-reach_d2_s0 is finished but its best.ckpt is gone", proc.stdout)
        self.assertIn("the 2 finished ones that started from it run again, the unfinished ones from the start",
                      proc.stdout)
        self.assertNotIn("resuming failed", proc.stdout)
        self.assertIn("4 cells done, 0 failed", proc.stdout)
        redone = clone / "cells" / "mt10"
        for cell in ("maps-without-reach_d2_s0", "transfer-new-reach_d1_s0", "transfer-tuned-new-reach_d1_s0"):
            first = json.loads((cells / cell / "result.json").read_text())
            kept = redone / cell / "replaced" / first["finished"].replace(":", "-")
            self.assertEqual(json.loads((kept / "result.json").read_text()), first, cell)
            self.assertEqual((kept / "curve.csv").read_text(), (cells / cell / "curve.csv").read_text(), cell)
            again = json.loads((redone / cell / "result.json").read_text())
            self.assertEqual(again["replaces"][0]["folder"], "replaced/" + kept.name, cell)
            self.assertEqual(again["replaces"][0]["best_step"], first["train"]["best_step"], cell)
            self.assertEqual((again["train"]["best_step"], again["train"]["best_validation_bc"],
                              again["eval"]["mean_score"]),
                             (first["train"]["best_step"], first["train"]["best_validation_bc"],
                              first["eval"]["mean_score"]), cell)
        source = json.loads((redone / "maps-without-reach_d2_s0" / "result.json").read_text())
        for cell in ("transfer-new-reach_d1_s0", "transfer-new-reach_d2_s0", "transfer-tuned-new-reach_d1_s0"):
            again = json.loads((redone / cell / "result.json").read_text())
            self.assertEqual(again["source"], {"cell": "maps-without-reach_d2_s0", "finished": source["finished"]})
        # Cells that do not start from it are left alone.
        self.assertFalse((redone / "mt_bc-new-reach_d1_s0" / "replaced").exists())
        self.assertEqual(json.loads((redone / "mt_bc-new-reach_d1_s0" / "result.json").read_text()),
                         json.loads((cells / "mt_bc-new-reach_d1_s0" / "result.json").read_text()))
        # With every cell that starts from it finished, a source without its checkpoint is not run again.
        (redone / "maps-without-reach_d2_s0" / "best.ckpt").unlink()
        proc = run("suite", "run", fixture, "--out", clone)
        self.assertIn("0 to run", proc.stdout)
        self.assertNotIn("best.ckpt is gone", proc.stdout)
        self.assertNotIn("run again", run("suite", "status", clone).stdout)
        # Merging the first results with the reruns keeps the reruns, whichever comes first, with their replaced/
        # record. The first results here get other scores (as runs on another machine may) to tell them apart: the
        # source and a retired transfer, and the transfer that was unfinished in the clone (its first result started
        # from the replaced source run).
        stale = work() / "suite-stale"
        shutil.copytree(work() / "suite", stale)
        for cell in ("maps-without-reach_d2_s0", "transfer-new-reach_d1_s0", "transfer-new-reach_d2_s0"):
            path = stale / "cells" / "mt10" / cell / "result.json"
            changed = json.loads(path.read_text())
            changed["eval"]["mean_score"] += 0.001
            path.write_text(json.dumps(changed))
        for order in ((stale, clone), (clone, stale)):
            merged = work() / ("merged-" + order[0].name)
            proc = run("suite", "merge", "--out", merged, *order)
            self.assertIn(f"{len(names)} of {len(names)} cells finished", proc.stdout)
            for cell in ("maps-without-reach_d2_s0", "transfer-new-reach_d1_s0", "transfer-new-reach_d2_s0"):
                self.assertEqual(json.loads((merged / "cells" / "mt10" / cell / "result.json").read_text()),
                                 json.loads((redone / cell / "result.json").read_text()), (order, cell))
            # The transfer that was unfinished in the clone: its first result (from the replaced source run) is
            # kept in replaced/ whichever side came first.
            first = json.loads((stale / "cells" / "mt10" / "transfer-new-reach_d2_s0" / "result.json").read_text())
            kept = merged / "cells" / "mt10" / "transfer-new-reach_d2_s0" / "replaced" / \
                first["finished"].replace(":", "-")
            self.assertEqual(json.loads((kept / "result.json").read_text()), first, order)
            # Every earlier result on record in the clone is in the merge; the first results that differ from
            # them (the scores changed above) are kept too, under names of their own.
            for cell in ("maps-without-reach_d2_s0", "transfer-new-reach_d1_s0"):
                records = [json.loads(p.read_text())
                           for p in (merged / "cells" / "mt10" / cell / "replaced").glob("*/result.json")]
                expected = [json.loads(p.read_text()) for p in (redone / cell / "replaced").glob("*/result.json")]
                expected.append(json.loads((stale / "cells" / "mt10" / cell / "result.json").read_text()))
                self.assertCountEqual(records, expected, (order, cell))
        self.assertIn("mt10/transfer-new-reach_d2_s0: " + str(stale) + "'s result of", proc.stdout)
        self.assertIn("was run again since (or its source was); not merged", proc.stdout)
        self.assertIn("(4 results left out: their cells, or the sources they started from, were run again since)",
                      proc.stdout)
        # Two results of one cell where neither replaced the other are still refused.
        proc = run("suite", "merge", "--out", work() / "merged-conflict", stale, work() / "suite", check=False)
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("neither is a rerun that replaced the other", proc.stdout + proc.stderr)
        # A suite.json that lists the transfers before their source (a hand-written suite may): the source is merged
        # first all the same, so a transfer's result from the replaced source run is still left out, and not taken
        # for a conflict with the rerun.
        for folder in (stale, clone):
            manifest = json.loads((folder / "suite.json").read_text())
            manifest["cells"].reverse()
            (folder / "suite.json").write_text(json.dumps(manifest))
        proc = run("suite", "merge", "--out", work() / "merged-reversed", clone, stale)
        self.assertEqual(
            json.loads((work() / "merged-reversed" / "cells" / "mt10" / "transfer-new-reach_d2_s0" /
                        "result.json").read_text()),
            json.loads((redone / "transfer-new-reach_d2_s0" / "result.json").read_text()))

    def test_shards_keep_a_transfer_cell_with_its_source(self):
        fixture = pathlib.Path(__file__).resolve().parent / "fixtures" / "transfer-tiny.json"
        transfers = {c["name"] for c in json.loads(run("suite", "plan", fixture, "--json").stdout)["cells"]
                     if c["name"].startswith("mt10/transfer-")}
        self.assertEqual(len(transfers), 3)
        for shards in (2, 3, 4):
            placed = set()
            for shard in range(shards):
                cells = json.loads(run("suite", "plan", fixture, "--json", "--shard", f"{shard}/{shards}").stdout)["cells"]
                names = {c["name"] for c in cells}
                placed |= names & transfers
                if names & transfers:
                    self.assertIn("mt10/maps-without-reach_d2_s0", names, f"shard {shard}/{shards}")
                self.assertTrue(all(c["shard_key"] % shards == shard for c in cells))
            self.assertEqual(placed, transfers, f"{shards} shards")
        # Each shard in a folder of its own, as on a cluster: every transfer cell runs and finds its source.
        for shard in range(2):
            proc = run("suite", "run", fixture, "--out", f"sharded/shard-{shard}", "--shard", f"{shard}/2")
            self.assertIn("0 failed", proc.stdout)
        ran = {f"mt10/{p.parent.name}" for p in work().glob("sharded/shard-*/cells/mt10/transfer-*/result.json")}
        self.assertEqual(ran, transfers)

    def test_a_failed_source_fails_its_transfer_cells_by_name(self):
        # The holdout run fails (train.freeze names no parameter, which only its training finds): its transfer cells
        # fail naming it, and are counted failed.
        config = json.loads((pathlib.Path(__file__).resolve().parent / "fixtures" / "transfer-tiny.json").read_text())
        config["variants"]["diverges"] = {"train": {"freeze": ["no_such_parameter"]}}
        config["grids"][0]["variants"] = ["diverges"]
        config["grids"][1].update(source_variant="diverges", methods=["transfer"])
        del config["grids"][2]
        path = work() / "diverging-suite.json"
        path.write_text(json.dumps(config))
        proc = run("suite", "run", path, "--out", "diverging", "--jobs", "2", check=False)
        self.assertIn("0 cells done, 3 failed", proc.stdout)
        cells = work() / "diverging" / "cells" / "mt10"
        self.assertEqual(json.loads((cells / "maps-diverges-without-reach_d2_s0" / "error.json").read_text())["stage"],
                         "train")
        for demos in (1, 2):
            error = json.loads((cells / f"transfer-new-reach_d{demos}_s0" / "error.json").read_text())
            self.assertEqual(error["stage"], "source")
            self.assertIn("maps-diverges-without-reach_d2_s0 failed (see its error.json)", error["error"])
        status = run("suite", "status", "diverging").stdout
        self.assertIn("3 failed", status)


if __name__ == "__main__":
    main(__file__)
