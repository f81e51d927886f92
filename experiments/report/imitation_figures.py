"""The figures of GAIL against BC (issue 45, docs/adversarial.md), each with its numbers in a CSV beside it:

    imitation_scores.png  mean score over tasks against demos per task, one panel per set: each method under BC (solid,
                          on to the counts only BC ran) and under GAIL (dashed), band: 95% CI over seeds
    gail_module_usage.png MAPS's per-task module usage under BC and under GAIL, one seed per setting, side by side
    gail_curves.png       GAIL's learning curves: the training episodes' return over the expert's (mean over tasks,
                          then over seeds) against env steps per task, one panel per set and demo count, each
                          method's BC score (evaluated) as a dotted line for reference

Each function returns the Figures it wrote, or [] when the suite has no GAIL cells."""
import csv

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from figures import (Figure, color, legend_below, line_with_band, name, save, score_limits, setting_axes,  # noqa: E402
                     setting_panels, write_csv)
from imitation import MAIN_VARIANTS, by_objective, network, objective, training_curve  # noqa: E402
from suite_results import SET_ORDER, order, score_name, short_task, success_scored  # noqa: E402
from suite_stats import ci95, describe_n, mean, span  # noqa: E402

STYLES = {"bc": {"linestyle": "-"}, "gail": {"linestyle": "--", "markerfacecolor": "white"}}
OBJECTIVE_NAMES = {"bc": "BC", "gail": "GAIL"}
LINES = ["-", "-.", (0, (5, 1)), (0, (3, 1, 1, 1, 1, 1)), (0, (1, 1)), (0, (8, 2, 2, 2))]


def written(fig, out, stem, header, rows, caption):
    """Saves the figure as stem.png and its numbers as stem.csv; [its Figure]."""
    save(fig, out, f"{stem}.png")
    write_csv(out / f"{stem}.csv", header, rows)
    return [Figure(f"{stem}.png", caption)]


def mine_cells(settings):
    return [c for runs in settings.values() for kind in runs.values() for c in kind]


def variant_name(method, variant):
    """"MAPS" for the suite's own GAIL runs (MAIN_VARIANTS: one line style and legend entry on every set, MT10's
    settings said in the captions), "MAPS (pilot_b)" for another GAIL variant."""
    return name(method) + ("" if variant in MAIN_VARIANTS else f" ({variant})")


def main_variants_note(cells):
    """Which of the suite's own GAIL variants ran on which set, where it ran more than one (their lines share a style
    and a legend entry): " The suite's GAIL runs: gail on gravity and modified, gail_mt10 on mt10."; "" otherwise."""
    sets = {}
    for c in cells:
        if objective(c) == "gail" and c.variant in MAIN_VARIANTS:
            sets.setdefault(c.variant, set()).add(c.set)
    if len(sets) < 2:
        return ""
    return (" The suite's GAIL runs (one style and legend entry): "
            + ", ".join(f"{v} on {' and '.join(order(SET_ORDER, sets[v]))}" for v in MAIN_VARIANTS if v in sets) + ".")


def bc_identity(cell):
    """What makes BC cells one line: the label (method and BC variant), the network and the subsampling."""
    return cell.label, network(cell), cell.subsample


def extend_bc_line(cells, set_name, xs, runs):
    """A BC line's counts and runs (xs, runs) grown by the counts where its cells' network ran BC alone, with no GAIL
    setting to pair with (the study's 10 on the cheetah): BC cells of the set of the line's one identity (bc_identity).
    A line whose partners differ in identity from count to count is left as it is: there is no one curve to extend."""
    identities = {bc_identity(c) for r in runs for c in r}
    if len(identities) != 1:
        return xs, runs
    identity = identities.pop()
    more = {}
    for c in cells:
        if objective(c) == "bc" and c.set == set_name and bc_identity(c) == identity and c.demos not in xs:
            more.setdefault(c.demos, []).append(c)
    grown = sorted(list(zip(xs, runs)) + list(more.items()), key=lambda item: item[0])
    return [x for x, _ in grown], [r for _, r in grown]


