#!/usr/bin/python3
"""One MAPS training step in PyTorch: the peer of `maps bench step` (experiments/bench/bench_step.cpp).

The same model, shapes, losses, FLOP count and timing as the C++ tool: M = 10 proto-policy modules (3x128 tanh,
run as batched matrix products), a 2x128 tanh selector over [state, one-hot task] scoring every state under every
task (its first layer's state part computed once per state, as maps does), a head over the scored features, the BC
loss and the share, explore, sparse and smooth selector losses with the paper's HalfCheetah weights, backward, and
one Adam step. Prints ms/step (median) and GFLOP/s; --json prints one JSON object as the last line.

Run with Debian's python3-torch, one thread: /usr/bin/python3 experiments/bench/peer_pytorch.py --set gravity
Debian's torch calls the system BLAS; install libopenblas0-pthread for a fair comparison (with netlib's reference
BLAS it is several times slower). With --threads N > 1 the threads can go to OpenBLAS or to torch's own ops, and
both at once oversubscribe the cores (measured, gravity on 2 cores: 30 ms with 2 OpenBLAS threads, 35 ms with 2
torch threads, 65 ms with both, 40 ms with one thread); the script times both splits in child processes and
reports the faster.
"""
import subprocess
import argparse
import json
import math
import os
import statistics
import sys
import time

SETS = {  # S, A, K, states per task (issue 6)
    "gravity": (17, 6, 5, 128),
    "modified": (17, 6, 11, 128),
    "mt10": (39, 4, 10, 32),
}
MODULES = 10
MODULE_HIDDEN = [128, 128, 128]
SELECTOR_HIDDEN = [128, 128]
BC_WEIGHT, SELECTOR_WEIGHT = 0.75, 0.25
LOSS_WEIGHTS = {"share": 1.0, "explore": 0.5, "sparse": 0.001, "smooth": 1.0}


def parse_args():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", default="gravity", choices=sorted(SETS))
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--seconds", type=float, default=2.0)
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--blas-threads", type=int, help=argparse.SUPPRESS)  # set by the parent for one split
    args = parser.parse_args()
    if args.threads < 1:
        parser.error(f"--threads must be >= 1, got {args.threads}")
    if not args.seconds > 0:
        parser.error(f"--seconds must be > 0, got {args.seconds}")
    return args


def step_flops(S, A, K, per_task):
    """maps_training_step_flops (maps/policies/maps_flops.cpp), term for term."""
    M, n = MODULES, K * per_task
    flops, fan_in = 0.0, S
    for i, h in enumerate(MODULE_HIDDEN):
        flops += 2.0 * n * M * fan_in * h * (2.0 if i == 0 else 3.0)
        fan_in = h
    flops += 3.0 * 2.0 * n * M * fan_in * A
    sizes = SELECTOR_HIDDEN + [M]
    rows = (K + 1.0) * n
    flops += 2.0 * (2.0 * 2.0 * n * S * sizes[0])
    flops += sum(3.0 * 2.0 * rows * a * b for a, b in zip(sizes, sizes[1:]))
    return flops


def uniform(torch, shape, bound):
    return (torch.rand(*shape) * 2.0 - 1.0) * bound


def build(torch, S, A, K):
    """Parameters as maps lays them out: module layers [M, in, out], selector layers [in, out]."""
    params = {}
    fan_in = S
    for i, h in enumerate(MODULE_HIDDEN):
        bound = 1.0 / math.sqrt(fan_in)
        params[f"module{i}.w"] = uniform(torch, (MODULES, fan_in, h), bound)
        params[f"module{i}.b"] = uniform(torch, (MODULES, 1, h), bound)
        fan_in = h
    bound = 1.0 / math.sqrt(MODULES * fan_in)
    params["head.w"] = uniform(torch, (MODULES, fan_in, A), bound)
    params["head.b"] = uniform(torch, (A,), bound)
    sizes = [S + K] + SELECTOR_HIDDEN + [MODULES]
    for i, (a, b) in enumerate(zip(sizes, sizes[1:])):
        bound = 1.0 / math.sqrt(a)
        params[f"selector{i}.w"] = uniform(torch, (a, b), bound)
        params[f"selector{i}.b"] = uniform(torch, (b,), bound)
    for p in params.values():
        p.requires_grad_(True)
    return params


