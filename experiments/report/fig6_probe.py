#!/usr/bin/env python3
"""Fig. 6 probe of one trained MAPS run: what each module does alone, and frame strips of it.

    experiments/report/fig6_probe.py CELL --out DIR [--tasks drawer-open drawer-close window-open]
                                     [--episodes 20] [--maps build/bin/maps]

1. `maps eval --run CELL --each-module` (unless CELL/eval_modules.json exists): every task scored with the
   selector, and with every score forced onto each module in turn.
2. For each task asked for, `maps render` strips of one evaluation episode: the policy as trained, its most used
   module (module usage in CELL/eval.json or result.json) forced, and the module that alone scores best on the task
   forced (when another).
3. DIR/modules.md: the usage and the forced-module scores of those tasks, with the strips.
"""
import argparse
import pathlib
import subprocess
import sys

from suite_results import JsonTooDeep, read_json


def short(task):
    return task.split("/", 1)[-1]


def read_probe(path):
    """eval_modules.json (maps-eval-modules/1), checked; exits naming the file when it is not one."""
    try:
        record = read_json(path)
        if record.get("format") != "maps-eval-modules/1":
            raise ValueError(f"format {record.get('format')!r}, expected 'maps-eval-modules/1'")
        count = len(record["tasks"])
        for entry in [record["selector"]] + record["modules"]:
            if len(entry["scores"]) != count:
                raise ValueError(f"{len(entry['scores'])} scores for {count} tasks")
        if not record["modules"]:
            raise ValueError("no modules")
        return record
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as e:
        sys.exit(f"{path}: not a readable module probe ({e}); delete it and rerun to probe again")


def usage_by_task(cell):
    for name in ("eval.json", "result.json"):
        path = cell / name
        if path.exists():
            try:
                record = read_json(path)
            except JsonTooDeep as e:
                sys.exit(str(e))
            tasks = record["eval"]["tasks"] if name == "result.json" else record["tasks"]
            if all("module_usage" in t for t in tasks):
                return {short(t["task"]): t["module_usage"] for t in tasks}
    sys.exit(f"{cell}: no module usage in eval.json or result.json (is it a finished MAPS run?)")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("cell", type=pathlib.Path)
    parser.add_argument("--out", type=pathlib.Path, required=True)
    parser.add_argument("--tasks", nargs="+", default=["drawer-open", "drawer-close", "window-open"])
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--maps", default="build/bin/maps")
    args = parser.parse_args()

    probe = args.cell / "eval_modules.json"
    if not probe.exists():
        subprocess.run([args.maps, "eval", "--run", str(args.cell), "--each-module", "--episodes",
                        str(args.episodes), "--threads", "1"], check=True)
    record = read_probe(probe)
    tasks = [short(t) for t in record["tasks"]]
    missing = [t for t in args.tasks if t not in tasks]
    if missing:
        sys.exit(f"--tasks: {', '.join(missing)} not among {args.cell}'s tasks ({', '.join(tasks)})")
    usage = usage_by_task(args.cell)
    set_name = record["tasks"][0].split("/", 1)[0]
    args.out.mkdir(parents=True, exist_ok=True)

    lines = [f"# Fig. 6 probe of {args.cell}", "",
             f"Best-validation checkpoint (step {record['best_step']}); {record['episodes']} evaluation episodes per "
             f"task from seed {record['first_seed']}. 'alone' = the score with every selector score forced onto "
             "that one module.", "",
             "| task | with the selector | most used module (usage) | its score alone | best module alone (score) |",
             "|---|---|---|---|---|"]
    strips = []
    for task in args.tasks:
        k = tasks.index(task)
        used = max(range(len(usage[task])), key=lambda j: usage[task][j])
        alone = [m["scores"][k] for m in record["modules"]]
        best = max(range(len(alone)), key=lambda j: alone[j])
        lines.append(f"| {task} | {record['selector']['scores'][k]:.2f} | m{used} ({usage[task][used]:.2f}) | "
                     f"{alone[used]:.2f} | m{best} ({alone[best]:.2f}) |")
        for label, module in [("selector", None), (f"module{used}", used)] + \
                ([(f"module{best}", best)] if best != used else []):
            png = args.out / f"{task}_{label}.png"
            command = [args.maps, "render", "--run", str(args.cell), "--task", f"{set_name}/{task}", "--frames", "5",
                       "--width", "256", "--height", "192", "--out", str(png)]
            if module is not None:
                command += ["--module", str(module)]
            said = subprocess.run(command, check=True, capture_output=True, text=True).stdout.strip().splitlines()
            strips.append((task, label, png.name, said[-1] if said else ""))
    lines += ["", "Module usage of every task (mean selector score over its evaluation states) and every module's "
              "score alone:", "",
              "| task | " + " | ".join(f"m{j}" for j in range(len(record["modules"]))) + " | with the selector |",
              "|---|" + "---|" * (len(record["modules"]) + 1)]
    for k, task in enumerate(tasks):
        cells = [f"{usage[task][j]:.2f} / {record['modules'][j]['scores'][k]:.2f}" for j in range(len(record["modules"]))]
        lines.append(f"| {task} | " + " | ".join(cells) + f" | {record['selector']['scores'][k]:.2f} |")
    lines += ["", "(each entry: usage / score alone)", ""]
    for task, label, name, said in strips:
        lines += [f"**{task}, {label}**: {said.split(': ', 1)[-1] if said else ''}", "", f"![]({name})", ""]
    (args.out / "modules.md").write_text("\n".join(lines))
    print(f"wrote {args.out / 'modules.md'} and {len(strips)} strips")


if __name__ == "__main__":
    main()