def imitation_scores(cells, out):
    settings = by_objective(cells)
    sets = order(SET_ORDER, {s.set for s in settings})
    if not sets:
        return []
    fig, axes = plt.subplots(1, len(sets), figsize=(max(6.5, 5.2 * len(sets)), 5.0), squeeze=False)
    rows, drawn = [], []
    for ax, set_name in zip(axes[0], sets):
        mine = {s: runs for s, runs in settings.items() if s.set == set_name}
        means = []
        bc_points = set()  # (BC identity, demos) drawn on this panel: two GAIL variants of one network share them
        for method, variant in dict.fromkeys((s.method, s.variant) for s in mine):
            for kind in ("bc", "gail"):
                keys = sorted((s for s in mine if (s.method, s.variant) == (method, variant) and mine[s][kind]),
                              key=lambda s: s.demos)
                if not keys or (kind == "bc" and variant not in MAIN_VARIANTS and any(
                        mine.get(s._replace(variant=main), {}).get("bc") == mine[s]["bc"]
                        for s in keys for main in MAIN_VARIANTS)):
                    continue  # BC's line once per method and network (beside the suite's own GAIL variant)
                xs, runs = [s.demos for s in keys], [mine[s][kind] for s in keys]
                bc_label = mine[keys[0]]["bc"][0].label if mine[keys[0]]["bc"] else method
                if kind == "bc":
                    xs, runs = extend_bc_line(cells, set_name, xs, runs)
                    kept = [(x, r) for x, r in zip(xs, runs) if (bc_identity(r[0]), x) not in bc_points]
                    if not kept:
                        continue
                    xs, runs = [x for x, _ in kept], [r for _, r in kept]
                    bc_points |= {(bc_identity(r[0]), x) for x, r in kept}
                shown = (name(method) + bc_label[len(method):] if kind == "bc" else variant_name(method, variant))
                # A width control (its BC partner a variant of the method, "mt_bc (w430)"): square markers.
                style = dict(STYLES[kind], **({} if bc_label == method else {"marker": "s"}))
                points = line_with_band(ax, xs, runs, lambda c: c.mean_score,
                                        color=color(method), label=f"{shown}, {OBJECTIVE_NAMES[kind]}", **style)
                rows += [[set_name, bc_label if kind == "bc" else method, kind if kind == "bc" else variant, x,
                          keys[0].subsample, n, m, h] for x, n, m, h in points]
                means += [m for _, _, m, _ in points]
                drawn += [c for r in runs for c in r]
        ax.set_title(f"{set_name}", fontsize=9)
        ax.set_xlabel("demonstrations per task")
        ax.set_ylabel(f"{score_name(set_name, drawn, short=True)}\n(mean over tasks)")
        ax.set_xticks(sorted({r[3] for r in rows if r[0] == set_name}))
        score_limits(ax, set_name, drawn, means)
        ax.grid(alpha=0.3)
    legend_below(fig, axes[0], 3)
    fig.suptitle("Mean score over tasks against demos per task\nBC: solid; GAIL: dashed, hollow markers\n"
                 "(mean over seeds, band: 95% CI)")
    fig.tight_layout(rect=(0, 0.14, 1, 1))
    return written(fig, out, "imitation_scores", ["set", "method", "objective", "demos", "subsample", "seeds", "mean",
                                                  "ci95"], rows,
                   "Each set's mean score over its tasks against demonstrations per task, each method trained by BC"
                   " (solid) and by GAIL (dashed, hollow markers; square markers: a width control beside its BC"
                   " partner of the same width; BC's line runs on to the counts only BC ran); points are means"
                   " over seeds, the band the 95% CI"
                   f" over seeds. {describe_n(drawn)} (GAIL: iterations). The same evaluation for both"
                   f" (the mean action).{main_variants_note(drawn)}")


def describe_curves(cells, seed_counts):
    """"n = 3 seeds per point, 2 training episodes per task per iteration (500 iterations)": what a curve's point
    averages, the training episodes (not the evaluation's), ranges where the cells differ."""
    # 2: GailConfig's default (maps/adversarial/gail_config.h), for a config that leaves the key out.
    episodes = "/".join(str(e) for e in sorted({int(c.config.get("gail", {}).get("rollout_episodes", 2))
                                                 for c in cells}))
    iterations = "/".join(str(s) for s in sorted({c.steps for c in cells}))
    return (f"n = {span(sorted(seed_counts))} seed{'s' if max(seed_counts) > 1 else ''} per point, {episodes} training"
            f" episodes per task per iteration ({iterations} iterations)")