def selector_rest(torch, p, h):
    """The selector's layers after the first, on its first layer's output h, then the softmax over modules."""
    layers = len(SELECTOR_HIDDEN) + 1
    for i in range(1, layers):
        h = h @ p[f"selector{i}.w"] + p[f"selector{i}.b"]
        if i + 1 < layers:
            h = torch.tanh(h)
    return torch.softmax(h, dim=-1)


def selector_scores(torch, p, obs, S, K):
    """Softmax scores [K, n, M] of every state under every task; the first layer's state part once per state."""
    w0 = p["selector0.w"]
    state_part = obs @ w0[:S]  # [n, H]
    h = torch.tanh(state_part.unsqueeze(0) + (w0[S:] + p["selector0.b"]).unsqueeze(1))  # [K, n, H]
    return selector_rest(torch, p, h)


def own_task_scores(torch, p, obs, tasks, S, K):
    """Scores [n, M] of each state under its own task."""
    w0 = p["selector0.w"]
    h = torch.tanh(obs @ w0[:S] + w0[S:][tasks] + p["selector0.b"])
    return selector_rest(torch, p, h)


def loss(torch, p, batch, S, K):
    obs, prev, actions, tasks = batch
    n = obs.shape[0]
    h = obs.unsqueeze(0).expand(MODULES, n, S)
    for i in range(len(MODULE_HIDDEN)):
        h = torch.tanh(torch.baddbmm(p[f"module{i}.b"], h, p[f"module{i}.w"]))  # [M, n, F]
    all_scores = selector_scores(torch, p, obs, S, K)  # [K, n, M]
    scores = all_scores[tasks, torch.arange(n)]  # [n, M]
    previous = own_task_scores(torch, p, prev, tasks, S, K)
    per_module = torch.bmm(h, p["head.w"])  # [M, n, A]
    action = (per_module * scores.t().unsqueeze(-1)).sum(0) + p["head.b"]
    bc = torch.mean((action - actions) ** 2)

    M = float(MODULES)
    share = (2.0 * K * torch.sum(all_scores**2) - 2.0 * torch.sum(all_scores.sum(0) ** 2)) / (K * (K - 1.0) * n * M)
    usage = scores.sum(0)
    explore = torch.sum((usage - n / M) ** 2) * (M / (n * n))
    safe = scores.clamp_min(1e-30)
    sparse = torch.sum(safe.pow(1.0 / math.log(M)) * torch.log(safe)) * (-1.0 / (M * n))
    smooth = torch.mean((scores - previous) ** 2)
    selector = (LOSS_WEIGHTS["share"] * share + LOSS_WEIGHTS["explore"] * explore + LOSS_WEIGHTS["sparse"] * sparse
                + LOSS_WEIGHTS["smooth"] * smooth)
    return BC_WEIGHT * bc + SELECTOR_WEIGHT * selector


def best_split(args):
    """With several threads: times (all threads to OpenBLAS, torch ops on one) and (OpenBLAS on one, torch ops on
    all) in child processes and returns the faster result, naming its split."""
    results = []
    for blas, torch_threads in ((args.threads, 1), (1, args.threads)):
        env = dict(os.environ, OPENBLAS_NUM_THREADS=str(blas))
        python = [sys.executable] + (["-S"] if sys.flags.no_site else [])  # the children see the same packages
        done = subprocess.run([*python, __file__, "--set", args.set, "--threads", str(torch_threads),
                               "--seconds", str(args.seconds), "--json", "--blas-threads", str(blas)],
                              capture_output=True, text=True, env=env)
        if done.returncode != 0:
            sys.exit(f"peer_pytorch: the child for {blas} BLAS / {torch_threads} torch threads failed:\n{done.stderr}")
        result = json.loads(done.stdout.strip().splitlines()[-1])
        if "skipped" in result:
            return result
        results.append(result)
    best = min(results, key=lambda r: r["ms_per_step"])
    best["threads"] = args.threads
    return best


