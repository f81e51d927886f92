#!/usr/bin/python3
"""Kill -9 at random moments (issue 15, item 5): `maps train` and `maps collect` killed again and again, then run
to the end, must end exactly where an uninterrupted run ends, and must never leave a file that a later step
trusts half-written (checkpoints and demo files are written to a temporary and renamed). The suite's own kill test
is in suite_run_test.py. Run by ctest as: kill_test.py path/to/maps (needs h5diff, from hdf5-tools)."""
import json
import os
import pathlib
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import unittest

from maps_tool import curve_without_timing  # beside this file

MAPS = None  # set from argv
# MAPS_TEST_QUICK=1 (a sanitizer build, where every step is several times slower; CI runs this file in its Release
# pass only, .ci/run phase 4 says why): fewer kills.
QUICK = os.environ.get("MAPS_TEST_QUICK") == "1"
WORK = None  # scratch folder


def run(*args, cwd=None):
    return subprocess.run([MAPS, *map(str, args)], cwd=cwd or WORK, capture_output=True, text=True)


def timed(*args, cwd=None):
    start = time.monotonic()
    proc = run(*args, cwd=cwd)
    if proc.returncode != 0:
        raise AssertionError(f"maps {' '.join(map(str, args))}: {proc.stderr}")
    return time.monotonic() - start