def gail_curves(cells, out):
    settings = by_objective(cells)
    sets = order(SET_ORDER, {s.set for s in settings})
    if not sets:
        return []
    fig, axes, height = setting_panels([{(s.demos, s.subsample) for s in settings if s.set == name_}
                                        for name_ in sets])
    rows, drawn, used, seed_counts = [], False, [], []
    others = sorted({s.variant for s in settings} - set(MAIN_VARIANTS))  # the suite's own runs: LINES[0]
    for ax, set_name, (demos, k), panel in setting_axes(axes, sets, list(settings)):
        mine = {s: settings[s] for s in panel}
        shown = []  # the panel's means and BC lines: its y range (a band of two seeds can span -1 to 3)
        bc_drawn = set()
        for setting in panel:
            curves = [c for c in (training_curve(c) for c in mine[setting]["gail"]) if c]
            if not curves:
                continue
            used += mine[setting]["gail"]
            seed_counts.append(len(curves))
            steps = sorted(set.intersection(*(set(c) for c in curves)))
            values = [[c[s] for c in curves] for s in steps]
            means = np.array([mean(v) for v in values])
            half = np.array([ci95(v) for v in values])
            line = 0 if setting.variant in MAIN_VARIANTS else 1 + others.index(setting.variant)
            ax.plot(steps, means, color=color(setting.method), linestyle=LINES[line % len(LINES)],
                    label=f"{variant_name(setting.method, setting.variant)}, GAIL (training)")
            ax.fill_between(steps, means - half, means + half, where=np.isfinite(half), alpha=0.15,
                            color=color(setting.method), linewidth=0)
            rows += [[set_name, setting.method, setting.variant, demos, k, s, len(curves), m, h]
                     for s, m, h in zip(steps, means, half)]
            shown += list(means)
            # One BC line per BC partner: GAIL variants of one network share it, a width control has its own
            # (drawn dash-dotted, labelled with its variant).
            bc = mine[setting]["bc"]
            partner = frozenset(id(c) for c in bc)
            if bc and partner not in bc_drawn:
                bc_drawn.add(partner)
                shown.append(mean([c.mean_score for c in bc]))
                own = bc[0].label == bc[0].method
                ax.axhline(shown[-1], color=color(setting.method), linestyle=":" if own else (0, (1, 2, 4, 2)),
                           label=f"{name(setting.method)}{'' if own else f' ({bc[0].variant})'}, BC (evaluated)")
            drawn = True
        ax.set_title(f"{set_name}, {demos} demos per task, k = {k}")
        ax.set_xlabel("env steps per task")
        ax.set_ylabel("success rate (training episodes)" if success_scored(set_name, mine_cells(mine))
                      else "return / expert's return\n(mean over tasks)")
        if shown:  # bands past the means' range by more than a tenth are clipped
            low, high = min(shown), max(shown)
            ax.set_ylim(min(low, 0.0) - 0.1, max(high, 1.0) + 0.1)
        ax.grid(alpha=0.3)
    if not drawn:
        plt.close(fig)
        return []
    legend_below(fig, axes.flat, 2)
    fig.suptitle("GAIL's learning curves: training return over the expert's against env steps per task\n"
                 "(mean over seeds, band: 95% CI; dotted: the same network's BC score)")
    fig.tight_layout(rect=(0, 1.0 / height, 1, 1))
    return written(fig, out, "gail_curves", ["set", "method", "variant", "demos", "subsample", "env_steps_per_task",
                                             "seeds", "mean", "ci95"], rows,
                   "GAIL's learning curves: each iteration's training episodes (actions drawn from the policy's"
                   " Gaussian, so below what the mean action scores) as return over the task's expert return, mean"
                   " over tasks, then over seeds (band: 95% CI; each panel's y range spans its means and BC lines,"
                   " and 0 to 1, with a tenth to spare, so a wider band is cut off), against env steps per task; the"
                   " dotted line is the same network's BC score at the same demos (evaluated, the mean action; a width"
                   " control's BC partner dash-dotted, labelled with its variant)."
                   f" {describe_curves(used, seed_counts)}.{main_variants_note(used)}")


def panel_rows(keys, sets):
    """{set: its (demos, k) settings in order}, of keys (set, demos, k, ...): row r of a figure shows each set's r-th
    setting, so that MT10's k = 1 and the cheetah sets' k = 10 share rows rather than each leaving the other's
    empty."""
    return {set_name: sorted({key[1:3] for key in keys if key[0] == set_name}) for set_name in sets}