def main():
    args = parse_args()
    if args.threads > 1 and args.blas_threads is None:
        result = best_split(args)
        if args.json:
            print(json.dumps(result))
        elif "skipped" in result:
            print(f"peer_pytorch: skipped: {result['skipped']}", file=sys.stderr)
        else:
            print(f"PyTorch {result['torch']} ({result['blas']}), set {args.set}, {args.threads} threads "
                  f"({result['split']}): {result['ms_per_step']:.3f} ms/step (median of {result['steps_timed']}), "
                  f"{result['gflops']:.1f} GFLOP/s")
        return 0
    blas_threads = args.blas_threads if args.blas_threads is not None else 1
    os.environ["OPENBLAS_NUM_THREADS"] = str(blas_threads)  # read when torch loads OpenBLAS
    try:
        import torch
        message = REFERENCE_BLAS_MESSAGE if _blas_name(torch) == REFERENCE_BLAS else None
    except ImportError:
        message = "PyTorch is not installed (apt-get install python3-torch libopenblas0-pthread; run with /usr/bin/python3)"
    if message:
        if args.json:
            print(json.dumps({"skipped": message}))
            return 0
        print(f"peer_pytorch: skipped: {message}", file=sys.stderr)
        return 0
    torch.set_num_threads(args.threads)
    torch.manual_seed(0)
    S, A, K, per_task = SETS[args.set]
    n = K * per_task
    params = build(torch, S, A, K)
    obs = torch.randn(n, S)
    batch = (obs, obs + 0.1 * torch.randn(n, S), torch.rand(n, A) * 2.0 - 1.0,
             torch.arange(K).repeat_interleave(per_task))
    adam = torch.optim.Adam(params.values(), lr=1e-4)

    def step():
        total = loss(torch, params, batch, S, K)
        adam.zero_grad()
        total.backward()
        adam.step()
        return total.item()

    for _ in range(5):
        step()
    times, start, value = [], time.perf_counter(), 0.0
    while len(times) < 10 or time.perf_counter() - start < args.seconds:
        t0 = time.perf_counter()
        value = step()
        times.append(time.perf_counter() - t0)
    if not math.isfinite(value):
        sys.exit("peer_pytorch: the loss became non-finite")
    seconds = statistics.median(times)
    flops = step_flops(S, A, K, per_task)
    result = {"set": args.set, "threads": args.threads, "torch": torch.__version__,
              "blas": _blas_name(torch), "steps_timed": len(times),
              "ms_per_step": seconds * 1e3, "gflops": flops / seconds * 1e-9,
              "split": f"{blas_threads} OpenBLAS thread(s), {args.threads} torch thread(s)"}
    if args.json:
        print(json.dumps(result))
    else:
        print(f"PyTorch {result['torch']} ({result['blas']}), set {args.set}, {args.threads} thread(s): "
              f"{result['ms_per_step']:.3f} ms/step (median of {len(times)}), {result['gflops']:.1f} GFLOP/s")
    return 0


REFERENCE_BLAS = "netlib reference BLAS"
REFERENCE_BLAS_MESSAGE = ("PyTorch calls netlib's reference BLAS, which makes its step 10-20x slower than with OpenBLAS "
                          "and the comparison meaningless (apt-get install libopenblas0-pthread, or point libblas.so.3 "
                          "back at OpenBLAS: update-alternatives --auto libblas.so.3-x86_64-linux-gnu)")


def _blas_name(torch):
    """The BLAS this torch process calls (Debian's torch calls the system's libblas.so.3), from /proc/self/maps."""
    torch.ones(2, 2) @ torch.ones(2, 2)  # the BLAS is loaded by now
    try:
        with open("/proc/self/maps") as maps:
            paths = {line.split(None, 5)[-1].strip() for line in maps if "blas" in line.lower() and "/" in line}
    except OSError:
        return "unknown BLAS"
    return blas_of(paths)


def blas_of(paths):
    """Names the BLAS from the loaded libraries' paths. The alternatives system points libblas.so.3 at OpenBLAS or at
    netlib's reference BLAS, files of the same name in different folders; torch needs libblas.so.3 itself, so that
    file's sgemm is the one it calls even when OpenBLAS is loaded too (through liblapack.so.3, whose alternative can
    point elsewhere)."""
    blas = [path for path in paths if path.split("/")[-1].startswith("libblas.so")]
    if any("/blas/" in path for path in blas):
        return REFERENCE_BLAS
    if any("openblas" in path.lower() for path in blas or paths):
        return "OpenBLAS"
    return ", ".join(sorted(path.split("/")[-1] for path in paths)) or "unknown BLAS"


if __name__ == "__main__":
    sys.exit(main())
