#!/usr/bin/python3
"""A file is read from itself alone (issue 41, item 1): every HDF5 reader refuses an object whose data lives outside
the file it was given (an external link, external raw storage, a virtual dataset, a user-defined link), a soft link
that does not resolve inside the file, a group linked twice and a dataset stored through a filter HDF5 would load
from a plugin, naming the file and the object, writing no output and copying no byte of the file pointed at.
Otherwise a demo file downloaded from the internet could make `maps data export` copy any file of the user's machine
into a file they then share.

Readers: `maps data export` (this project's C++ reader, then experiments/interop/formats.py), `maps data import`
(formats.py, then the C++ reader on the result), `maps train`, the Python module (maps.read_demo_file,
maps.demo_arrays, maps.load_run's data_file) and formats.py run directly. Each bad file is a valid file with one
member replaced, and the same replacement by an ordinary dataset, a resolving soft link or a dataset compressed by
HDF5's own filters is read fine (the controls), so a refusal comes from the check, not from a broken fixture.
Run as: self_contained_test.py path/to/maps (needs python3-h5py)."""
import concurrent.futures
import importlib
import json
import os
import pathlib
import re
import shutil
import subprocess
import sys
import unittest

import h5py
import numpy as np

import maps_tool
from maps_tool import main, run, work

ROOT = pathlib.Path(__file__).resolve().parents[2]
FORMATS = ROOT / "experiments" / "interop" / "formats.py"
PYTHON = "/usr/bin/python3"  # Debian's, with h5py: the one `maps data` runs formats.py with
CRASH_SIGNS = ["Traceback (most recent call", "terminate called", "Segmentation fault", "core dumped"]

# What the files pointed at hold: bytes no reader output could contain by chance, as float64 (finite) wherever a
# reader expects numbers, so that nothing but the check stands between them and an output.
MARKER = b"SECRET-of-the-user's-machine-42!"

# The member replaced in each kind of file: a dataset every reader reads, and the group holding it.
MEMBERS = {"maps": ("data/demo_0/actions", "data/demo_0"), "robomimic": ("data/demo_0/actions", "data/demo_0"),
           "d4rl": ("actions", "infos"), "minari": ("episode_0/actions", "episode_0")}

# kind: (a word the refusal must hold, the objects it may name as the culprit given the member dataset and group).
KINDS = {
    "external_link": ("external link", lambda dataset, group: [dataset]),
    "external_group_link": ("external link", lambda dataset, group: [group]),
    "external_raw": ("external raw", lambda dataset, group: [dataset]),
    "virtual": ("virtual dataset", lambda dataset, group: [dataset]),
    "dangling_soft_link": ("soft link", lambda dataset, group: [dataset]),
    # A walk may meet either end of the loop first.
    "soft_link_loop": ("soft link", lambda dataset, group: [dataset, "loop_partner"]),
    "user_defined_link": ("user-defined link", lambda dataset, group: [dataset]),
    "hard_link_loop": ("linked twice", lambda dataset, group: [f"{group}/loop"]),
    # Not a leak but code: a filter HDF5 does not build in is a shared object it would load from HDF5_PLUGIN_PATH.
    "plugin_filter": ("load from a plugin", lambda dataset, group: [dataset]),
}
# Compressed data is common in files from elsewhere (robomimic's, D4RL's): HDF5's own filters are read.
CONTROLS = ("plain", "resolving_soft_link", "built_in_filters")