def gail_module_usage(cells, out):
    """MAPS's per-task module usage under BC and under GAIL side by side, a heatmap (tasks x modules) per objective for
    each set (a pair of columns) and setting (demos and k: the set's r-th in row r, so that a set's rows are not left
    empty where another set has other settings), one seed (the lowest both objectives ran: module indices mean
    nothing across runs), the modules of each panel sorted by their total usage so that the two panels' shapes
    compare; one colour scale for all."""
    panels = {}
    for setting, runs in by_objective(cells).items():
        key = (setting.set, setting.demos, setting.subsample)
        if setting.method != "maps" or (key in panels and setting.variant not in MAIN_VARIANTS):
            continue  # one GAIL variant per setting: the suite's own (MAIN_VARIANTS), else the first (a pilot's)
        bc = {c.seed: c for c in runs["bc"] if c.has_usage}
        gail = {c.seed: c for c in runs["gail"] if c.has_usage}
        both = sorted(set(bc) & set(gail))
        if both:
            panels[key] = (bc[both[0]], gail[both[0]], setting.variant)
    if not panels:
        return []
    sets = order(SET_ORDER, {key[0] for key in panels})
    usage_of = {}
    for key, pair in panels.items():
        gail_tasks = {t.task for t in pair[1].tasks}
        tasks = [t.task for t in pair[0].tasks if t.task in gail_tasks]  # the tasks both runs were evaluated on
        if not tasks:
            continue
        for kind, cell in zip(("bc", "gail"), pair[:2]):
            by_task = {t.task: t.usage for t in cell.tasks}
            shown = OBJECTIVE_NAMES[kind] + (f" ({pair[2]})" if kind == "gail" and pair[2] not in MAIN_VARIANTS
                                             else "")
            usage_of[key + (kind,)] = (tasks, cell.seed, np.array([by_task[task] for task in tasks], dtype=float),
                                       shown)
    if not usage_of:
        return []
    top = max(0.5, max(float(u.max()) for _, _, u, _ in usage_of.values()))
    settings_of = panel_rows(usage_of, sets)
    height = max(len(settings) for settings in settings_of.values())
    fig, axes = plt.subplots(height, 2 * len(sets), figsize=(4.2 * len(sets) + 1.5, 2.9 * height + 1.2),
                             squeeze=False)
    rows, image = [], None
    for s_, set_name in enumerate(sets):
        for r in range(height):
            for c, kind in enumerate(("bc", "gail")):
                ax = axes[r, 2 * s_ + c]
                if r >= len(settings_of[set_name]):
                    ax.set_visible(False)
                    continue
                demos, k = settings_of[set_name][r]
                found = usage_of.get((set_name, demos, k, kind))
                if found is None:
                    ax.set_visible(False)
                    continue
                tasks, seed, usage, shown = found
                order_ = np.argsort(-usage.sum(axis=0), kind="stable")
                image = ax.imshow(usage[:, order_], cmap="viridis", vmin=0, vmax=top, aspect="auto")
                ax.set_yticks(range(len(tasks)), [short_task(t) for t in tasks] if c == 0 else [], fontsize=7)
                ax.set_xticks(range(len(order_)), [str(m) for m in order_], fontsize=6)
                ax.set_xlabel("module (index as trained)", fontsize=7)
                ax.set_title(f"{set_name}, {demos} demos, k = {k}\n{shown}, seed {seed}", fontsize=8)
                rows += [[set_name, demos, k, kind, seed, task, m, usage[i, m]]
                         for i, task in enumerate(tasks) for m in range(usage.shape[1])]
    fig.suptitle("MAPS's module usage per task under BC and under GAIL: the mean selector score over the task's"
                 " evaluation states\n(one seed each; each panel's modules sorted by total usage, since indices mean"
                 " nothing across runs)", fontsize=9)
    fig.tight_layout(rect=(0, 0, 0.9, 0.95))
    fig.colorbar(image, cax=fig.add_axes((0.92, 0.1, 0.012, 0.75)), label="usage")
    return written(fig, out, "gail_module_usage", ["set", "demos", "subsample", "objective", "seed", "task", "module",
                                                   "usage"], rows,
                   "MAPS's module usage per task (rows) and module (columns: each panel's modules sorted by their"
                   " total usage, labelled with their indices as trained), the mean selector score over the task's"
                   " evaluation states, under BC and under GAIL side by side, one seed per setting (the lowest both"
                   " ran: module indices mean nothing across runs, so the panels compare in shape, not module by"
                   " module); uniform routing over M modules is 1/M everywhere. The routing table above gives every"
                   f" seed's numbers.{main_variants_note([c for pair in panels.values() for c in pair[:2]])}")
