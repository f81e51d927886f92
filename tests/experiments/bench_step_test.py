#!/usr/bin/python3
"""Tests of `maps bench step` (experiments/bench/bench_step.cpp) and its PyTorch peer
(experiments/bench/peer_pytorch.py): the JSON keys and their consistency, the errors for a bad set or thread
count, the peer's factored selector against the plain one on [state, one-hot task], and its skip without torch.
Run by ctest with the maps binary as the argument (tests/CMakeLists.txt)."""
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
PEER = ROOT / "experiments" / "bench" / "peer_pytorch.py"
MAPS = None  # set from argv


def run(*args):
    return subprocess.run([MAPS, *args], capture_output=True, text=True, timeout=120)


def registered_methods():
    """The method names `maps train --help` lists (the registry's)."""
    text = run("train", "--help").stdout
    lines = text[text.index("Methods ("):].splitlines()[1:]
    return [line.split()[0] for line in lines if line.startswith("  ") and line.split()]


def cpu_model():
    """The first "model name" of /proc/cpuinfo, as maps reads it ("unknown" without one)."""
    try:
        for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name") and ":" in line:
                return line.split(":", 1)[1].strip() or "unknown"
    except OSError:
        pass
    return "unknown"


class BenchStep(unittest.TestCase):
    def test_json_has_the_issue_keys_and_they_agree(self):
        done = run("bench", "step", "--set", "mt10", "--seconds", "0.2", "--json")
        self.assertEqual(done.returncode, 0, done.stderr)
        result = json.loads(done.stdout.strip().splitlines()[-1])
        for key in ("ms_per_step", "gflops", "gemm_gflops", "ratio_to_gemm", "own_gemm_gflops", "ratio_to_own_gemm"):
            self.assertIn(key, result)
            self.assertTrue(math.isfinite(result[key]) and result[key] > 0, key)
        self.assertAlmostEqual(result["gflops"], result["gflop_per_step"] / (result["ms_per_step"] * 1e-3), delta=1e-6 * result["gflops"])
        self.assertAlmostEqual(result["ratio_to_gemm"], result["gflops"] / result["gemm_gflops"], places=9)
        self.assertAlmostEqual(result["ratio_to_own_gemm"], result["gflops"] / result["own_gemm_gflops"], places=9)
        self.assertEqual(result["states"], 320)
        self.assertGreaterEqual(result["steps_timed"], 10)
        # A speed figure names its CPU: /proc/cpuinfo's first model name.
        self.assertEqual(result["cpu"], cpu_model())
        self.assertIn(result["float32_gemm_kernel"], ("maps AVX-512", "maps AVX2", "Eigen"))

    def test_precision_bf16_runs_where_the_cpu_has_it_and_is_refused_by_name_where_not(self):
        done = run("bench", "step", "--set", "mt10", "--seconds", "0.1", "--precision", "bf16", "--json")
        flags = pathlib.Path("/proc/cpuinfo").read_text()
        if all(re.search(rf"\b{flag}\b", flags) for flag in ("avx512f", "avx512bw", "avx512_bf16")):
            self.assertEqual(done.returncode, 0, done.stderr)
            result = json.loads(done.stdout.strip().splitlines()[-1])
            self.assertEqual(result["matmul_precision"], "bf16")
            self.assertTrue(math.isfinite(result["ms_per_step"]) and result["ms_per_step"] > 0)
        else:
            self.assertNotEqual(done.returncode, 0)
            self.assertIn("precision bf16 needs a CPU with AVX512-BF16", done.stderr)
        default = json.loads(run("bench", "step", "--set", "mt10", "--seconds", "0.05", "--json").stdout.strip()
                             .splitlines()[-1])
        self.assertEqual(default["matmul_precision"], "float32")

    def test_text_output_names_the_set_and_the_ceiling(self):
        done = run("bench", "step", "--set", "gravity", "--seconds", "0.1")
        self.assertEqual(done.returncode, 0, done.stderr)
        self.assertIn("set gravity: 640 states (5 tasks x 128)", done.stdout)
        self.assertIn("Eigen float32 GEMM 1024^3", done.stdout)
        self.assertIn("maps's own float32 GEMM 1024^3", done.stdout)
        self.assertIn(f"  CPU: {cpu_model()}\n", done.stdout)

    def test_every_method_has_a_step_and_the_counted_work_agrees_with_maps_analytic_count(self):
        methods = registered_methods()
        self.assertIn("moore", methods)
        for method in methods:
            done = run("bench", "step", "--set", "mt10", "--method", method, "--seconds", "0.05", "--json")
            self.assertEqual(done.returncode, 0, method + ": " + done.stderr)
            result = json.loads(done.stdout.strip().splitlines()[-1])
            self.assertEqual(result["method"], method)
            self.assertGreater(result["gemm_gflop_counted"], 0, method)
            self.assertGreater(result["parameters"], 0, method)
            if method == "maps":
                # The counter sees every product the step runs; the analytic count is what the step needs. They
                # agree but for products a kernel runs beyond that (none today beyond a few percent). The other
                # methods have no analytic count: their GFLOP/step is the counter's.
                self.assertAlmostEqual(result["gemm_gflop_counted"] / result["gflop_per_step"], 1.0, delta=0.05)
        done = run("bench", "step", "--method", "nope", "--seconds", "0.05")
        self.assertNotEqual(done.returncode, 0)
        self.assertIn('got "nope"', done.stderr)
        self.assertIn("moore", done.stderr)

    def test_bad_set_and_threads_are_named(self):
        done = run("bench", "step", "--set", "cheetah", "--seconds", "0.1")
        self.assertEqual(done.returncode, 2)  # the command line is wrong: checked with the other options' values
        self.assertIn("--set: cheetah not in {gravity,modified,mt10}", done.stderr)
        done = run("bench", "step", "--threads", "-1")  # 0 is one per core (docs/cli.md)
        self.assertNotEqual(done.returncode, 0)
        self.assertIn("--threads", done.stderr)


