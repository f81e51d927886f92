#!/usr/bin/python3
"""A demo file written by `maps collect`, read with h5py the way robomimic reads its datasets (issue 16, item 1).
Each check names the robomimic code it stands for (ARISE-Initiative/robomimic: robomimic/utils/dataset.py's
SequenceDataset, robomimic/utils/file_utils.py, robomimic/scripts/get_dataset_info.py and split_train_val.py); the
facts are in docs/interop.md. Run by ctest as: robomimic_layout_test.py path/to/maps (needs python3-h5py)."""
import json
import pathlib
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


@unittest.skipIf(h5py is None, "h5py not found (bash scripts/setup.sh installs python3-h5py)")
class RobomimicLayout(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.path = pathlib.Path(WORK) / "mt10.h5"
        subprocess.run([MAPS, "collect", "--set", "mt10", "--demos", "3", "--out", cls.path], check=True,
                       capture_output=True)
        cls.file = h5py.File(cls.path, "r")

    @classmethod
    def tearDownClass(cls):
        cls.file.close()

    def demos(self):
        # SequenceDataset.load_demo_info: every child of /data, sorted by the integer after "demo_".
        names = list(self.file["data"].keys())
        return [names[i] for i in np.argsort([int(name[5:]) for name in names])]

    def test_env_args_and_total(self):
        # file_utils.get_env_metadata_from_dataset: json.loads(f["data"].attrs["env_args"]), then env_name, type
        # and env_kwargs; get_dataset_info.py prints data.attrs["total"].
        env_meta = json.loads(self.file["data"].attrs["env_args"])
        self.assertEqual(env_meta["env_name"], "maps/mt10")
        self.assertEqual(env_meta["type"], 2)  # robomimic's EnvType.GYM_TYPE
        self.assertEqual(len(env_meta["env_kwargs"]["task_names"]), 10)
        total = sum(int(self.file[f"data/{d}"].attrs["num_samples"]) for d in self.demos())
        self.assertEqual(int(self.file["data"].attrs["total"]), total)

    def test_every_demo_as_sequence_dataset_reads_it(self):
        self.assertEqual(len(self.demos()), 30)
        for demo in self.demos():
            group = self.file[f"data/{demo}"]
            n = int(group.attrs["num_samples"])  # the only source of a demo's length in SequenceDataset
            self.assertGreaterEqual(n, 1)
            obs, next_obs = group["obs/flat"][()], group["next_obs/flat"][()]  # obs/<key>, next_obs/<key>
            self.assertEqual(obs.shape, (n, 39))
            self.assertEqual(next_obs.shape, (n, 39))
            np.testing.assert_array_equal(next_obs[:-1], obs[1:])
            for key, shape in (("actions", (n, 4)), ("rewards", (n,)), ("dones", (n,))):
                self.assertEqual(group[key].shape, shape, f"{demo}/{key}")
                group[key][()].astype("float32")  # its cache casts every dataset key to float32
            self.assertEqual(group["dones"][-1], 1)
            self.assertTrue(np.all(group["dones"][:-1] == 0))
            # get_dataset_info.py raises unless every action is in [-1, 1].
            actions = group["actions"][()]
            self.assertTrue(np.all(actions >= -1.0) and np.all(actions <= 1.0), demo)
            self.assertIn(group.attrs["episode_end"], ("terminated", "truncated"))

    def test_masks_are_byte_strings_naming_demos(self):
        # SequenceDataset: [elem.decode("utf-8") for elem in np.array(f["mask/<key>"][:])]; split_train_val.py
        # writes np.array(names, dtype="S").
        seen = []
        for key in ("train", "valid"):
            elements = np.array(self.file[f"mask/{key}"][:])
            self.assertEqual(elements.dtype.kind, "S", key)
            names = [elem.decode("utf-8") for elem in elements]
            for name in names:
                self.assertIn(name, self.file["data"])
            seen += names
        self.assertEqual(sorted(seen), sorted(self.demos()))
        self.assertEqual(len(seen), len(set(seen)))


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    MAPS = str(pathlib.Path(sys.argv.pop(1)).resolve())
    with tempfile.TemporaryDirectory(prefix="maps-robomimic-test-") as scratch:
        WORK = scratch
        unittest.main()