# h5py has no call to make a user-defined link, so this child process registers a link class in the libhdf5 h5py
# loaded and makes one through ctypes (HDF5 1.10's H5L_class_t; a C++ test covers such links too). The class
# is registered in the child only: to every reader the link is of a type they do not know, as in a file from
# elsewhere.
MAKE_USER_DEFINED_LINK = r"""
import ctypes, sys, h5py
path, member = sys.argv[1], sys.argv[2]
lib = None
for line in open("/proc/self/maps"):
    name = line.split()[-1]
    if "/libhdf5" in name and "_hl" not in name and ".so" in name:
        lib = ctypes.CDLL(name)
        break
TRAVERSE = ctypes.CFUNCTYPE(ctypes.c_int64, ctypes.c_char_p, ctypes.c_int64, ctypes.c_void_p, ctypes.c_size_t,
                            ctypes.c_int64, ctypes.c_int64)
traverse = TRAVERSE(lambda *args: -1)
class LinkClass(ctypes.Structure):
    _fields_ = [("version", ctypes.c_int), ("id", ctypes.c_int), ("comment", ctypes.c_char_p),
                ("create", ctypes.c_void_p), ("move", ctypes.c_void_p), ("copy", ctypes.c_void_p),
                ("traverse", TRAVERSE), ("delete", ctypes.c_void_p), ("query", ctypes.c_void_p)]
link_class = LinkClass(1, 100, b"maps test", None, None, None, traverse, None, None)
if lib is None or lib.H5Lregister(ctypes.byref(link_class)) < 0:
    sys.exit("H5Lregister failed")
lib.H5Lcreate_ud.argtypes = [ctypes.c_int64, ctypes.c_char_p, ctypes.c_int, ctypes.c_void_p, ctypes.c_size_t,
                             ctypes.c_int64, ctypes.c_int64]
with h5py.File(path, "r+") as f:
    del f[member]
    if lib.H5Lcreate_ud(f.id.id, member.encode(), 100, b"/etc/passwd", 11, 0, 0) < 0:
        sys.exit("H5Lcreate_ud failed")
with h5py.File(path, "r") as f:
    if f.id.links.get_info(member.encode()).type != 100:
        sys.exit("the link made is not of type 100")
"""


