#!/usr/bin/python3
"""Bad input anywhere (issue 15, item 7): every `maps` subcommand given wrong CLI values, missing, damaged or
foreign files and configs must exit non-zero with a message on stderr that names the input and what was
expected; never a crash, an uncaught exception, a Python traceback or silence. Issue 41: every numeric option
is swept with the edge values of its type and documented range. Run by ctest as: bad_input_test.py path/to/maps."""
import json
import math
import os
import pathlib
import re
import subprocess
import sys
import tempfile
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]
MAPS = None  # set from argv
WORK = None  # scratch folder

CRASH_SIGNS = ["terminate called", "Segmentation fault", "Aborted", "core dumped", "Traceback (most recent call",
               "AddressSanitizer", "runtime error:"]

# No such option: the tool refuses it only after every value before it is parsed and checked, so a value that
# gets that far was accepted, and nothing ran.
STOP = "--bad-input-sweep-stop"
REFUSE, ACCEPT = "refused", "accepted"
# MAPS_TEST_QUICK=1 (CI's sanitizer pass, where each start of the tool costs some 0.15 s): the sweep gives every
# value to the first option of each type and range only; the options sharing it get the values that tell whether
# their own range was wired (the bounds and one past each, a word, a billion) and one accepted value.
QUICK = os.environ.get("MAPS_TEST_QUICK") == "1"
# The edge values of every numeric type: 2^31 and 2^32 + 1 (which wraps to 1 in a 32-bit int) past int, 2^63 past
# int64, 2^64 past uint64, a double's largest decade and past it, NaN, infinities, a fraction, a word, nothing.
EDGE_VALUES = ["0", "-1", "1", "1e308", "1000000000", "2147483648", "4294967297", "9223372036854775808",
               "18446744073709551616", "99999999999999999999999", "2.5", "nan", "inf", "-inf", "1e400", "abc", ""]
# An INT whose --help shows no upper bound is a C++ int; the tool's 64-bit ones all show their range, because
# CLI11 2.1 saturates a number past int64 instead of refusing it.
TYPE_RANGE = {"INT": (-2**31, 2**31 - 1), "INT64": (-2**63, 2**63 - 1), "UINT": (0, 2**64 - 1)}


def subcommands(prefix=()):
    """{command: its --help} for every subcommand under prefix, read from the Subcommands list of each --help."""
    usage = subprocess.run([MAPS, *prefix, "--help"], capture_output=True, text=True).stdout
    found = {prefix: usage} if prefix else {}
    if "Subcommands:" in usage:
        for name in re.findall(r"^  ([a-z][\w-]*)(?:  |$)", usage.split("Subcommands:", 1)[1], re.M):
            found.update(subcommands((*prefix, name)))
    return found


def numeric_options(usage):
    """(option, INT|UINT|FLOAT, check or None) of every numeric option in a --help text."""
    pattern = re.compile(r"^\s+(--[\w-]+) (INT|UINT|FLOAT)(?::([A-Z0-9_]+(?: in \[[^\]]*\])?))?", re.M)
    return pattern.findall(usage)


def number(text):
    return int(text) if re.fullmatch(r"-?\d+", text) else float(text)


def documented_range(check):
    """(low, high, low included) of a check as --help names it; None for one the sweep does not know."""
    if not check:
        return (-math.inf, math.inf, True)
    if check in ("POSITIVE", "NONNEGATIVE"):
        return (0, math.inf, check == "NONNEGATIVE")
    if check == "UINT64":
        return TYPE_RANGE["UINT"] + (True,)
    bounds = re.fullmatch(r"(?:INT|FLOAT) in \[(\S+) - (\S+)\]", check)
    return (number(bounds[1]), number(bounds[2]), True) if bounds else None


def edge_values(check):
    """EDGE_VALUES and the documented range's bounds with one past each."""
    low, high, _ = documented_range(check)
    bounds = [str(x) for x in (low, low - 1, high, high + 1) if math.isfinite(x)]
    return list(dict.fromkeys(EDGE_VALUES + bounds))


def verdict(kind, check, text):
    """REFUSE for a value outside the option's type or documented range, ACCEPT inside both."""
    low, high, low_included = documented_range(check)
    if kind == "INT" and math.isfinite(high):
        kind = "INT64"
    if kind == "FLOAT":
        try:
            value = float(text)
        except ValueError:
            return REFUSE
        if not math.isfinite(value):
            return REFUSE
    elif re.fullmatch(r"-?\d+", text):
        value = int(text)
        if not TYPE_RANGE[kind][0] <= value <= TYPE_RANGE[kind][1]:
            return REFUSE
    else:
        return REFUSE
    if value < low or value > high or (value == low and not low_included):
        return REFUSE
    return ACCEPT


def wiring_values(check, values):
    """Of values, those that tell whether an option was given its own range (QUICK's sweep of a shared type)."""
    low, high, _ = documented_range(check)
    telling = {str(x) for x in (low, low - 1, high, high + 1) if math.isfinite(x)} | {"abc", "1000000000"}
    return [value for value in values if value in telling]


