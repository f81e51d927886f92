#!/usr/bin/python3
"""`maps data export|import` (issue 16, item 2): every format's round trip gives back the same demo file bit for bit
(h5diff: every dataset and attribute), each exported file meets its format's documented requirements as read with
h5py (the facts are in docs/interop.md), datasets made elsewhere import, and bad ones are refused by name. Run by
ctest as: interop_test.py path/to/maps (needs python3-h5py and h5diff)."""
import json
import pathlib
import re
import shutil
import subprocess
import sys
import tempfile
import unittest

MAPS = None  # set from argv
WORK = None

try:
    import h5py
    import numpy as np
except ImportError:  # scripts/setup.sh installs python3-h5py
    h5py = None


def maps(*args, check=True):
    proc = subprocess.run([MAPS, *map(str, args)], cwd=WORK, capture_output=True, text=True)
    if check and proc.returncode != 0:
        raise AssertionError(f"maps {' '.join(map(str, args))} exited {proc.returncode}:\n{proc.stderr}")
    return proc


def same_file(a, b):
    return subprocess.run(["h5diff", str(a), str(b)], capture_output=True).returncode == 0


@unittest.skipIf(h5py is None or shutil.which("h5diff") is None, "needs python3-h5py and h5diff (scripts/setup.sh)")
class Interop(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.demos = pathlib.Path(WORK) / "mt10.h5"
        maps("collect", "--set", "mt10", "--demos", "3", "--out", cls.demos)
        # Every collected episode runs to the time limit; one marked terminated shows that end survives too.
        cls.mixed = pathlib.Path(WORK) / "mixed.h5"
        shutil.copy(cls.demos, cls.mixed)
        with h5py.File(cls.mixed, "r+") as f:
            f["data/demo_4"].attrs.modify("episode_end", "terminated")

    def round_trip(self, fmt, source):
        out = pathlib.Path(WORK) / f"{source.stem}.{fmt}"
        back = pathlib.Path(WORK) / f"{source.stem}_{fmt}_back.h5"
        maps("data", "export", "--format", fmt, source, "--out", out)
        maps("data", "import", "--format", fmt, out, "--out", back, "--force")
        self.assertTrue(same_file(source, back), f"{fmt}: the round trip changed the file")
        refused = maps("data", "import", "--format", fmt, out, "--out", back, check=False)
        self.assertEqual(refused.returncode, 1)
        self.assertIn("--force", refused.stderr)
        return out

    def test_round_trips_are_exact(self):
        for fmt in ("d4rl", "minari", "robomimic"):
            for source in (self.demos, self.mixed):
                with self.subTest(format=fmt, source=source.name):
                    self.round_trip(fmt, source)

    def test_d4rl_export_meets_d4rl(self):
        out = self.round_trip("d4rl", self.mixed)
        with h5py.File(out, "r") as f, h5py.File(self.mixed, "r") as src:
            # d4rl/offline_env.py get_dataset: these four keys, N rows; rewards and terminals (N,).
            n = f["observations"].shape[0]
            self.assertEqual(f["observations"].shape, (n, 39))
            self.assertEqual(f["actions"].shape, (n, 4))
            self.assertEqual(f["rewards"].shape, (n,))
            self.assertEqual(f["terminals"].shape, (n,))
            self.assertEqual(f["terminals"].dtype, np.bool_)
            self.assertEqual(f["timeouts"].dtype, np.bool_)
            self.assertEqual(n, int(src["data"].attrs["total"]))
            # sequence_dataset splits where terminals or timeouts are set: one episode per demo, in order.
            ends = np.flatnonzero(f["terminals"][()] | f["timeouts"][()])
            lengths = np.diff(np.concatenate([[-1], ends]))
            self.assertEqual(list(lengths), [int(src[f"data/demo_{i}"].attrs["num_samples"]) for i in range(30)])
            self.assertEqual(int(np.sum(f["terminals"][()])), 1)  # demo_4, the one marked terminated
            self.assertTrue(f["terminals"][ends[4]])
            # next_observations is observations one row on inside each episode.
            obs, nxt = f["observations"][()], f["next_observations"][()]
            inside = np.setdiff1d(np.arange(n - 1), ends)
            np.testing.assert_array_equal(nxt[inside], obs[inside + 1])

    def test_minari_export_meets_minari(self):
        out = self.round_trip("minari", self.mixed)
        meta = json.loads((out / "data" / "metadata.json").read_text())
        # What minari's loader needs (MinariDataset, MinariStorage.read, parse_dataset_id; Minari 0.5).
        self.assertRegex(meta["dataset_id"], r"^([\w\-/]+/)?[\w\-]+-v\d+$")
        self.assertIn(meta["minari_version"], {"0.4.0", "0.4.1", "0.4.2", "0.4.3", "0.5.0", "0.5.1"})
        self.assertEqual(meta["data_format"], "hdf5")
        for key in ("observation_space", "action_space"):
            space = json.loads(meta[key])  # a JSON string inside the JSON (minari/serialization.py)
            self.assertEqual(space["type"], "Box")
            self.assertEqual(len(space["low"]), space["shape"][0])
        with h5py.File(out / "data" / "main_data.hdf5", "r") as f:
            self.assertEqual(sorted(f.keys(), key=lambda k: int(k[8:])), [f"episode_{i}" for i in range(30)])
            self.assertEqual(meta["total_episodes"], 30)
            total = 0
            for i in range(30):
                ep = f[f"episode_{i}"]
                steps = int(ep.attrs["total_steps"])
                total += steps
                self.assertEqual(int(ep.attrs["id"]), i)
                self.assertEqual(ep["observations"].shape, (steps + 1, 39))  # the reset observation to the final
                for key in ("actions", "rewards", "terminations", "truncations"):
                    self.assertEqual(ep[key].shape[0], steps, key)
                self.assertEqual(ep["terminations"].dtype, np.bool_)
                self.assertEqual(bool(ep["terminations"][-1]) + bool(ep["truncations"][-1]), 1)
            self.assertEqual(meta["total_steps"], total)

    def test_deeply_nested_metadata_is_refused(self):
        """Issue 41: a metadata.json nested past 64 levels of arrays and objects is refused naming it (exit 1, as
        the C++ readers refuse such JSON), not a RecursionError traceback; 64 levels still import."""
        exported = pathlib.Path(WORK) / "nested.minari"
        maps("data", "export", "--format", "minari", self.demos, "--out", exported)
        meta = json.loads((exported / "data" / "metadata.json").read_text())
        # The object itself is level 1, so the arrays under one of its keys make levels 2 and on.
        cases = {"levels_64": "[" * 63 + "]" * 63, "levels_65": "[" * 64 + "]" * 64,
                 "levels_100000": None}
        for name, nested in cases.items():
            with self.subTest(name):
                folder = pathlib.Path(WORK) / f"nested_{name}"
                shutil.copytree(exported, folder)
                text = "[" * 100000 + "]" * 100000 if nested is None else \
                    json.dumps(meta)[:-1] + f', "nested": {nested}}}'
                (folder / "data" / "metadata.json").write_text(text)
                out = pathlib.Path(WORK) / f"nested_{name}.h5"
                proc = maps("data", "import", "--format", "minari", folder, "--out", out, check=False)
                self.assertNotIn("Traceback", proc.stderr)
                if name == "levels_64":
                    self.assertEqual(proc.returncode, 0, proc.stderr)
                    self.assertTrue(same_file(self.demos, out), "64 levels: the import changed the file")
                    continue
                self.assertEqual(proc.returncode, 1, proc.stderr)
                self.assertIn(f"{folder / 'data' / 'metadata.json'} nests JSON deeper than 64 levels", proc.stderr)
                self.assertFalse(out.exists())

    def test_damaged_metadata_is_refused_by_name(self):
        """A metadata.json that is not an object, or whose "maps" entry lacks a key or has one of another type, is
        refused naming the file and the key (it was an AttributeError or KeyError traceback)."""
        exported = pathlib.Path(WORK) / "damaged.minari"
        maps("data", "export", "--format", "minari", self.demos, "--out", exported)
        meta = json.loads((exported / "data" / "metadata.json").read_text())
        broken = {"a_list": [1], "maps_empty": dict(meta, maps={}),
                  "train_a_string": dict(meta, maps=dict(meta["maps"], train="0,1")),
                  "task_name_a_number": dict(meta, maps=dict(meta["maps"], task_names=[1]))}
        for name, content in broken.items():
            with self.subTest(name):
                folder = pathlib.Path(WORK) / f"damaged_{name}"
                shutil.copytree(exported, folder)
                (folder / "data" / "metadata.json").write_text(json.dumps(content))
                out = pathlib.Path(WORK) / f"damaged_{name}.h5"
                proc = maps("data", "import", "--format", "minari", folder, "--out", out, check=False)
                self.assertEqual(proc.returncode, 1, proc.stderr)
                self.assertNotIn("Traceback", proc.stderr)
                self.assertIn(str(folder / "data" / "metadata.json"), proc.stderr)
                self.assertFalse(out.exists())

    def test_datasets_made_elsewhere_import(self):
        rng = np.random.default_rng(0)
        # D4RL as its generation scripts write it: float32, bool terminals, no timeouts or next_observations.
        d4rl = pathlib.Path(WORK) / "foreign_d4rl.h5"
        with h5py.File(d4rl, "w") as f:
            f["observations"] = rng.normal(size=(25, 5)).astype(np.float32)
            f["actions"] = rng.uniform(-1, 1, size=(25, 2)).astype(np.float32)
            f["rewards"] = rng.normal(size=25).astype(np.float32)
            f["terminals"] = np.isin(np.arange(25), [9, 19])
        out = pathlib.Path(WORK) / "from_d4rl.h5"
        maps("data", "import", "--format", "d4rl", d4rl, "--out", out, "--task-set", "hopper")
        with h5py.File(out, "r") as f:
            self.assertEqual(int(f["data"].attrs["num_demos"]), 3)  # 10 + 10 + an unfinished 5
            self.assertEqual(f["data/demo_2"].attrs["episode_end"], "truncated")
            self.assertEqual(f["data/demo_0"].attrs["episode_end"], "terminated")
            self.assertEqual(f["data"].attrs["task_set"], "hopper")
        # Minari without this project's metadata.
        minari = pathlib.Path(WORK) / "foreign_minari"
        (minari / "data").mkdir(parents=True)
        (minari / "data" / "metadata.json").write_text(json.dumps(
            {"dataset_id": "test/pointmaze-v1", "total_episodes": 2, "total_steps": 7, "data_format": "hdf5",
             "minari_version": "0.5.1"}))
        with h5py.File(minari / "data" / "main_data.hdf5", "w") as f:
            for i, steps in enumerate((3, 4)):
                ep = f.create_group(f"episode_{i}")
                ep["observations"] = rng.normal(size=(steps + 1, 4))
                ep["actions"] = rng.normal(size=(steps, 2))
                ep["rewards"] = rng.normal(size=steps)
                ep["terminations"] = np.arange(steps) == steps - 1
                ep["truncations"] = np.zeros(steps, dtype=bool)
                ep.attrs["id"], ep.attrs["seed"] = i, 40 + i
        maps("data", "import", "--format", "minari", minari, "--out", pathlib.Path(WORK) / "from_minari.h5")
        # robomimic with two observation keys and its masks.
        robo = pathlib.Path(WORK) / "foreign_robomimic.hdf5"
        with h5py.File(robo, "w") as f:
            data = f.create_group("data")
            data.attrs["env_args"] = json.dumps({"env_name": "Lift", "type": 1, "env_kwargs": {}})
            for i in range(3):
                demo = data.create_group(f"demo_{i + 1}")  # robosuite numbers its demos from 1
                demo.attrs["num_samples"] = 6
                for key, width in (("robot0_eef_pos", 3), ("object", 10)):
                    sequence = rng.normal(size=(7, width))  # 6 steps and the final observation
                    demo[f"obs/{key}"], demo[f"next_obs/{key}"] = sequence[:-1], sequence[1:]
                demo["actions"] = rng.uniform(-1, 1, size=(6, 7))
                demo["rewards"] = np.zeros(6)
                demo["dones"] = np.arange(6) == 5
            f["mask/train"] = np.array([b"demo_1", b"demo_3"], dtype="S")
            f["mask/valid"] = np.array([b"demo_2"], dtype="S")
        out = pathlib.Path(WORK) / "from_robomimic.h5"
        maps("data", "import", "--format", "robomimic", robo, "--out", out, "--obs-keys", "robot0_eef_pos,object")
        with h5py.File(robo, "r") as src, h5py.File(out, "r") as f:
            self.assertEqual(f["data/demo_0/obs/flat"].shape, (6, 13))
            np.testing.assert_array_equal(f["data/demo_0/obs/flat"][:, :3], src["data/demo_1/obs/robot0_eef_pos"][()])
            self.assertEqual([n.decode() for n in f["mask/valid"][()]], ["demo_1"])

    def test_bad_datasets_are_refused_by_name(self):
        no_terminals = pathlib.Path(WORK) / "no_terminals.h5"
        with h5py.File(no_terminals, "w") as f:
            f["observations"], f["actions"], f["rewards"] = np.zeros((4, 2)), np.zeros((4, 1)), np.zeros(4)
        proc = maps("data", "import", "--format", "d4rl", no_terminals, "--out", "x.h5", check=False)
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("missing dataset 'terminals'", proc.stderr)
        self.assertFalse((pathlib.Path(WORK) / "x.h5").exists())
        empty = pathlib.Path(WORK) / "empty_minari"
        empty.mkdir()
        proc = maps("data", "import", "--format", "minari", empty, "--out", "y.h5", check=False)
        self.assertIn("metadata.json", proc.stderr)
        self.assertNotEqual(proc.returncode, 0)
        odd = pathlib.Path(WORK) / "odd_robomimic.hdf5"
        with h5py.File(odd, "w") as f:
            f.create_group("data/trajectory_a")
        proc = maps("data", "import", "--format", "robomimic", odd, "--out", "z.h5", check=False)
        self.assertIn("not named demo_<number>", proc.stderr)
        proc = maps("data", "export", "--format", "d4rl", no_terminals, "--out", "w.h5", check=False)
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("no_terminals.h5", proc.stderr)


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    MAPS = str(pathlib.Path(sys.argv.pop(1)).resolve())
    with tempfile.TemporaryDirectory(prefix="maps-interop-test-") as scratch:
        WORK = scratch
        unittest.main()
