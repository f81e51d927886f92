#!/usr/bin/python3
"""Bad input anywhere (issue 15, item 7): every `maps` subcommand given wrong CLI values, missing, damaged or
foreign files and configs must exit non-zero with a message on stderr that names the input and what was
expected; never a crash, an uncaught exception, a Python traceback or silence. Run by ctest as:
bad_input_test.py path/to/maps."""
import json
import pathlib
import subprocess
import sys
import tempfile
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]
MAPS = None  # set from argv
WORK = None  # scratch folder

CRASH_SIGNS = ["terminate called", "Segmentation fault", "Aborted", "core dumped", "Traceback (most recent call",
               "AddressSanitizer", "runtime error:"]


class BadInputTest(unittest.TestCase):
    def expect_refused(self, args, *needles):
        proc = subprocess.run([MAPS, *map(str, args)], cwd=WORK, capture_output=True, text=True, timeout=300)
        where = f"maps {' '.join(map(str, args))}"
        self.assertNotEqual(proc.returncode, 0, f"{where} exited 0:\n{proc.stdout}")
        self.assertGreater(proc.returncode, 0, f"{where} died of signal {-proc.returncode}")
        self.assertTrue(proc.stderr.strip(), f"{where}: nothing on stderr")
        for sign in CRASH_SIGNS:
            self.assertNotIn(sign, proc.stderr, where)
        for needle in needles:
            self.assertIn(needle, proc.stderr, where)
        return proc.stderr

    def write(self, name, text):
        path = pathlib.Path(WORK) / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text) if isinstance(text, str) else path.write_bytes(text)
        return path

    def config(self, name, **override):
        base = {"method": "mt_bc", "data": {"file": str(pathlib.Path(WORK) / "absent.h5")}}
        base.update(override)
        return self.write(name, json.dumps(base))

    def test_cli_values(self):
        self.expect_refused(["no-such-command"], "no-such-command")
        self.expect_refused(["collect", "--set", "nope", "--out", "x.h5"], "--set")
        self.expect_refused(["collect", "--set", "mt10", "--demos", "-3", "--out", "x.h5"], "--demos")
        self.expect_refused(["collect", "--set", "mt10", "--demos", "many", "--out", "x.h5"], "--demos")
        self.expect_refused(["train", "--config", self.config("ok.json"), "--out", "r", "--threads", "0"], "--threads")
        self.expect_refused(["bench", "step", "--set", "nope"], "nope")
        self.expect_refused(["expert-eval", "--task", "gravity/9.9"], "gravity/9.9")
        self.expect_refused(["render", "--task", "mt10/no-such-task", "--out", "x.png"], "mt10/no-such-task")
        self.expect_refused(["suite", "run", ROOT / "experiments/suites/tiny.json", "--out", "o", "--shard", "3/2"],
                            "3/2")

    def test_run_configs(self):
        self.expect_refused(["train", "--config", "absent.json", "--out", "r1"], "absent.json")
        self.expect_refused(["train", "--config", self.write("broken.json", '{"method": "mt_bc", '), "--out", "r2"],
                            "broken.json")
        self.expect_refused(["train", "--config", self.config("typo.json", trian={}), "--out", "r3"], "'trian'")
        self.expect_refused(["train", "--config", self.config("float.json", seed=1.5), "--out", "r4"], "seed")
        self.expect_refused(["train", "--config", self.config("absent_data.json"), "--out", "r5"], "absent.h5")
        not_hdf5 = self.write("fake.h5", "this is not an HDF5 file\n")
        self.expect_refused(["train", "--config", self.config("fake.json", data={"file": str(not_hdf5)}),
                             "--out", "r6"], "fake.h5")

    def test_run_folders_and_checkpoints(self):
        empty = pathlib.Path(WORK) / "empty_run"
        empty.mkdir(exist_ok=True)
        self.expect_refused(["eval", "--run", empty], "empty_run")
        self.expect_refused(["eval", "--run", "absent_run"], "absent_run")
        # A real run whose best checkpoint is then damaged (truncated, then garbage).
        demos = pathlib.Path(WORK) / "demos.h5"
        subprocess.run([MAPS, "collect", "--set", "mt10", "--demos", "2", "--out", demos], cwd=WORK, check=True,
                       capture_output=True)
        config = self.write("small.json", json.dumps({
            "method": "mt_bc", "data": {"file": str(demos), "demos_per_task": 1}, "baselines": {"hidden": [4]},
            "train": {"steps": 20, "states_per_task": 4, "validate_every": 10, "checkpoint_every": 10},
            "eval": {"episodes": 1}}))
        damaged = pathlib.Path(WORK) / "damaged_run"
        subprocess.run([MAPS, "train", "--config", config, "--out", damaged], cwd=WORK, check=True,
                       capture_output=True)
        whole = (damaged / "best.ckpt").read_bytes()
        (damaged / "best.ckpt").write_bytes(whole[: len(whole) // 2])
        self.expect_refused(["eval", "--run", damaged], "best.ckpt")
        (damaged / "best.ckpt").write_bytes(b"\x00garbage" * 10)
        self.expect_refused(["eval", "--run", damaged], "best.ckpt")
        (damaged / "best.ckpt").write_bytes(whole)
        (damaged / "config.json").write_text("{")
        self.expect_refused(["eval", "--run", damaged], "config.json")

    def test_suite_configs_and_folders(self):
        self.expect_refused(["suite", "plan", "absent_suite.json"], "absent_suite.json")
        self.expect_refused(["suite", "plan", self.write("bad_suite.json", '{"grids": 3}')], "bad_suite.json")
        tiny = json.loads((ROOT / "experiments/suites/tiny.json").read_text())
        tiny["grids"][0]["seeds"] = [0.5]
        self.expect_refused(["suite", "plan", self.write("float_seed.json", json.dumps(tiny))], "seeds")
        self.expect_refused(["suite", "status", WORK], "has no suite.json")
        self.expect_refused(["report", WORK], "suite.json")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    MAPS = str(pathlib.Path(sys.argv.pop(1)).resolve())
    with tempfile.TemporaryDirectory(prefix="maps-bad-input-test-") as scratch:
        WORK = scratch
        unittest.main()
