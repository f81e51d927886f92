#!/usr/bin/env python3
"""How far outside the demonstrations' range a policy's observations go, once standardised as a run standardises
them (docs/adversarial.md, "Observations out of the demonstrations' range").

The statistics are fitted as maps::core::Standardizer::fit does (population std, a std below 1e-6 taken as 1) to the
first --demos training demonstrations of every task of the file (the file's order, not a run's seeded draw: a
diagnostic, the same order of magnitude). Each task's env is then stepped by two policies that are not experts:
uniformly random actions, and on MT10 a scripted approach (the hand moves towards the object with noise, the gripper
random), which is what a policy learning a manipulation task does early on. Prints per task and policy the largest
|standardised observation|, the share of steps with any entry beyond --clip, and those entries' dimensions.

  /usr/bin/python3 experiments/bench/observation_range.py --data data/mt10.h5 --demos 2
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "build", "python"))
import maps  # noqa: E402

MIN_STD = 1e-6  # Standardizer::fit's floor


def statistics(path, demos):
    arrays = maps.demo_arrays(path, split="train")
    keep = np.zeros(len(arrays["demo"]), dtype=bool)
    for task in np.unique(arrays["task_index"]):
        own = np.unique(arrays["demo"][arrays["task_index"] == task])
        first = own[:demos] if demos > 0 else own
        keep |= np.isin(arrays["demo"], first)
    obs = arrays["observations"][keep]
    mean, std = obs.mean(0), obs.std(0)
    std[~(std >= MIN_STD)] = 1.0
    return mean, std


def approach(obs, rng, action_size):
    """MT10's observation starts with the hand's position (0:3), the gripper (3) and the object's position (4:7)."""
    towards = np.clip(10.0 * (obs[4:7] - obs[0:3]) + rng.normal(0.0, 0.3, 3), -1.0, 1.0)
    return np.concatenate([towards, rng.uniform(-1.0, 1.0, action_size - 3)])


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", required=True, help="a demo file (data/mt10.h5, data/gravity.h5, ...)")
    parser.add_argument("--demos", type=int, default=2, help="training demonstrations per task to fit to (0: all)")
    parser.add_argument("--episodes", type=int, default=5, help="episodes per task and policy")
    parser.add_argument("--clip", type=float, default=10.0, help="the bound to count steps beyond")
    args = parser.parse_args()
    if args.demos < 0 or args.episodes < 1 or not args.clip > 0:
        parser.error("--demos must be >= 0, --episodes >= 1 and --clip > 0")
    mean, std = statistics(args.data, args.demos)
    small = np.nonzero(std < 1e-2)[0]
    listed = ", ".join(f"{d} ({std[d]:.1e})" for d in small) if len(small) else "none"
    print(f"{args.data}: {args.demos or 'all'} training demos per task; dimensions with std < 0.01: {listed}")
    task_set = str(maps.read_demo_file(args.data).task_set)
    policies = ["random"] + (["approach"] if task_set == "mt10" else [])
    print("| task | policy | max abs z | steps beyond the clip | dimensions beyond it |")
    print("|---|---|---|---|---|")
    rng = np.random.default_rng(0)
    for task in maps.task_names(task_set):
        env = maps.make_env(task)
        action_size = env.action_space.shape[0]
        for policy in policies:
            worst, beyond, steps, dims = 0.0, 0, 0, set()
            for episode in range(args.episodes):
                obs, _ = env.reset(seed=2**41 + episode)  # outside the demonstration and evaluation seeds
                for _ in range(env.max_episode_steps):
                    obs = np.asarray(obs)
                    action = (rng.uniform(-1.0, 1.0, action_size) if policy == "random"
                              else approach(obs, rng, action_size))
                    obs, _, terminated, truncated, _ = env.step(action)
                    z = np.abs((np.asarray(obs) - mean) / std)
                    worst = max(worst, float(z.max()))
                    beyond += bool((z > args.clip).any())
                    dims.update(int(d) for d in np.nonzero(z > args.clip)[0])
                    steps += 1
                    if terminated or truncated:
                        break
            print(f"| {task} | {policy} | {worst:.0f} | {beyond / steps:.2f} | "
                  f"{', '.join(map(str, sorted(dims))) or '-'} |")


if __name__ == "__main__":
    main()
