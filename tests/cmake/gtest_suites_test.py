#!/usr/bin/python3
"""Tests of cmake/GTestSuites.cmake, which registers a GoogleTest binary's tests with ctest one suite per process
(MAPS_CTEST_PER_SUITE, CI's sanitizer pass): on listings a fake test binary prints, every enabled case is covered by
exactly one registered test (typed and value-parameterized suites, printed parameters holding ';', '[' or '#',
DISABLED_ cases and suites, gtest_main's greeting), ISOLATE suites get a test per case, and a binary that fails to
list, lists nothing or lacks an ISOLATE suite is refused by name. Run by ctest as: gtest_suites_test.py CMAKE."""
import pathlib
import re
import subprocess
import sys
import tempfile
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "cmake" / "GTestSuites.cmake"
CMAKE = "cmake"

LISTING = """Running main() from ./googletest/src/gtest_main.cc
Plain.
  First
  Second
  DISABLED_Third
Typed/0.  # TypeParam = std::map<int, float>
  Works
Typed/1.  # TypeParam = a;b[c
  Works
Prefix/Param.
  Case/0  # GetParam() = [1; 2
  Case/1  # GetParam() = ]] # not a comment end
DISABLED_Off.
  Anything
Plugins.
  LoadsOne
  LoadsTwo
"""


def fake_binary(folder, listing, status=0):
    """A shell script that answers --gtest_list_tests with `listing` and exits with `status`."""
    path = pathlib.Path(folder) / "fake_tests"
    path.write_text(f"#!/bin/sh\ncat <<'LISTING'\n{listing}LISTING\nexit {status}\n")
    path.chmod(0o755)
    return path


def generate(folder, binary, isolated=""):
    out = pathlib.Path(folder) / "out.cmake"
    proc = subprocess.run([CMAKE, f"-DTEST_EXECUTABLE={binary}", f"-DCTEST_FILE={out}", "-DTEST_PREFIX=layer.",
                           "-DTEST_LABELS=layer", f"-DWORKING_DIR={folder}", f"-DISOLATED={isolated}", "-P",
                           str(SCRIPT)], capture_output=True, text=True)
    return proc, (out.read_text() if out.exists() else "")


def said(proc):
    """stderr with CMake's line wrapping undone."""
    return " ".join(proc.stderr.split())


def registered(script):
    """{test name: gtest filter} from the add_test lines, and the properties of each test."""
    tests = dict(re.findall(r"add_test\(\[==\[(.*?)\]==\] \[==\[.*?\]==\] \[==\[--gtest_filter=(.*?)\]==\]\)", script))
    properties = dict(re.findall(r"set_tests_properties\(\[==\[(.*?)\]==\] PROPERTIES (.*)\)", script))
    return tests, properties


class GTestSuites(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = self.tmp.name

    def tearDown(self):
        self.tmp.cleanup()

    def test_every_enabled_case_is_run_by_exactly_one_test(self):
        proc, script = generate(self.dir, fake_binary(self.dir, LISTING), isolated="Plugins")
        self.assertEqual(proc.returncode, 0, proc.stderr)
        tests, properties = registered(script)
        self.assertEqual(tests, {
            "layer.Plain": "Plain.*", "layer.Typed/0": "Typed/0.*", "layer.Typed/1": "Typed/1.*",
            "layer.Prefix/Param": "Prefix/Param.*",
            "layer.Plugins.LoadsOne": "Plugins.LoadsOne", "layer.Plugins.LoadsTwo": "Plugins.LoadsTwo"})
        for name in tests:
            self.assertIn(f"WORKING_DIRECTORY [==[{self.dir}]==] LABELS [==[layer]==] TIMEOUT 900", properties[name])
            self.assertNotIn("SKIP_REGULAR_EXPRESSION", properties[name])  # a skipped case must not hide a failure
        # The written script is one ctest can read: every line an add_test or set_tests_properties call.
        self.assertTrue(all(line.startswith(("add_test(", "set_tests_properties(")) for line in script.splitlines()))

    def test_the_filters_select_the_listed_cases(self):
        """A filter Suite.* matches only that suite's cases (not a suite whose name starts the same)."""
        listing = "Net.\n  A\nNetwork.\n  B\n"
        proc, script = generate(self.dir, fake_binary(self.dir, listing))
        self.assertEqual(proc.returncode, 0, proc.stderr)
        tests, _ = registered(script)
        self.assertEqual(tests, {"layer.Net": "Net.*", "layer.Network": "Network.*"})

    def test_a_binary_that_cannot_list_is_named(self):
        proc, _ = generate(self.dir, fake_binary(self.dir, "Plain.\n  First\n", status=3))
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("fake_tests --gtest_list_tests exited 3", said(proc))

    def test_a_binary_listing_no_enabled_test_is_refused(self):
        proc, _ = generate(self.dir, fake_binary(self.dir, "DISABLED_Off.\n  A\nPlain.\n  DISABLED_B\n"))
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("lists no test", said(proc))

    def test_an_unexpected_line_is_refused(self):
        proc, _ = generate(self.dir, fake_binary(self.dir, "Plain.\n  First\nnot a suite line\n"))
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("unexpected line 'not a suite line'", said(proc))

    def test_an_isolated_suite_the_binary_lacks_is_refused(self):
        proc, script = generate(self.dir, fake_binary(self.dir, LISTING), isolated="Plugin")
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("has no test suite 'Plugin' to isolate", said(proc))
        self.assertEqual(script, "")

    def test_a_missing_argument_is_named(self):
        proc = subprocess.run([CMAKE, "-DTEST_EXECUTABLE=x", "-P", str(SCRIPT)], capture_output=True, text=True)
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("CTEST_FILE is not set", said(proc))


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    CMAKE = sys.argv.pop(1)
    unittest.main()
