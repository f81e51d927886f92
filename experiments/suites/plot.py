#!/usr/bin/python3
"""Plots of a grid's results (experiments/suites/run_grid.sh), as PNG files in OUT (default: the grid folder):
- scores.png: mean normalised score over tasks against demos per task, one line per method (95% CI over seeds);
- validation.png: validation BC loss against training step, one panel per demo count, each method's mean over
  seeds (the curves a step budget is chosen from);
- module_usage.png: MAPS's module usage per task (one panel per demo count, the lowest seed's run).

    /usr/bin/python3 experiments/suites/plot.py results/compare-gravity-20k [OUT]

Needs matplotlib (Debian: python3-matplotlib; scripts/setup.sh installs it).
"""
import pathlib
import statistics
import sys

from grid_results import ci95, cells, load_runs

try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    sys.exit("plot.py: matplotlib is missing (apt-get install python3-matplotlib, or bash scripts/setup.sh)")


def colors_of(by_cell):
    """One colour per method label, the same in every plot."""
    palette = plt.get_cmap("tab10").colors
    return {label: palette[i % len(palette)] for i, label in enumerate(sorted({lab for lab, _, _ in by_cell}))}


def plot_scores(by_cell, out):
    fig, ax = plt.subplots(figsize=(6, 4))
    colors = colors_of(by_cell)
    for label in sorted(colors):
        keys = sorted((d, k) for lab, d, k in by_cell if lab == label)
        xs = [d for d, _ in keys]
        means = [statistics.mean(r.eval["mean_score"] for r in by_cell[(label, d, k)]) for d, k in keys]
        errs = [ci95([r.eval["mean_score"] for r in by_cell[(label, d, k)]]) for d, k in keys]
        errs = [0.0 if e != e else e for e in errs]  # one seed: no interval
        ax.errorbar(xs, means, yerr=errs, marker="o", capsize=3, label=label, color=colors[label])
    ax.set_xlabel("demonstrations per task")
    ax.set_ylabel("normalised score (mean over tasks)")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "scores.png", dpi=120)
    plt.close(fig)


def plot_validation(by_cell, out):
    counts = sorted({(d, k) for _, d, k in by_cell})
    colors = colors_of(by_cell)
    fig, axes = plt.subplots(1, len(counts), figsize=(5 * len(counts), 4), squeeze=False)
    for ax, (demos, k) in zip(axes[0], counts):
        for label in sorted({lab for lab, d, kk in by_cell if (d, kk) == (demos, k)}):
            curves = [r.curve() for r in by_cell[(label, demos, k)]]
            curves = [c for c in curves if c[0]]
            if not curves:
                continue
            length = min(len(steps) for steps, _ in curves)
            steps = curves[0][0][:length]
            mean = [statistics.mean(valid[i] for _, valid in curves) for i in range(length)]
            ax.plot(steps, mean, label=label, color=colors[label])
        ax.set_yscale("log")
        ax.set_title(f"{demos} demos per task, k = {k}")
        ax.set_xlabel("training step")
        ax.set_ylabel("validation BC loss (mean over seeds)")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "validation.png", dpi=120)
    plt.close(fig)


def plot_usage(by_cell, out):
    keys = sorted((d, k) for label, d, k in by_cell if label == "maps")
    runs = [by_cell[("maps", d, k)][0] for d, k in keys]
    runs = [r for r in runs if "module_usage" in r.eval["tasks"][0]]
    if not runs:
        return False
    fig, axes = plt.subplots(1, len(runs), figsize=(5 * len(runs), 3.2), squeeze=False)
    for ax, run in zip(axes[0], runs):
        usage = [t["module_usage"] for t in run.eval["tasks"]]
        image = ax.imshow(usage, cmap="viridis", vmin=0.0, vmax=max(0.3, max(max(u) for u in usage)))
        ax.set_yticks(range(len(usage)), run.tasks, fontsize=8)
        ax.set_xticks(range(len(usage[0])), [f"m{i}" for i in range(len(usage[0]))], fontsize=8)
        ax.set_title(f"MAPS module usage, {run.demos} demos, seed {run.seed}", fontsize=9)
        fig.colorbar(image, ax=ax, fraction=0.046)
    fig.tight_layout()
    fig.savefig(out / "module_usage.png", dpi=120)
    plt.close(fig)
    return True


def main(root, out):
    by_cell = cells(load_runs(root))
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    plot_scores(by_cell, out)
    plot_validation(by_cell, out)
    written = ["scores.png", "validation.png"] + (["module_usage.png"] if plot_usage(by_cell, out) else [])
    print("plots: " + ", ".join(str(out / name) for name in written))


if __name__ == "__main__":
    if len(sys.argv) not in (2, 3):
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2] if len(sys.argv) == 3 else sys.argv[1])
