#!/usr/bin/python3
"""docs/performance.md's GAIL table (issue 45): env steps per second of a GAIL run on 1 and 2 threads, and where the
time goes (physics, the policy's calls in rollouts, the discriminator, PPO's updates, the rest).

    /usr/bin/python3 experiments/bench/gail_speed.py [--maps build/bin/maps] [--data data/gravity.h5]
        [--methods mt_bc maps] [--threads 1 2] [--env-steps 100000] [--work runs/gail_speed] [--out FILE.jsonl]

For each method and thread count it trains `maps train` by GAIL on every task of the demo file (5 demonstrations per
task, subsampled every 20 steps, gail.rollout_episodes 2, the discriminator's warm-up off so that every iteration is
alike; the rest at the defaults) for --env-steps per task, with gail.threads (the envs stepped side by side, and the
ops' threads) set to the thread count, from an empty run folder. It reads train.json's timing and prints one Markdown
row per run with the CPU model; each run's record is one JSON line in --out. The two thread counts need two idle
cores: run it on a quiet machine."""
import argparse
import json
import pathlib
import shutil
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
PARTS = [("physics_seconds", "physics"), ("rollout_policy_seconds", "policy in rollouts"),
         ("discriminator_seconds", "discriminator"), ("ppo_seconds", "PPO"), ("other_seconds", "other")]


def cpu_model():
    try:
        for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--maps", default=str(ROOT / "build" / "bin" / "maps"))
    parser.add_argument("--data", default=str(ROOT / "data" / "gravity.h5"))
    parser.add_argument("--methods", nargs="+", default=["mt_bc", "maps"])
    parser.add_argument("--threads", nargs="+", type=int, default=[1, 2])
    parser.add_argument("--env-steps", type=int, default=100000)
    parser.add_argument("--work", default=str(ROOT / "runs" / "gail_speed"))
    parser.add_argument("--out", default=str(ROOT / "results" / "performance" / "gail_speed.jsonl"))
    args = parser.parse_args(argv)
    if not pathlib.Path(args.maps).is_file():
        sys.exit(f"gail_speed.py: --maps {args.maps} is not a file (build it: cmake --build build)")
    if not pathlib.Path(args.data).is_file():
        sys.exit(f"gail_speed.py: --data {args.data} is not a file (maps collect --set gravity --out {args.data})")
    if args.env_steps < 2000:
        sys.exit(f"gail_speed.py: --env-steps must be at least 2000 (one iteration), got {args.env_steps}")
    if any(t < 1 for t in args.threads):
        sys.exit(f"gail_speed.py: --threads must be positive, got {' '.join(map(str, args.threads))}")
    work = pathlib.Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    records = []
    for method in args.methods:
        for threads in args.threads:
            config = {"method": method, "seed": 0,
                      "data": {"file": str(pathlib.Path(args.data).resolve()), "demos_per_task": 5, "subsample": 20},
                      "imitation": "gail",
                      "gail": {"env_steps_per_task": args.env_steps, "rollout_episodes": 2, "threads": threads,
                               "discriminator_warmup_iterations": 0}}
            folder = work / f"{method}_t{threads}"
            shutil.rmtree(folder, ignore_errors=True)
            config_path = work / f"{method}_t{threads}.json"
            config_path.write_text(json.dumps(config))
            print(f"gail_speed.py: {method}, {threads} thread(s), {args.env_steps} env steps per task...",
                  file=sys.stderr, flush=True)
            subprocess.run([args.maps, "train", "--config", str(config_path), "--out", str(folder)], check=True,
                           stdout=subprocess.DEVNULL)
            train = json.loads((folder / "train.json").read_text())
            tasks = len(train["training_demo_seeds"])
            seconds = train["seconds_this_process"]
            record = {"method": method, "threads": threads, "tasks": tasks, "cpu": cpu_model(),
                      "env_steps": train["env_steps_this_process"], "seconds": seconds,
                      "env_steps_per_second": train["env_steps_this_process"] / seconds}
            record.update({key: train[key] for key, _ in PARTS})
            records.append(record)
    pathlib.Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    with open(args.out, "w") as f:
        for record in records:
            f.write(json.dumps(record) + "\n")
    print(f"CPU: {records[0]['cpu']}; {pathlib.Path(args.data).name}, every task, {args.env_steps} env steps per task")
    print("| method | threads | tasks | env steps | seconds | env steps per second | speed-up over 1 thread | "
          + " | ".join(label for _, label in PARTS) + " |")
    print("|---" * (7 + len(PARTS)) + "|")
    for r in records:
        one = next((o for o in records if o["method"] == r["method"] and o["threads"] == 1), None)
        speedup = f"{r['env_steps_per_second'] / one['env_steps_per_second']:.2f}x" if one else "-"
        shares = " | ".join(f"{100 * r[key] / r['seconds']:.0f}%" for key, _ in PARTS)
        print(f"| {r['method']} | {r['threads']} | {r['tasks']} | {r['env_steps']:,} | {r['seconds']:.1f} |"
              f" {r['env_steps_per_second']:,.0f} | {speedup} | {shares} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
