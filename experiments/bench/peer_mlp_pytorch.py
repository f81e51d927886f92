#!/usr/bin/python3
"""The same work as experiments/bench/micro/mlp_bench.cpp in PyTorch, on one thread.

A 17-128-128-128-6 tanh MLP at batch 640 in float32: forward (no grad), forward + backward of
an MSE loss, one Adam step, and the whole training step. Prints microseconds per iteration
(median of 5 repetitions) and GFLOP/s with the same FLOP counts as the C++ benchmark.

Run with Debian's python3-torch: /usr/bin/python3 experiments/bench/peer_mlp_pytorch.py
Debian's torch calls the system BLAS: with only netlib's reference libblas3 it is about 9x slower,
so install libopenblas0-pthread for a fair comparison (the script prints which BLAS is active).
"""
import os
import statistics
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # one thread, like the C++ benchmark

try:
    import torch
except ImportError:
    sys.exit("peer_mlp_pytorch: PyTorch is not installed (apt-get install python3-torch libopenblas0-pthread; run "
             "/usr/bin/python3)")
from peer_pytorch import REFERENCE_BLAS, REFERENCE_BLAS_MESSAGE, _blas_name  # noqa: E402 (beside this script)

if _blas_name(torch) == REFERENCE_BLAS:
    sys.exit(f"peer_mlp_pytorch: {REFERENCE_BLAS_MESSAGE}")

torch.set_num_threads(1)
torch.manual_seed(0)
BATCH = 640
SIZES = [17, 128, 128, 128, 6]
FORWARD_FLOPS = sum(2.0 * BATCH * a * b for a, b in zip(SIZES, SIZES[1:]))
BACKWARD_FLOPS = sum(2.0 * BATCH * a * b * (1 if i == 0 else 2) for i, (a, b) in enumerate(zip(SIZES, SIZES[1:])))

layers = []
for i, (a, b) in enumerate(zip(SIZES, SIZES[1:])):
    layers.append(torch.nn.Linear(a, b))
    if i + 2 < len(SIZES):
        layers.append(torch.nn.Tanh())
mlp = torch.nn.Sequential(*layers)
x = torch.randn(BATCH, SIZES[0])
y = torch.randn(BATCH, SIZES[-1])
adam = torch.optim.Adam(mlp.parameters(), lr=1e-4)


def time_us(body, seconds=0.5, repetitions=5):
    medians = []
    for _ in range(repetitions):
        count, start = 0, time.perf_counter()
        while time.perf_counter() - start < seconds:
            body()
            count += 1
        medians.append((time.perf_counter() - start) / count * 1e6)
    return statistics.median(medians)


def forward():
    with torch.no_grad():
        mlp(x)


def forward_backward():
    adam.zero_grad()
    torch.nn.functional.mse_loss(mlp(x), y).backward()


def train_step():
    forward_backward()
    adam.step()


forward_backward()
cases = [
    ("MlpForward", forward, FORWARD_FLOPS),
    ("MlpForwardBackward", forward_backward, FORWARD_FLOPS + BACKWARD_FLOPS),
    ("MlpAdamStep", adam.step, None),
    ("MlpTrainStep", train_step, FORWARD_FLOPS + BACKWARD_FLOPS),
]
blas = os.path.realpath("/usr/lib/x86_64-linux-gnu/libblas.so.3")
print(f"PyTorch {torch.__version__}, {torch.get_num_threads()} thread, BLAS {blas}")
if "openblas" not in blas and "blis" not in blas and "mkl" not in blas:
    print("warning: this BLAS looks like netlib's reference one; PyTorch's numbers will be far too slow")
for name, body, flops in cases:
    us = time_us(body)
    rate = f"{flops / us * 1e-3:8.1f} GFLOP/s" if flops else ""
    print(f"{name:20s} {us:9.1f} us  {rate}")