class BenchEval(unittest.TestCase):
    def test_the_time_split_adds_up(self):
        done = run("bench", "eval", "--set", "gravity", "--episodes", "1", "--json")
        self.assertEqual(done.returncode, 0, done.stderr)
        result = json.loads(done.stdout.strip().splitlines()[-1])
        self.assertEqual((result["tasks"], result["horizon"]), (5, 1000))
        parts = result["setup_seconds"] + result["env_seconds"] + result["policy_seconds"]
        self.assertGreater(result["env_seconds"], 0)
        self.assertGreater(result["policy_seconds"], 0)
        self.assertLessEqual(parts, result["wall_seconds"] * 1.05)  # one evaluator thread: the parts fit the wall time

    def test_any_method_at_its_defaults_or_a_config(self):
        # A method predicting chunks (Diffusion Policy, small) and one that routes (top-k MoE): both run, named.
        with tempfile.TemporaryDirectory() as folder:
            config = pathlib.Path(folder) / "small.json"
            config.write_text(json.dumps({"diffusion_policy": {"denoiser": "mlp", "width": 16, "inference_steps": 2}}))
            done = run("bench", "eval", "--set", "mt10", "--episodes", "1", "--method", "diffusion_policy",
                       "--config", str(config), "--json")
            self.assertEqual(done.returncode, 0, done.stderr)
            result = json.loads(done.stdout.strip().splitlines()[-1])
            self.assertEqual((result["method"], result["tasks"]), ("diffusion_policy", 10))
            self.assertGreater(result["policy_seconds"], 0)
        done = run("bench", "eval", "--set", "mt10", "--episodes", "1", "--method", "top_k_moe", "--json")
        self.assertEqual(done.returncode, 0, done.stderr)
        self.assertEqual(json.loads(done.stdout.strip().splitlines()[-1])["method"], "top_k_moe")
        done = run("bench", "eval", "--method", "no_such_method")
        self.assertNotEqual(done.returncode, 0)
        self.assertIn("no_such_method", done.stderr)

    def test_bad_set_is_named(self):
        done = run("bench", "eval", "--set", "cheetah")
        self.assertNotEqual(done.returncode, 0)
        self.assertIn("cheetah", done.stderr)


