#!/usr/bin/python3
"""Tests of docs/performance.md's GAIL speed script (experiments/bench/gail_speed.py; issue 45): its refusals name the
argument and what was expected, and its table and records come from each run's train.json (a stand-in for `maps`
writes them, so no GAIL run is needed). Run by ctest (tests/CMakeLists.txt)."""
import contextlib
import io
import json
import pathlib
import sys
import tempfile
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "experiments" / "bench"))

import gail_speed  # noqa: E402

# `maps train --config C --out F` as far as the script sees it: F/train.json with 1 thread twice as slow as 2.
STAND_IN = """#!/usr/bin/python3
import json, pathlib, sys
config = json.loads(pathlib.Path(sys.argv[sys.argv.index("--config") + 1]).read_text())
out = pathlib.Path(sys.argv[sys.argv.index("--out") + 1])
out.mkdir(parents=True)
seconds = 100.0 / config["gail"]["threads"]
parts = {"physics_seconds": 0.5, "rollout_policy_seconds": 0.2, "discriminator_seconds": 0.1, "ppo_seconds": 0.15,
         "other_seconds": 0.05}
train = {"training_demo_seeds": [[1], [2], [3]], "seconds_this_process": seconds,
         "env_steps_this_process": 3 * config["gail"]["env_steps_per_task"]}
train.update({key: share * seconds for key, share in parts.items()})
(out / "train.json").write_text(json.dumps(train))
"""


class GailSpeedTest(unittest.TestCase):
    def setUp(self):
        self.folder = tempfile.TemporaryDirectory(prefix="gail-speed-")
        self.addCleanup(self.folder.cleanup)
        self.root = pathlib.Path(self.folder.name)
        self.maps = self.root / "maps"
        self.maps.write_text(STAND_IN)
        self.maps.chmod(0o755)
        self.data = self.root / "gravity.h5"
        self.data.write_bytes(b"")

    def run_script(self, *extra):
        args = ["--maps", str(self.maps), "--data", str(self.data), "--work", str(self.root / "work"), "--out",
                str(self.root / "speed.jsonl"), *extra]
        printed = io.StringIO()
        with contextlib.redirect_stdout(printed), contextlib.redirect_stderr(io.StringIO()):
            code = gail_speed.main(args)
        return code, printed.getvalue()

    def refusal(self, *extra):
        with self.assertRaises(SystemExit) as stop:
            self.run_script(*extra)
        return str(stop.exception.code)

    def test_refusals_name_the_argument_and_what_was_expected(self):
        self.assertIn("--maps", self.refusal("--maps", str(self.root / "missing")))
        self.assertIn("is not a file", self.refusal("--maps", str(self.root / "missing")))
        self.assertIn("maps collect --set gravity", self.refusal("--data", str(self.root / "missing.h5")))
        steps = self.refusal("--env-steps", "1999")
        self.assertIn("--env-steps must be at least 2000", steps)
        self.assertNotIn("--threads", steps)
        threads = self.refusal("--threads", "1", "0")
        self.assertIn("--threads must be positive, got 1 0", threads)
        self.assertNotIn("--env-steps", threads)

    def test_rows_and_records_come_from_each_runs_train_json(self):
        code, printed = self.run_script("--methods", "mt_bc", "--threads", "1", "2", "--env-steps", "4000")
        self.assertEqual(code, 0)
        records = [json.loads(line) for line in (self.root / "speed.jsonl").read_text().splitlines()]
        self.assertEqual([(r["method"], r["threads"], r["tasks"]) for r in records], [("mt_bc", 1, 3), ("mt_bc", 2, 3)])
        self.assertAlmostEqual(records[0]["env_steps_per_second"], 12000 / 100.0)
        self.assertAlmostEqual(records[1]["env_steps_per_second"], 12000 / 50.0)
        self.assertIn("| mt_bc | 1 | 3 | 12,000 | 100.0 | 120 | 1.00x | 50% | 20% | 10% | 15% | 5% |", printed)
        self.assertIn("| mt_bc | 2 | 3 | 12,000 | 50.0 | 240 | 2.00x | 50% | 20% | 10% | 15% | 5% |", printed)
        written = json.loads((self.root / "work" / "mt_bc_t2.json").read_text())
        self.assertEqual(written["imitation"], "gail")
        self.assertEqual(written["gail"]["threads"], 2)


if __name__ == "__main__":
    unittest.main()
