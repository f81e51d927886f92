#!/usr/bin/python3
"""The Python route of docs/extending.md, whole: a selector loss and a policy written in Python (task_overlap.py,
film_policy.py), the loss checked by gradcheck and gradgradcheck, both trained by maps.train (the C++ trainer of
`maps train`), evaluated by the `maps` tool, and compared with MAPS and MT-BC in a tiny suite that the tool runs
(its embedded interpreter runs the same files) and reports.

    python3 example.py [MAPS_TOOL]        (default: `maps` on the PATH)

Writes data/gravity.h5 and runs/ here; a rerun resumes."""

import os
import subprocess
import sys

import numpy as np

import maps

here = os.path.dirname(os.path.abspath(__file__))
os.chdir(here)
tool = sys.argv[1] if len(sys.argv) > 1 else "maps"
sys.path.insert(0, here)
import task_overlap  # noqa: E402  (registers task_overlap_py)

# The loss's gradients, numerically, in float64: 3 tasks, 4 states each, 5 modules.
rng = np.random.default_rng(0)
tasks = [0] * 4 + [1] * 4 + [2] * 4
logits = maps.tensor(rng.normal(size=(12, 5)), requires_grad=True)
loss = task_overlap.TaskOverlap()


def of_logits(x):
    return loss(maps.SelectorOutputs(maps.softmax(x, 1), tasks, 3))


assert maps.gradcheck(of_logits, [logits]) and maps.gradgradcheck(of_logits, [logits])
print(f"task_overlap_py: gradcheck and gradgradcheck passed; value {of_logits(logits).item():.4f}")

if not os.path.exists("data/gravity.h5"):
    subprocess.run([tool, "collect", "--set", "gravity", "--demos", "4", "--out", "data/gravity.h5"], check=True)
for run in ("maps_task_overlap", "film"):
    maps.train(f"configs/{run}.json", out=f"runs/{run}")
    subprocess.run([tool, "eval", "--run", f"runs/{run}"], check=True)
subprocess.run([tool, "suite", "run", "suite.json", "--out", "runs/suite"], check=True)
subprocess.run([tool, "report", "runs/suite"], check=True)
