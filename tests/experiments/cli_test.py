#!/usr/bin/python3
"""The tool as a new user meets it (issue 16, item 5): `maps train --print-config` and `--set`, a finished run
extended step for step, what a run folder records (provenance.json, train.log), `collect --force`, `--json` and
`--threads 0` meaning the same in every command, the exit codes of docs/cli.md, `maps eval` progress, and
docs/configs.md naming every config key. Run by ctest as: cli_test.py path/to/maps."""
import hashlib
import json
import pathlib
import re
import unittest

from maps_tool import curve_without_timing, main, run, work

ROOT = pathlib.Path(__file__).resolve().parents[2]


def dotted_keys(value, prefix=""):
    if isinstance(value, dict) and prefix not in ("maps.selector_losses", "data.task_demos"):
        for key, inner in value.items():
            yield from dotted_keys(inner, f"{prefix}.{key}" if prefix else key)
    else:
        yield prefix


class ChunkedRender(unittest.TestCase):
    def test_render_acts_as_the_evaluator_for_a_policy_predicting_chunks(self):
        """`maps render` and `maps eval` share one step (maps/evaluation/step_actions.h): the rendered episode of a
        policy predicting chunks returns what the evaluator's first episode (the same seed) returns. On the cheetah,
        whose reward is dense, so the returns tell the action sequences apart."""
        if "--every" not in run("render", "--help").stdout:
            self.skipTest("built without the renderer")
        run("collect", "--set", "gravity", "--demos", "2", "--out", "gravity.h5", "--threads", "1")
        config = work() / "chunked.json"
        config.write_text(json.dumps({"method": "mt_bc", "data": {"file": "gravity.h5"},
                                      "train": {"steps": 50, "validate_every": 50, "checkpoint_every": 50,
                                                "validation_states_per_task": 50},
                                      "chunking": {"horizon": 4, "execution": "open_loop", "execute": 2},
                                      "eval": {"episodes": 1, "threads": 1, "tasks": ["gravity/1.0"]}}))
        out = work() / "chunked"
        run("train", "--config", config, "--out", out)
        run("eval", "--run", out)
        evaluated = json.loads((out / "eval.json").read_text())["tasks"][0]
        self.assertEqual(evaluated["task"], "gravity/1.0")
        strip = work() / "cheetah.png"
        proc = run("render", "--run", out, "--task", "gravity/1.0", "--out", strip, "--width", "64", "--height",
                   "48", "--frames", "2", check=False)
        if proc.returncode != 0 and "PNG" in proc.stderr:
            self.skipTest("built without libpng")
        self.assertEqual(proc.returncode, 0, proc.stderr)
        rendered = float(re.search(r"return (-?[0-9.]+)", proc.stdout).group(1))
        self.assertGreater(abs(evaluated["returns"][0]), 1.0)
        self.assertAlmostEqual(rendered, evaluated["returns"][0], delta=0.051)  # render prints one decimal