class PeerPyTorch(unittest.TestCase):
    def test_without_torch_it_says_so_and_skips(self):
        # -S leaves out site-packages, where Debian's torch lives.
        done = subprocess.run([sys.executable, "-S", str(PEER), "--json"], capture_output=True, text=True, timeout=60)
        self.assertEqual(done.returncode, 0, done.stderr)
        self.assertIn("PyTorch is not installed", json.loads(done.stdout.strip())["skipped"])
        done = subprocess.run([sys.executable, "-S", str(PEER), "--threads", "2", "--json"], capture_output=True,
                              text=True, timeout=60)
        self.assertEqual(done.returncode, 0, done.stderr)
        self.assertIn("skipped", json.loads(done.stdout.strip()))

    def test_the_blas_is_named_from_the_loaded_libraries(self):
        sys.path.insert(0, str(PEER.parent))
        import peer_pytorch as peer
        lib = "/usr/lib/x86_64-linux-gnu"
        # libblas.so.3 pointed at netlib's while liblapack.so.3 still loads OpenBLAS: torch calls the reference sgemm.
        self.assertEqual(peer.blas_of({f"{lib}/blas/libblas.so.3", f"{lib}/openblas-pthread/liblapack.so.3",
                                       f"{lib}/openblas-pthread/libopenblas.so.0"}), peer.REFERENCE_BLAS)
        self.assertEqual(peer.blas_of({f"{lib}/openblas-pthread/libblas.so.3", f"{lib}/lapack/liblapack.so.3"}),
                         "OpenBLAS")
        self.assertEqual(peer.blas_of({"/opt/libopenblas.so.0"}), "OpenBLAS")
        self.assertEqual(peer.blas_of(set()), "unknown BLAS")

    def test_factored_selector_equals_the_plain_one(self):
        try:
            import torch
        except ImportError:
            self.skipTest("torch is not installed")
        sys.path.insert(0, str(PEER.parent))
        import peer_pytorch as peer
        torch.manual_seed(0)
        S, A, K, n = 5, 2, 3, 7
        p = peer.build(torch, S, A, K)
        obs = torch.randn(n, S)
        tasks = torch.tensor([0, 1, 2, 2, 1, 0, 0])
        plain_rows = []
        for k in range(K):
            x = torch.cat([obs, torch.nn.functional.one_hot(torch.full((n,), k), K).float()], 1)
            h = x
            for i in range(len(peer.SELECTOR_HIDDEN) + 1):
                h = h @ p[f"selector{i}.w"] + p[f"selector{i}.b"]
                if i < len(peer.SELECTOR_HIDDEN):
                    h = torch.tanh(h)
            plain_rows.append(torch.softmax(h, -1))
        plain = torch.stack(plain_rows)
        self.assertTrue(torch.allclose(peer.selector_scores(torch, p, obs, S, K), plain, atol=1e-6))
        self.assertTrue(torch.allclose(peer.own_task_scores(torch, p, obs, tasks, S, K), plain[tasks, torch.arange(n)], atol=1e-6))
        total = peer.loss(torch, p, (obs, obs, torch.zeros(n, A), tasks), S, K)
        self.assertTrue(math.isfinite(total.item()))

    def test_flop_count_matches_the_cpp_count(self):
        sys.path.insert(0, str(PEER.parent))
        import peer_pytorch as peer
        # tests/maps/policies/maps_flops_test.cpp
        self.assertEqual(peer.step_flops(17, 6, 5, 128), 1761607680)
        self.assertEqual(peer.step_flops(39, 4, 10, 32), 1088716800)