def kill_at(args, seconds):
    """Starts maps with args, SIGKILLs it after `seconds` unless it ended first; True if it was killed."""
    proc = subprocess.Popen([MAPS, *map(str, args)], cwd=WORK, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        proc.wait(timeout=seconds)
        if proc.returncode != 0:
            raise AssertionError(f"maps {' '.join(map(str, args))} failed: {proc.stderr.read().decode()}")
        return False
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        return True
    finally:
        proc.stderr.close()


def timed_with_start_up(args, curve):
    """Runs maps to the end; returns (start-up seconds until `curve` got its first row, total seconds): the first
    kill_at's range, before a killed start has timed its own start-up."""
    start = time.monotonic()
    proc = subprocess.Popen([MAPS, *map(str, args)], cwd=WORK, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    start_up = None
    while proc.poll() is None:
        if start_up is None and curve_rows(curve) > 0:
            start_up = time.monotonic() - start
        time.sleep(0.005)
    total = time.monotonic() - start
    error = proc.stderr.read().decode()
    proc.stderr.close()
    if proc.returncode != 0:
        raise AssertionError(f"maps {' '.join(map(str, args))}: {error}")
    return (start_up if start_up is not None else total), total


def curve_rows(path):
    try:
        with open(path) as f:
            return sum(1 for _ in f)
    except FileNotFoundError:
        return 0


def kill_after_progress(args, curve, rows_ahead, share_of_a_row):
    """Starts maps with args, waits until `curve` holds `rows_ahead` rows more than before (the run got past its
    start-up and trained), then SIGKILLs it `share_of_a_row` of one row's time later (the last row's interval, timed
    live) unless it ended first. Returns (whether it was killed, seconds from launch to its first row past the file's
    rows: this start's start-up, for the next kill_at). Progress is counted in rows, not seconds from a reference run:
    a delay scaled by a reference run measured while the machine was busy lets a start on a quieter machine train to
    the end (CI once landed 2 kills where 5 were required, and before that killed 40 starts in a row before any of
    them trained a step when start-up was slow). A resumed run first cuts the curve back to its checkpoint, so the
    rows it must pass are counted from the file before the start."""
    before = curve_rows(curve)
    target = before + rows_ahead
    launched = time.monotonic()
    proc = subprocess.Popen([MAPS, *map(str, args)], cwd=WORK, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        rows, last_row_time, interval, start_up = before, launched, None, None
        while proc.poll() is None and rows < target:
            time.sleep(0.002)
            now_rows = curve_rows(curve)
            if now_rows != rows:
                now = time.monotonic()
                if now_rows > rows:
                    interval = now - last_row_time
                if start_up is None and now_rows > before:
                    start_up = now - launched
                rows, last_row_time = now_rows, now
        start_up = start_up if start_up is not None else time.monotonic() - launched
        try:
            proc.wait(timeout=share_of_a_row * (interval if interval is not None else 0.01))
        except subprocess.TimeoutExpired:
            proc.send_signal(signal.SIGKILL)
            proc.wait()
            return True, start_up
        if proc.returncode != 0:
            raise AssertionError(f"maps {' '.join(map(str, args))} failed: {proc.stderr.read().decode()}")
        return False, start_up
    finally:
        proc.stderr.close()


def same_demo_files(a, b):
    """h5diff compares the content (HDF5 stamps creation times into object headers, so bytes differ)."""
    return subprocess.run(["h5diff", str(a), str(b)], capture_output=True).returncode == 0


class KillTest(unittest.TestCase):
    demos = None  # a small MT10 demo file, collected once

    @classmethod
    def setUpClass(cls):
        if shutil.which("h5diff") is None:
            raise unittest.SkipTest("h5diff not found (bash scripts/setup.sh installs hdf5-tools)")
        # Collected in a folder of its own under the name the killed collections use: the file records its
        # command line, which must match for the contents to compare equal.
        reference = pathlib.Path(WORK) / "reference"
        reference.mkdir()
        cls.collect_seconds = timed("collect", "--set", "mt10", "--demos", "8", "--out", "collected.h5",
                                    cwd=reference)
        cls.demos = reference / "collected.h5"

    def setUp(self):
        self.rng = random.Random(int(os.environ.get("MAPS_KILL_SEED", "0")))

    def test_train_killed_anywhere_ends_where_an_uninterrupted_run_ends(self):
        config = pathlib.Path(WORK) / "train.json"
        config.write_text(json.dumps({
            "method": "maps", "seed": 3,
            "data": {"file": str(self.demos), "demos_per_task": 4, "subsample": 1},
            "maps": {"modules": 3, "module_hidden": [32], "selector_hidden": [16]},
            # A checkpoint every 10 steps: a good share of the kills land inside a checkpoint write.
            "train": {"steps": 1500, "states_per_task": 8, "validate_every": 10, "checkpoint_every": 10,
                      "validation_states_per_task": 20}}))
        reference = pathlib.Path(WORK) / "train_reference"
        start_up, seconds = timed_with_start_up(["train", "--config", config, "--out", reference],
                                                reference / "curve.csv")
        training = max(seconds - start_up, 0.05)
        killed_dir = pathlib.Path(WORK) / "train_killed"
        args = ["train", "--config", config, "--out", killed_dir]
        kills = 0
        for start in range(100):
            # Every third start is killed at any moment from its launch until a little past its first new row
            # (start-up, loading, the first checkpoint write), timed by the last start that got that far; the others
            # after they have trained a few validation rows past where the file was, at a random point of the next
            # row (every row is also a checkpoint write), so the run always moves on.
            if start % 3 == 0:
                killed = kill_at(args, self.rng.uniform(0.0, 1.2 * start_up))
            else:
                killed, start_up = kill_after_progress(args, killed_dir / "curve.csv", self.rng.randint(2, 10),
                                                       self.rng.uniform(0.0, 1.5))
            if not killed:
                break
            kills += 1
        else:
            self.fail("the run never finished within 100 starts")
        print(f"train: {kills} kills; start-up {start_up:.2f} s, training {training:.2f} s", file=sys.stderr)
        self.assertGreaterEqual(kills, 2 if QUICK else 5, "too few kills landed: the run is too short for this machine")
        for name in ("last.ckpt", "best.ckpt"):
            self.assertEqual((killed_dir / name).read_bytes(), (reference / name).read_bytes(), name)
        self.assertEqual(curve_without_timing(killed_dir / "curve.csv"), curve_without_timing(reference / "curve.csv"))
        a = json.loads((reference / "train.json").read_text())
        b = json.loads((killed_dir / "train.json").read_text())
        for key in ("best_step", "best_validation_bc", "steps", "training_demo_seeds"):
            self.assertEqual(a[key], b[key], key)
        self.assertTrue(b["resumed"])
        # Killed writers leave their temporaries behind; no later run may take one for a checkpoint.
        leftovers = [p.name for p in killed_dir.iterdir() if p.name not in
                     {"last.ckpt", "best.ckpt", "curve.csv", "train.json", "config.json", "train.log",
                      "provenance.json"}]
        for name in leftovers:
            self.assertIn("tmp", name)

    def test_collect_killed_anywhere_leaves_the_file_complete_or_absent(self):
        out = pathlib.Path(WORK) / "collected.h5"
        complete = 0
        trials = 4 if QUICK else 12
        for _ in range(trials):
            out.unlink(missing_ok=True)
            kill_at(["collect", "--set", "mt10", "--demos", "8", "--out", out.name],
                    self.rng.uniform(0.0, self.collect_seconds * 1.1))
            if out.exists():
                self.assertTrue(same_demo_files(self.demos, out), "a killed collect left a different demo file")
                complete += 1
        # A temporary left by a killed writer is never read as the demo file: training on the folder's file fails
        # cleanly when it is absent, and a rerun writes it whole.
        out.unlink(missing_ok=True)
        proc = run("collect", "--set", "mt10", "--demos", "8", "--out", out.name)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        self.assertTrue(same_demo_files(self.demos, out))
        self.assertLess(complete, trials, "no kill landed before the rename: the collection is too short")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    MAPS = str(pathlib.Path(sys.argv.pop(1)).resolve())
    with tempfile.TemporaryDirectory(prefix="maps-kill-test-") as scratch:
        WORK = scratch
        unittest.main()