def without(args, option):
    """args without option and its value (the sweep gives it instead)."""
    args = list(args)
    while option in args:
        at = args.index(option)
        del args[at:at + 2]
    return args


class BadInputTest(unittest.TestCase):
    def expect_refused(self, args, *needles, timeout=300):
        proc = subprocess.run([MAPS, *map(str, args)], cwd=WORK, capture_output=True, text=True, timeout=timeout)
        where = f"maps {' '.join(map(str, args))}"
        self.assertNotEqual(proc.returncode, 0, f"{where} exited 0:\n{proc.stdout}")
        self.assertGreater(proc.returncode, 0, f"{where} died of signal {-proc.returncode}")
        self.assertTrue(proc.stderr.strip(), f"{where}: nothing on stderr")
        for sign in CRASH_SIGNS:
            self.assertNotIn(sign, proc.stderr, where)
        for needle in needles:
            self.assertIn(needle, proc.stderr, where)
        self.last_stdout = proc.stdout
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
        self.expect_refused(["train", "--config", self.config("ok.json"), "--out", "r", "--threads", "-1"],
                            "--threads")
        self.expect_refused(["bench", "step", "--set", "nope"], "nope")
        self.expect_refused(["schema", "no-such-kind"], "no-such-kind")
        self.expect_refused(["expert-eval", "--task", "gravity/9.9"], "gravity/9.9")
        self.expect_refused(["render", "--task", "mt10/no-such-task", "--out", "x.png"], "mt10/no-such-task")
        self.expect_refused(["suite", "run", ROOT / "experiments/suites/tiny.json", "--out", "o", "--shard", "3/2"],
                            "3/2")

    def test_every_numeric_option_refuses_bad_values(self):
        """Every INT, UINT and FLOAT option of every subcommand (subcommands and options read from --help, so a new
        one is swept too) given the edge values of its type and documented range. A value outside them is refused
        naming the option, before any work starts (the base arguments are valid, so an accepted value would run).
        A value inside them must get through parsing: it is tried with an unknown option after it, which the tool
        refuses only once every value is parsed and checked, so nothing runs."""
        config = self.config("sweep.json")
        run_dir = pathlib.Path(WORK) / "sweep_run"
        run_dir.mkdir(exist_ok=True)
        tiny = ROOT / "experiments/suites/tiny.json"
        # Valid arguments for the commands with numeric options; one without an entry is swept with none (its
        # missing required options are reported after the values are checked).
        bases = {
            ("train-expert",): ["--task", "gravity/1.0", "--out", "sweep_te"],
            ("collect",): ["--set", "mt10", "--out", "sweep.h5"],
            ("render",): ["--task", "gravity/1.0", "--out", "s.png"],
            ("expert-eval",): ["--task", "gravity/1.0"], ("train",): ["--config", config, "--out", "sweep_train"],
            ("transfer",): ["--run", run_dir, "--task", "gravity/0.5", "--demos", "2", "--out", "sweep_transfer"],
            ("eval",): ["--run", run_dir], ("suite", "run"): [tiny, "--out", "sweep_suite"],
            ("suite", "plan"): [tiny], ("suite", "prepare"): [tiny], ("suite", "calibrate"): ["--work", "sweep_cal"]}
        commands = subcommands()
        self.assertIn(("schema",), commands, "maps schema is not among the subcommands --help lists")
        swept, tried, refused, accepted = 0, 0, 0, 0
        covered = set()  # (command, option, value) tried as must-refuse
        swept_whole = set()  # (kind, check) given every edge value
        for command, usage in commands.items():
            for option, kind, check in numeric_options(usage):
                self.assertIsNotNone(documented_range(check), f"maps {' '.join(command)} {option}: the sweep does "
                                     f"not know the range of '{check}'; teach documented_range() it")
                base = without(bases.get(command, []), option)
                values = edge_values(check)
                if QUICK and (kind, check) in swept_whole:
                    first_accepted = [value for value in values if verdict(kind, check, value) == ACCEPT][:1]
                    values = list(dict.fromkeys(wiring_values(check, values) + first_accepted))
                swept_whole.add((kind, check))
                for value in values:
                    expected = verdict(kind, check, value)
                    args = [*command, *base, option, value]
                    tried += 1
                    if expected == REFUSE:
                        covered.add((command, option, value))
                    with self.subTest(command=" ".join(command), option=option, value=value, expected=expected):
                        if expected == REFUSE:
                            self.expect_refused(args, option, timeout=30)
                            refused += 1
                            continue
                        stderr = self.expect_refused([*args, STOP], timeout=30)
                        self.assertTrue(STOP in stderr or (command not in bases and " is required" in stderr),
                                        f"maps {' '.join(map(str, args))} refused a value inside the type and range "
                                        f"--help gives ({kind}:{check}):\n{stderr}")
                        accepted += 1
                swept += 1
        print(f"\nbad_input sweep: {swept} options, {tried} values tried, {refused} refused, {accepted} accepted "
              f"({len(commands)} subcommands{', MAPS_TEST_QUICK' if QUICK else ''})", file=sys.stderr)
        self.assertGreaterEqual(swept, 40, "fewer numeric options than the tool has: is the --help format changed?")
        # A billion threads ended in std::terminate; 257 is one past the bound.
        with_threads = {command for command, option, _ in covered if option == "--threads"}
        self.assertGreaterEqual(len(with_threads), 8, "fewer commands with --threads than the tool has")
        for command in with_threads:
            for value in ("1000000000", "257"):
                self.assertTrue((command, "--threads", value) in covered,
                                f"maps {' '.join(command)} --threads {value} not tried as a value to refuse")

    def test_unwritable_outputs_are_refused_before_any_work(self):
        """An output under a file (a folder that cannot exist) or naming a folder as a file is refused at once,
        not after the collection or evaluation it would have held."""
        blocker = self.write("a_file", "not a folder\n")
        config = self.config("out.json")
        cases = [
            (["collect", "--set", "mt10", "--demos", "2", "--out", f"{blocker}/demos.h5"], "--out"),
            (["collect", "--set", "mt10", "--demos", "2", "--out", WORK], "is a folder"),
            (["expert-eval", "--task", "gravity/1.0", "--episodes", "3", "--out", f"{blocker}/t.json"], "--out"),
            (["render", "--task", "gravity/1.0", "--out", f"{blocker}/frame.png"], "--out"),
            (["train", "--config", config, "--out", f"{blocker}/run"], "--out"),
            (["train-expert", "--task", "gravity/1.0", "--out", f"{blocker}/expert"], "--out")]
        for args, needle in cases:
            with self.subTest(command=args[0]):
                self.expect_refused(args, needle, "a_file" if needle != "is a folder" else WORK, timeout=30)
                self.assertNotIn("[1/", self.last_stdout, "work started before the output was checked")

    def test_an_unknown_float32_kernel_in_the_environment_is_refused_by_name(self):
        for value, needle in (("sse", 'MAPS_F32_KERNEL: expected "avx512", "avx2" or "eigen", got "sse"'),
                              ("AVX2", 'got "AVX2"')):
            proc = subprocess.run([MAPS, "bench", "step", "--set", "mt10", "--seconds", "0.1"], cwd=WORK,
                                  capture_output=True, text=True, timeout=120, env=dict(os.environ, MAPS_F32_KERNEL=value))
            self.assertEqual(proc.returncode, 1, proc.stderr)
            self.assertIn(needle, proc.stderr)
            for sign in CRASH_SIGNS:
                self.assertNotIn(sign, proc.stderr)
        # --version still answers, saying the kernel is not settled.
        proc = subprocess.run([MAPS, "--version"], capture_output=True, text=True, timeout=60,
                              env=dict(os.environ, MAPS_F32_KERNEL="sse"))
        self.assertEqual(proc.returncode, 0, proc.stderr)
        self.assertIn("float32 GEMM kernel (none: MAPS_F32_KERNEL", proc.stdout)

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
        # The trainer's resume state in its place (a copy of last.ckpt) is named for what it is.
        (damaged / "best.ckpt").write_bytes((damaged / "last.ckpt").read_bytes())
        self.expect_refused(["eval", "--run", damaged], "is a training state (as last.ckpt is")
        (damaged / "best.ckpt").write_bytes(whole)
        (damaged / "config.json").write_text("{")
        self.expect_refused(["eval", "--run", damaged], "config.json")

    def test_suite_configs_and_folders(self):
        self.expect_refused(["suite", "plan", "absent_suite.json"], "absent_suite.json")
        self.expect_refused(["suite", "plan", self.write("bad_suite.json", '{"grids": 3}')], "bad_suite.json")
        tiny = json.loads((ROOT / "experiments/suites/tiny.json").read_text())
        tiny["grids"][0]["seeds"] = [0.5]
        self.expect_refused(["suite", "plan", self.write("float_seed.json", json.dumps(tiny))], "seeds")
        # Two cells that each start from the other (a hand-written init.run): neither could ever run.
        circle = json.loads((ROOT / "experiments/suites/tiny.json").read_text())
        circle["variants"] = {"p": {"init": {"run": "../maps-q_d2_s0"}}, "q": {"init": {"run": "../maps-p_d2_s0"}}}
        circle["grids"] = [{"name": "circle", "sets": ["mt10"], "methods": ["maps"], "variants": ["p", "q"],
                            "seeds": [0]}]
        self.expect_refused(["suite", "plan", self.write("circle.json", json.dumps(circle))],
                            "init.run goes round in a circle (mt10/maps-p_d2_s0 -> mt10/maps-q_d2_s0 -> "
                            "mt10/maps-p_d2_s0)")
        self.expect_refused(["suite", "status", WORK], "has no suite.json")
        self.expect_refused(["report", WORK], "suite.json")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    MAPS = str(pathlib.Path(sys.argv.pop(1)).resolve())
    with tempfile.TemporaryDirectory(prefix="maps-bad-input-test-") as scratch:
        WORK = scratch
        unittest.main()