class StepTable(unittest.TestCase):
    """experiments/bench/step_table.py's table from step_table.sh's JSON lines, and the script's refusals."""

    TABLE = ROOT / "experiments" / "bench" / "step_table.py"
    SCRIPT = ROOT / "experiments" / "bench" / "step_table.sh"

    def table(self, records):
        with tempfile.TemporaryDirectory() as folder:
            path = pathlib.Path(folder) / "step.jsonl"
            path.write_text("".join(json.dumps(r) + "\n" for r in records))
            return subprocess.run([sys.executable, str(self.TABLE), str(path)], capture_output=True, text=True,
                                  timeout=60)

    @staticmethod
    def step(kind, precision, ms, gflops, eigen, own):
        return {"kind": kind, "set": "mt10", "threads": 1, "cpu": "Test CPU", "matmul_precision": precision,
                "float32_gemm_kernel": "maps AVX-512", "ms_per_step": ms, "gflops": gflops, "gemm_gflops": eigen,
                "own_gemm_gflops": own}

    def test_shares_of_each_ceiling_the_best_bf16_over_float32_and_pytorch(self):
        records = [
            {"kind": "openblas_native", "gflops": 160.0, "openblas": {"core": "Zen"},
             "env": {"OPENBLAS_CORETYPE": None}},
            {"kind": "pytorch", "set": "mt10", "threads": 1, "torch": "1.13", "blas": "OpenBLAS", "ms_per_step": 30.0},
            self.step("step_native", "float32", 10.0, 120.0, 100.0, 150.0),
            self.step("step_native", "bf16", 8.0, 150.0, 100.0, 300.0),
        ]
        done = self.table(records)
        self.assertEqual(done.returncode, 0, done.stderr)
        rows = [line for line in done.stdout.splitlines() if line.startswith("| mt10")]
        self.assertEqual(len(rows), 2, done.stdout)
        float32 = [cell.strip() for cell in rows[0].split("|")[1:-1]]
        bf16 = [cell.strip() for cell in rows[1].split("|")[1:-1]]
        # set, precision, build, threads, ms, GFLOP/s, OpenBLAS, Eigen, own, best, over float32, PyTorch ms, speed-up
        self.assertEqual(float32[1], "float32")
        self.assertEqual(float32[6:11], ["0.75", "1.20", "0.80", "0.75", "-"])
        self.assertEqual(float32[12], "3.00x")
        self.assertEqual(bf16[6:11], ["0.94", "1.50", "0.50", "0.50", "1.25x"])
        self.assertIn("Test CPU", done.stdout)
        self.assertIn("kernel Zen, its own choice", done.stdout)

    def test_the_avx2_build_rows_are_judged_against_the_ceilings_of_the_kernel_they_ran(self):
        avx2 = dict(self.step("step_avx2", "float32", 20.0, 60.0, 80.0, 75.0), float32_gemm_kernel="maps AVX2")
        portable = self.step("step_portable", "float32", 10.0, 120.0, 80.0, 150.0)
        records = [{"kind": "openblas_native", "gflops": 160.0, "openblas": {"core": "Zen"}, "env": {}},
                   {"kind": "openblas_avx2", "gflops": 100.0, "openblas": {"core": "Haswell"},
                    "env": {"OPENBLAS_CORETYPE": "Haswell"}},
                   self.step("step_native", "float32", 10.0, 120.0, 100.0, 150.0), avx2, portable]
        done = self.table(records)
        self.assertEqual(done.returncode, 0, done.stderr)
        rows = [[cell.strip() for cell in line.split("|")[1:-1]] for line in done.stdout.splitlines()
                if line.startswith("| mt10")]
        self.assertEqual([r[2] for r in rows], ["x86-64-v3 (maps AVX2)", "x86-64-v3, run-time choice (maps AVX-512)",
                                                "native (maps AVX-512)"])
        self.assertEqual(rows[0][6:10], ["0.60", "0.75", "0.80", "0.60"])  # against OpenBLAS's Haswell kernel
        self.assertEqual(rows[1][6:10], ["0.75", "1.50", "0.80", "0.75"])  # against its native kernel
        self.assertIn("on its AVX2 kernel: 100.0 GFLOP/s (kernel Haswell, forced)", done.stdout)

    def test_a_damaged_line_is_named(self):
        with tempfile.TemporaryDirectory() as folder:
            path = pathlib.Path(folder) / "step.jsonl"
            path.write_text('{"kind": "pytorch"}\n{"kind": \n')
            done = subprocess.run([sys.executable, str(self.TABLE), str(path)], capture_output=True, text=True,
                                  timeout=60)
        self.assertNotEqual(done.returncode, 0)
        self.assertIn("line 2", done.stderr)

    def test_the_script_refuses_bad_settings_before_running_anything(self):
        for env, text in (({"PRECISIONS": "float16"}, "PRECISIONS: 'float16'"),
                          ({"THREADS": "0"}, "THREADS: '0'"),
                          ({"AVX2_BIN": "/nonexistent/maps"}, "AVX2_BIN '/nonexistent/maps'")):
            done = subprocess.run(["bash", str(self.SCRIPT), MAPS, "/nonexistent/out.jsonl", "1"],
                                  capture_output=True, text=True, timeout=60, env=dict(os.environ, **env))
            self.assertEqual(done.returncode, 2, done.stderr)
            self.assertIn(text, done.stderr)
        done = subprocess.run(["bash", str(self.SCRIPT), MAPS, "/nonexistent/out.jsonl", "soon"], capture_output=True,
                              text=True, timeout=60)
        self.assertEqual(done.returncode, 2)
        self.assertIn("SECONDS must be a positive number, got 'soon'", done.stderr)


if __name__ == "__main__":
    MAPS = sys.argv.pop(1)
    unittest.main()