def secret_array(shape):
    """float64 values of shape whose bytes are MARKER over and over."""
    count = int(np.prod(shape))
    raw = (MARKER * (count * 8 // len(MARKER) + 1))[:count * 8]
    return np.frombuffer(raw, dtype="<f8").reshape(shape)


def hdf5_of(fmt, path):
    """The HDF5 file of a fixture: the file itself, or a Minari folder's data/main_data.hdf5."""
    return path / "data" / "main_data.hdf5" if fmt == "minari" else path


def object_pattern(obj):
    """obj as an HDF5 path in a message, with or without its leading slash, not part of a longer path."""
    return re.compile(r"(?<![\w/])/?" + re.escape(obj.lstrip("/")) + r"(?![\w/])")


def leaks(folder):
    """Files under folder holding MARKER's bytes."""
    return [p for p in pathlib.Path(folder).rglob("*") if p.is_file() and MARKER[:16] in p.read_bytes()]


class SelfContained(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        fixtures = work("fixtures")
        fixtures.mkdir()
        cls.good = {"maps": fixtures / "good_maps.h5"}
        run("collect", "--set", "mt10", "--demos", "2", "--out", cls.good["maps"], "--threads", "1")
        cls.good["d4rl"] = fixtures / "good_d4rl.h5"
        cls.good["robomimic"] = fixtures / "good_robomimic.hdf5"
        cls.good["minari"] = fixtures / "good_minari"
        for fmt in ("d4rl", "robomimic", "minari"):
            run("data", "export", "--format", fmt, cls.good["maps"], "--out", cls.good[fmt])
        cls.made = {}  # (fmt, kind) -> the fixture; None for a kind this machine cannot make (user-defined links)
        cls.why_not = {}
        for fmt in MEMBERS:
            for kind in (*KINDS, *CONTROLS):
                cls.made[fmt, kind] = cls.make(fmt, kind, fixtures / f"{fmt}_{kind}{cls.good[fmt].suffix}")
        # A finished run, for maps.load_run's data_file.
        cls.run_dir = work("good_run")
        run("train", "--config", cls.train_config("good_run.json", cls.good["maps"]), "--out", cls.run_dir)

    @classmethod
    def make(cls, fmt, kind, out):
        """A copy of the good fixture of fmt with its member replaced by an object of this kind."""
        if fmt == "minari":
            shutil.copytree(cls.good[fmt], out)
        else:
            shutil.copy(cls.good[fmt], out)
        dataset, group = MEMBERS[fmt]
        path = hdf5_of(fmt, out)
        secret_h5 = out.with_name(out.name + ".secret.h5")
        secret_raw = out.with_name(out.name + ".secret.bin")
        if kind == "user_defined_link":
            proc = subprocess.run([PYTHON, "-c", MAKE_USER_DEFINED_LINK, str(path), dataset],
                                  capture_output=True, text=True)
            if proc.returncode != 0:
                cls.why_not[fmt, kind] = f"cannot make a user-defined link here: {proc.stderr.strip()}"
                return None
            return out
        with h5py.File(path, "r+") as f:
            original = f[dataset][()]
            shape = original.shape
            # Absolute paths: the library would find the files pointed at from any folder a reader runs in.
            if kind == "external_link":
                with h5py.File(secret_h5, "w") as s:
                    s["stolen"] = secret_array(shape)
                del f[dataset]
                f[dataset] = h5py.ExternalLink(str(secret_h5), "/stolen")
            elif kind == "external_group_link":
                with h5py.File(secret_h5, "w") as s:
                    f.copy(f[group], s, name="stolen")
                    s["stolen"].visititems(lambda name, obj: obj.__setitem__(..., secret_array(obj.shape))
                                           if isinstance(obj, h5py.Dataset) and obj.dtype == np.float64 else None)
                del f[group]
                f[group] = h5py.ExternalLink(str(secret_h5), "/stolen")
            elif kind == "external_raw":
                secret_raw.write_bytes(secret_array(shape).tobytes())
                del f[dataset]
                f.create_dataset(dataset, shape=shape, dtype="<f8",
                                 external=[(str(secret_raw), 0, h5py.h5f.UNLIMITED)])
            elif kind == "virtual":
                with h5py.File(secret_h5, "w") as s:
                    s["stolen"] = secret_array(shape)
                layout = h5py.VirtualLayout(shape=shape, dtype="<f8")
                layout[...] = h5py.VirtualSource(str(secret_h5), "stolen", shape=shape)
                del f[dataset]
                f.create_virtual_dataset(dataset, layout)
            elif kind == "dangling_soft_link":
                del f[dataset]
                f[dataset] = h5py.SoftLink("/nowhere/actions")
            elif kind == "soft_link_loop":
                del f[dataset]
                f[dataset] = h5py.SoftLink("/loop_partner")
                f["loop_partner"] = h5py.SoftLink("/" + dataset)
            elif kind == "hard_link_loop":
                f[f"{group}/loop"] = f["/"]
            elif kind == "plain":  # the member rewritten as an ordinary dataset: the replacing keeps a file valid
                del f[dataset]
                f[dataset] = original
            elif kind == "plugin_filter":  # 32001, Blosc's id; optional, so that it can be written without Blosc
                del f[dataset]
                f.create_dataset(dataset, data=original, chunks=True, compression=32001, allow_unknown_filter=True)
            elif kind == "built_in_filters":
                del f[dataset]
                f.create_dataset(dataset, data=original, chunks=True, compression="gzip", shuffle=True,
                                 fletcher32=True)
            elif kind == "resolving_soft_link":  # soft links inside the file are fine
                f.move(dataset, "/elsewhere/actions")
                f[dataset] = h5py.SoftLink("/elsewhere/actions")
            else:
                raise ValueError(kind)
        return out

    @staticmethod
    def train_config(name, demo_file):
        path = work(name)
        path.write_text(json.dumps({
            "method": "mt_bc", "data": {"file": str(demo_file), "demos_per_task": 1}, "baselines": {"hidden": [4]},
            "train": {"steps": 10, "states_per_task": 4, "validate_every": 10, "checkpoint_every": 10,
                      "validation_states_per_task": 4},
            "eval": {"episodes": 1, "threads": 1}}))
        return path

    # ----- helpers -------------------------------------------------------------------------------------------------

    def cases(self, fmt):
        """(kind, fixture) of every bad fixture of fmt; a kind that could not be made here is a skipped subtest."""
        for kind in KINDS:
            fixture = self.made[fmt, kind]
            if fixture is None:
                with self.subTest(format=fmt, kind=kind):
                    self.skipTest(self.why_not[fmt, kind])
                continue
            yield kind, fixture

    def assert_names(self, text, fmt, kind, fixture, where):
        """text names the file (a Minari folder's HDF5 file), the culprit object and its kind, and is no crash."""
        word, culprits = KINDS[kind]
        paths = culprits(*MEMBERS[fmt])
        self.assertIn(str(hdf5_of(fmt, fixture)), text, f"{where}: the file is not named:\n{text}")
        self.assertTrue(any(object_pattern(p).search(text) for p in paths),
                        f"{where}: none of {paths} is named:\n{text}")
        self.assertIn(word, text, f"{where}: does not say '{word}':\n{text}")
        for sign in CRASH_SIGNS:
            self.assertNotIn(sign, text, where)

    def out_folder(self, name):
        folder = work("out", name)
        folder.mkdir(parents=True)
        return folder

    def run_commands(self, commands):
        """Runs the commands ([program, args...], in WORK) side by side, one per core, to keep the test short; their
        CompletedProcesses in order."""
        def one(command):
            return subprocess.run(list(map(str, command)), cwd=maps_tool.WORK, capture_output=True, text=True,
                                  timeout=300)
        with concurrent.futures.ThreadPoolExecutor(max_workers=max(2, os.cpu_count() or 1)) as pool:
            return list(pool.map(one, commands))

    def expect_refusals(self, jobs, status=None):
        """jobs: (fmt, kind, fixture, command, out folder). Each exits non-zero (status, when given) naming the file
        and the object, and leaves its out folder empty."""
        procs = self.run_commands([job[3] for job in jobs])
        for (fmt, kind, fixture, command, out), proc in zip(jobs, procs):
            where = " ".join(map(str, command[1:]))
            with self.subTest(command=" ".join(map(str, command[1:3])), format=fmt, kind=kind):
                self.assertNotEqual(proc.returncode, 0, f"{where} exited 0:\n{proc.stdout}")
                self.assertGreater(proc.returncode, 0, f"{where} died of signal {-proc.returncode}")
                if status is not None:
                    self.assertEqual(proc.returncode, status, where)
                self.assertNotIn(MARKER.decode(), proc.stdout + proc.stderr)
                self.assert_names(proc.stderr, fmt, kind, fixture, where)
                self.assertEqual(sorted(p.name for p in out.iterdir()), [], f"{where} left files behind")

    def maps_module(self):
        package = pathlib.Path(maps_tool.MAPS).parents[1] / "python"
        if not (package / "maps" / "__init__.py").exists():
            # The sanitizer builds make no Python module (CMakeLists.txt): the Release pass tests it.
            self.skipTest(f"no Python module beside {maps_tool.MAPS} (a build without MAPS_BUILD_PYTHON)")
        if str(package) not in sys.path:
            sys.path.insert(0, str(package))
        return importlib.import_module("maps")

    # ----- the readers refuse ------------------------------------------------------------------------------------

    def test_formats_py_export_refuses(self):
        jobs = []
        for kind, fixture in self.cases("maps"):
            for target in ("d4rl", "robomimic", "minari"):
                out = self.out_folder(f"formats_export_{kind}_{target}")
                jobs.append(("maps", kind, fixture,
                             [PYTHON, FORMATS, "export", "--format", target, fixture, out / f"x.{target}"], out))
        self.expect_refusals(jobs, status=1)

    def test_formats_py_import_refuses(self):
        jobs = []
        for fmt in ("d4rl", "robomimic", "minari", "maps"):
            for kind, fixture in self.cases(fmt):
                out = self.out_folder(f"formats_import_{fmt}_{kind}")
                as_format = "robomimic" if fmt == "maps" else fmt  # a demo file is a robomimic file
                jobs.append((fmt, kind, fixture,
                             [PYTHON, FORMATS, "import", "--format", as_format, fixture, out / "x.h5"], out))
        self.expect_refusals(jobs, status=1)

    def test_maps_data_import_refuses(self):
        jobs = []
        for fmt in ("d4rl", "robomimic", "minari"):
            for kind, fixture in self.cases(fmt):
                out = self.out_folder(f"import_{fmt}_{kind}")
                jobs.append((fmt, kind, fixture,
                             [maps_tool.MAPS, "data", "import", "--format", fmt, fixture, "--out", out / "x.h5"], out))
        self.expect_refusals(jobs)

    def test_maps_data_export_refuses(self):
        jobs = []
        for kind, fixture in self.cases("maps"):
            for target in ("d4rl", "robomimic", "minari"):
                out = self.out_folder(f"export_{kind}_{target}")
                jobs.append(("maps", kind, fixture, [maps_tool.MAPS, "data", "export", "--format", target, fixture,
                                                     "--out", out / f"x.{target}"], out))
        self.expect_refusals(jobs)

    def test_maps_train_refuses(self):
        procs, runs = [], []
        for kind, fixture in self.cases("maps"):
            run_dir = work("out", f"train_{kind}")
            config = self.train_config(f"train_{kind}.json", fixture)
            runs.append((kind, fixture, run_dir))
            procs.append([maps_tool.MAPS, "train", "--config", config, "--out", run_dir])
        for (kind, fixture, run_dir), proc in zip(runs, self.run_commands(procs)):
            with self.subTest(kind=kind):
                self.assertNotEqual(proc.returncode, 0, f"train on {fixture.name} exited 0")
                self.assert_names(proc.stderr, "maps", kind, fixture, f"train on {fixture.name}")
                # A run folder may record the error (train.log); it must hold no checkpoint and nothing read.
                if run_dir.exists():
                    self.assertEqual(list(run_dir.rglob("*.ckpt")), [])
                    self.assertEqual(leaks(run_dir), [])

    def test_python_module_refuses(self):
        maps = self.maps_module()
        for kind, fixture in self.cases("maps"):
            readers = {"read_demo_file": lambda: maps.read_demo_file(str(fixture)),
                       "demo_arrays": lambda: maps.demo_arrays(str(fixture)),
                       "load_run": lambda: maps.load_run(self.run_dir, data_file=str(fixture))}
            for name, read in readers.items():
                with self.subTest(reader=name, kind=kind):
                    with self.assertRaises(Exception) as caught:
                        read()
                    self.assert_names(str(caught.exception), "maps", kind, fixture, f"maps.{name}")
                    self.assertNotIn(MARKER.decode(), str(caught.exception))

    def test_without_the_check_the_secret_would_leak(self):
        """The threat is real and the leak scan sees it: formats.py with its check switched off copies the bytes
        of the files pointed at into the export."""
        sys.path.insert(0, str(FORMATS.parent))
        try:
            formats = importlib.import_module("formats")
        finally:
            sys.path.remove(str(FORMATS.parent))
        check = formats.check_self_contained
        formats.check_self_contained = lambda f, path: None
        try:
            for kind in ("external_link", "external_raw", "virtual"):
                with self.subTest(kind=kind):
                    out = self.out_folder(f"unchecked_{kind}")
                    self.assertEqual(formats.main(["export", "--format", "d4rl", str(self.made["maps", kind]),
                                                   str(out / "x.h5")]), 0)
                    self.assertEqual(leaks(out), [out / "x.h5"])
        finally:
            formats.check_self_contained = check

    # ----- the controls: the same files without the bad object are read -------------------------------------------

    def test_controls_are_read(self):
        jobs = []
        for fmt in MEMBERS:
            for kind in CONTROLS:
                fixture = self.made[fmt, kind]
                out = self.out_folder(f"control_{fmt}_{kind}")
                as_format = "robomimic" if fmt == "maps" else fmt
                jobs.append(([PYTHON, FORMATS, "import", "--format", as_format, fixture, out / "f.h5"], (fmt, kind)))
                if fmt in ("d4rl", "robomimic", "minari"):
                    jobs.append(([maps_tool.MAPS, "data", "import", "--format", fmt, fixture, "--out", out / "m.h5"],
                                 (fmt, kind)))
                if fmt == "maps":
                    for target in ("d4rl", "robomimic", "minari"):
                        jobs.append(([PYTHON, FORMATS, "export", "--format", target, fixture, out / f"f.{target}"],
                                     (fmt, kind)))
                        jobs.append(([maps_tool.MAPS, "data", "export", "--format", target, fixture,
                                      "--out", out / f"m.{target}"], (fmt, kind)))
                    jobs.append(([maps_tool.MAPS, "train", "--config",
                                  self.train_config(f"control_{kind}.json", fixture), "--out", out / "run"],
                                 (fmt, kind)))
        for (command, (fmt, kind)), proc in zip(jobs, self.run_commands([job[0] for job in jobs])):
            with self.subTest(command=" ".join(map(str, command[1:3])), format=fmt, kind=kind):
                self.assertEqual(proc.returncode, 0, f"{' '.join(map(str, command))}:\n{proc.stderr}")
        maps = self.maps_module()
        for kind in CONTROLS:
            fixture = self.made["maps", kind]
            with self.subTest(reader="python module", kind=kind):
                expected = maps.demo_arrays(str(self.good["maps"]))
                got = maps.demo_arrays(str(fixture))
                np.testing.assert_array_equal(got["actions"], expected["actions"])
                self.assertEqual(len(maps.read_demo_file(str(fixture))),
                                 len(maps.read_demo_file(str(self.good["maps"]))))
                maps.load_run(self.run_dir, data_file=str(fixture))


if __name__ == "__main__":
    main(__file__)