class Tool(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        run("collect", "--set", "mt10", "--demos", "3", "--out", "mt10.h5", "--threads", "1")
        cls.config = work() / "config.json"
        cls.config.write_text(json.dumps({"method": "mt_bc", "data": {"file": "mt10.h5"},
                                          "train": {"steps": 100, "validate_every": 50, "checkpoint_every": 50,
                                                    "validation_states_per_task": 50},
                                          "eval": {"episodes": 2, "threads": 1}}))

    def print_config(self, *extra):
        return json.loads(run("train", "--config", self.config, "--print-config", *extra).stdout)

    def test_version_names_the_commit_and_the_build(self):
        lines = run("--version").stdout.splitlines()
        self.assertRegex(lines[0], r"^maps \d+\.\d+\.\d+$")
        self.assertRegex(lines[1], r"^commit ([0-9a-f]{40}(-dirty)?|unknown)")
        self.assertTrue(lines[2].startswith("build ") and "MAPS_NATIVE=" in lines[2], lines[2])
        self.assertTrue(lines[3].startswith("float32 GEMM kernel "), lines[3])

    def test_print_config_resolves_every_default_and_set_overrides(self):
        config = self.print_config()
        self.assertEqual(config["train"]["steps"], 100)
        self.assertEqual(config["train"]["learning_rate"], 3e-4)
        self.assertEqual(config["maps"]["selector_losses"]["explore"], 0.5)
        config = self.print_config("--set", "train.steps=7", "--set", "method=maps", "--set", "maps.module_hidden=[64]",
                                   "--set", "maps.selector_losses={\"share\": 0}", "--set", "seed=3")
        self.assertEqual((config["train"]["steps"], config["method"], config["maps"]["module_hidden"], config["seed"]),
                         (7, "maps", [64], 3))
        self.assertEqual(config["maps"]["selector_losses"], {"share": 0})
        self.assertFalse((work() / "runs").exists())

    def test_bad_overrides_are_usage_or_config_errors_naming_the_key(self):
        for assignment, needle in (("train.steps", "key=value"), ("train..steps=3", "empty part"),
                                   ("train.stepz=3", "stepz"), ("train.steps=2.5", "train.steps"),
                                   ("data.file.x=1", "'data.file' is \"mt10.h5\"")):
            with self.subTest(assignment=assignment):
                proc = run("train", "--config", self.config, "--print-config", "--set", assignment, check=False)
                self.assertEqual(proc.returncode, 1, proc.stderr)
                self.assertIn(needle, proc.stderr)

    def test_configs_md_names_every_key(self):
        doc = (ROOT / "docs" / "configs.md").read_text()
        keys = list(dotted_keys(self.print_config()))
        self.assertGreater(len(keys), 30)
        for key in keys:
            self.assertIn(f"| `{key}` |", doc, f"docs/configs.md does not list {key}")
        # Every registered method, with its own section's keys (printed when it is the method).
        help_text = run("train", "--help").stdout
        methods = [line.split()[0] for line in help_text[help_text.index("Methods ("):].splitlines()[1:]
                   if line.startswith("  ") and line.split()]
        self.assertIn("moore", methods)
        method_row = next(line for line in doc.splitlines() if line.startswith("| `method` |"))
        zoo = (ROOT / "docs" / "zoo.md").read_text()
        for method in methods:
            with self.subTest(method=method):
                self.assertIn(f"`{method}`", method_row, f"docs/configs.md's method row does not name {method}")
                self.assertIn(f"`{method}`", zoo, f"docs/zoo.md does not name {method}")
                for key in dotted_keys(self.print_config("--set", f"method={method}")):
                    self.assertIn(f"| `{key}` |", doc, f"docs/configs.md does not list {key}")
        for example in (ROOT / "experiments" / "configs").glob("*.json"):
            with self.subTest(example=example.name):
                run("train", "--config", example, "--print-config")

    def test_a_finished_run_extends_step_for_step(self):
        out, fresh = work() / "extended", work() / "fresh"
        run("train", "--config", self.config, "--out", out)
        proc = run("train", "--config", self.config, "--out", out, "--set", "train.steps=200")
        self.assertIn("configured for 100 steps; continuing to 200", proc.stdout)
        self.assertIn("resumed from", proc.stdout)
        run("train", "--config", self.config, "--out", fresh, "--set", "train.steps=200")
        self.assertEqual(curve_without_timing(out / "curve.csv"), curve_without_timing(fresh / "curve.csv"))
        self.assertEqual((out / "best.ckpt").read_bytes(), (fresh / "best.ckpt").read_bytes())
        self.assertEqual(json.loads((out / "config.json").read_text())["train"]["steps"], 200)
        shorter = run("train", "--config", self.config, "--out", out, "--set", "train.steps=150", check=False)
        self.assertEqual(shorter.returncode, 1)
        self.assertIn("extended, not shortened", shorter.stderr)
        self.assertEqual(json.loads((out / "config.json").read_text())["train"]["steps"], 200)
        other = run("train", "--config", self.config, "--out", out, "--set", "seed=4", "--set", "train.steps=300",
                    check=False)
        self.assertEqual(other.returncode, 1)
        self.assertIn("differs in seed", other.stderr)

    def test_run_folder_records_what_made_it(self):
        out = work() / "recorded"
        run("train", "--config", self.config, "--out", out, "--threads", "0")
        run("train", "--config", self.config, "--out", out, "--set", "train.steps=150")
        records = json.loads((out / "provenance.json").read_text())
        self.assertEqual(len(records), 2)
        digest = hashlib.sha256((work() / "mt10.h5").read_bytes()).hexdigest()
        for record in records:
            self.assertEqual(record["demo_file_sha256"], digest)
            self.assertRegex(record["git_commit"], r"^([0-9a-f]{40}(-dirty)?|unknown.*)$")
            self.assertRegex(record["started_utc"], r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ$")
            self.assertIn("train --config", record["command_line"])
            self.assertTrue(record["tool_version"])
            # The machine's CPU and float32 kernel: CPU-time figures of runs on different machines differ.
            self.assertTrue(record["cpu"])
            self.assertIn(record["float32_gemm_kernel"], ("maps AVX-512", "maps AVX2", "Eigen"))
            self.assertEqual(record["matmul_precision"], "float32")
        self.assertGreaterEqual(records[0]["threads"], 1)  # --threads 0: one per core
        self.assertEqual(records[1]["overrides"], ["train.steps=150"])
        log = (out / "train.log").read_text()
        self.assertEqual(log.count("---- "), 2)
        self.assertIn("step 100/100", log)
        self.assertIn("resumed from", log)
        failed = run("train", "--config", self.config, "--out", out, "--set", "seed=9", check=False)
        self.assertEqual(failed.returncode, 1)
        self.assertEqual((out / "train.log").read_text().splitlines()[-1], failed.stderr.strip())

    def test_bf16_trains_where_the_cpu_has_it_and_is_refused_by_name_where_not(self):
        """train.precision bf16 (issue 44): on a CPU with AVX512-BF16 a run trains and its provenance records the
        precision; on one without, the run is refused naming the key and what the CPU lacks, before its folder is
        made."""
        out = work() / "bf16"
        cpu_flags = pathlib.Path("/proc/cpuinfo").read_text()
        has_bf16 = all(re.search(rf"\b{flag}\b", cpu_flags) for flag in ("avx512f", "avx512bw", "avx512_bf16"))
        done = run("train", "--config", self.config, "--out", out, "--set", "train.precision=bf16", check=False)
        if has_bf16:
            self.assertEqual(done.returncode, 0, done.stderr)
            record = json.loads((out / "provenance.json").read_text())[-1]
            self.assertEqual(record["matmul_precision"], "bf16")
            self.assertEqual(json.loads((out / "config.json").read_text())["train"]["precision"], "bf16")
            self.assertTrue((out / "best.ckpt").exists())
        else:
            self.assertEqual(done.returncode, 1)
            self.assertIn("train.precision \"bf16\"", done.stderr)
            self.assertIn("avx512", done.stderr)
            self.assertFalse(out.exists())
        wrong = run("train", "--config", self.config, "--out", out, "--set", "train.precision=fp16", check=False)
        self.assertNotEqual(wrong.returncode, 0)
        self.assertIn("train.precision", wrong.stderr)

    def test_eval_shows_progress(self):
        out = work() / "evaluated"
        run("train", "--config", self.config, "--out", out)
        proc = run("eval", "--run", out, "--threads", "0")
        self.assertEqual(len(re.findall(r"^  \[\d+/10\] mt10/\S+: score", proc.stdout, re.M)), 10)
        evaluation = json.loads((out / "eval.json").read_text())
        self.assertGreaterEqual(evaluation["tasks"][0]["score_ci95"], 0.0)

    def test_render_animates_a_trained_policy(self):
        if "--every" not in run("render", "--help").stdout or "GIF" not in run("render", "--help").stdout:
            self.skipTest("built without the renderer")
        out = work() / "animated"
        run("train", "--config", self.config, "--out", out)
        gif = work() / "reach.gif"
        proc = run("render", "--run", out, "--task", "mt10/reach", "--out", gif, "--width", "160", "--height", "120",
                   "--every", "10", check=False)
        if proc.returncode != 0 and "no GIF writer" in proc.stderr:
            self.skipTest("built without giflib")
        self.assertEqual(proc.returncode, 0, proc.stderr)
        frames = int(re.search(r"; (\d+) frames \(every 10 steps", proc.stdout).group(1))
        self.assertEqual(frames, 150 // 10 + 1)
        self.assertEqual(gif.read_bytes()[:6], b"GIF89a")
        try:
            from PIL import Image
        except ImportError:
            return
        with Image.open(gif) as image:
            self.assertEqual((image.n_frames, image.size), (frames, (160, 120)))

    def test_collect_refuses_to_overwrite_without_force(self):
        path = work() / "mt10.h5"
        before = path.read_bytes()
        proc = run("collect", "--set", "mt10", "--demos", "2", "--out", path, check=False)
        self.assertEqual(proc.returncode, 1)
        self.assertIn("--force", proc.stderr)
        self.assertEqual(path.read_bytes(), before)
        copy = work() / "copy.h5"
        copy.write_bytes(before)
        run("collect", "--set", "mt10", "--demos", "2", "--out", copy, "--force")
        self.assertNotEqual(copy.read_bytes(), before)

    def test_json_prints_one_json_document_on_stdout(self):
        for args in (["expert-eval", "--task", "mt10/reach", "--episodes", "2", "--json"],
                     ["bench", "eval", "--set", "mt10", "--episodes", "1", "--threads", "0", "--json"],
                     ["bench", "step", "--set", "mt10", "--seconds", "0.2", "--threads", "0", "--json"]):
            with self.subTest(command=" ".join(args[:2])):
                json.loads(run(*args).stdout)
        table = work() / "experts.json"
        run("expert-eval", "--task", "mt10/reach", "--episodes", "2", "--out", table)
        self.assertEqual(json.loads(table.read_text())[0]["task"], "mt10/reach")

    def test_exit_codes(self):
        self.assertEqual(run("train", "--help").returncode, 0)
        for args in (["train"], ["train", "--config"], ["no-such-command"], ["collect", "--set", "nope", "--out", "x"],
                     ["eval", "--run", "missing-folder"], ["train", "--config", self.config]):
            with self.subTest(args=args):
                self.assertEqual(run(*args, check=False).returncode, 2)
        self.assertEqual(run(check=False).returncode, 2)
        self.assertEqual(run("eval", "--run", work(), check=False).returncode, 1)


if __name__ == "__main__":
    main(__file__)
