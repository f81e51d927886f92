"""The figures of a suite report (PNG, matplotlib Agg), each with its numbers in a CSV file beside it:

    fig2_scores.png        Fig. 2: mean score over tasks against demos per task, one panel per set, one line per method
    fig2_tasks_<set>.png   the per-task bars beside it: per demo count, each task's mean score per method
    fig3_vs_single_bc.png  Fig. 3: shares of (set, task, demos) settings better / worse than Single BC
    fig4_ablations.png     Fig. 4: MAPS with a selector term zeroed: module usage and score against demos
    fig5_modules_heatmap.png  Fig. 5: MAPS's mean score by number of modules M and demos
    fig6_module_usage.png  Fig. 6 (left): MAPS's per-task module usage on MT10, one seed
    zoo_routing.png        every routing method's per-task module usage (the zoo, docs/zoo.md), one seed each
    validation.png         validation BC loss against training step, mean over seeds per method
    denoising_validation.png  Diffusion Policy's validation denoising loss against training step, per denoiser

Each function returns the Figures it wrote ((file name, caption) pairs; the caption says what n is and what the
score is), or [] when the suite has no data for it. One colour per method everywhere (the paper's). Beside a
quick-scale suite (report.py), fig2_scores and fig4_ablations also draw the committed study's scores of the same
methods, hollow on dashed lines (their numbers in fig2_scores_study.csv, fig4_ablations_study.csv)."""
import csv
import math
from collections import namedtuple

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker as ticker  # noqa: E402
import numpy as np  # noqa: E402

from suite_results import (METHOD_NAMES, METHOD_ORDER, SET_ORDER, ablation_cells, ablation_groups,  # noqa: E402
                           compared_cells, display_label as label_name, groups, label_rank, maps_reference,
                           method_of_label, module_sweep_cells, order, score_name, short_task, shown_variant,
                           success_scored, task_names, task_score)
from suite_stats import (MUCH_BETTER, ci95, describe_n, mean, sorted_usage, span, usage_distances,  # noqa: E402
                         vs_single_bc)

Figure = namedtuple("Figure", "file caption")
DPI = 120
COLORS = {"maps": "tab:blue", "maml": "tab:orange", "mt_bc": "m", "mt_mh_bc": "tab:red", "single_bc": "tab:green",
          "transfer": "tab:cyan", "moore": "tab:purple", "paco": "tab:brown", "care": "tab:olive",
          "top_k_moe": "tab:gray", "soft_modularization": "tab:pink", "diffusion_policy": "darkgoldenrod"}
SPARE = ["tab:purple", "tab:brown", "tab:gray", "tab:olive", "tab:cyan", "k"]
# MAPS's variants in Fig. 4 (base MAPS keeps its blue): colours no method has.
VARIANT_COLORS = ["tab:purple", "tab:brown", "tab:olive", "tab:cyan", "tab:gray", "tab:pink", "k", "gold"]
# For a figure whose variants are lines of their own beside many methods (label_style): distinct named colours.
MORE_COLORS = ["teal", "navy", "crimson", "darkorange", "slateblue", "sienna", "orchid", "turquoise", "indigo",
               "chartreuse", "salmon", "olivedrab"]

plt.rcParams.update({"font.size": 10, "axes.titlesize": 10, "legend.fontsize": 9, "figure.titlesize": 11})


def name(method):
    return METHOD_NAMES.get(method, method)


def color(method):
    if method in COLORS:
        return COLORS[method]
    return SPARE[sum(map(ord, method)) % len(SPARE)]  # the same in every run


def base_cells(cells):
    """The cells of the methods themselves (no variants)."""
    return [c for c in cells if c.label == c.method]


def methods_of(cells):
    """The cells' labels (a method, or "method (variant)"), by method in the report's order, each method's own cells
    before its variants'."""
    return sorted({c.label for c in cells}, key=label_rank)


def label_style(label, labels):
    """Colour, line and marker of a label among `labels` (all of a figure's, so that a label looks the same in every
    panel): a method its own colour; a variant of a method among them that colour, dashed, with squares (and hatched
    bars); a variant whose method is not among them (Diffusion Policy's denoisers) a colour no method there has, in
    order."""
    method = method_of_label(label)
    if label == method:
        return {"color": color(method)}
    if method in labels:
        return {"color": color(method), "linestyle": "--", "marker": "s", "hatch": "//"}
    taken = {color(m) for m in labels if m == method_of_label(m)}
    palette = list(dict.fromkeys(VARIANT_COLORS + SPARE + MORE_COLORS))
    free = [c for c in palette if c not in taken]
    alone = [other for other in labels if other != method_of_label(other) and method_of_label(other) not in labels]
    return {"color": free[alone.index(label) % len(free)]}


def stats(values):
    """(mean, CI half-width with nan as 0) for plotting."""
    half = ci95(values)
    return mean(values), 0.0 if half != half else half


def write_csv(path, header, rows):
    with path.open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(header)
        writer.writerows(rows)


def save(fig, out, file):
    fig.savefig(out / file, dpi=DPI)
    plt.close(fig)


def line_with_band(ax, xs, runs_per_x, value, dodge=0.0, **style):
    """Mean over seeds at each x, a shaded 95% band between points with 2+ seeds; returns the (x, n, mean, ci)
    rows. A lone point (one demo count) gets an error bar instead, drawn `dodge` to the side so that the methods'
    bars at one x stay apart."""
    rows = []
    for x, runs in zip(xs, runs_per_x):
        vals = [value(c) for c in runs]
        rows.append((x, len(vals), mean(vals), ci95(vals)))
    ys = np.array([r[2] for r in rows])
    half = np.array([r[3] for r in rows])
    marker = style.pop("marker", "o")
    if len(xs) == 1:
        ax.errorbar([xs[0] + dodge], ys, yerr=np.nan_to_num(half), fmt=marker, capsize=4, **style)
        return rows
    ax.plot(xs, ys, marker=marker, **style)
    ax.fill_between(xs, ys - half, ys + half, where=np.isfinite(half), alpha=0.15, color=style.get("color"),
                    linewidth=0)
    return rows


STUDY_STYLE = {"linestyle": "--", "marker": "o", "markerfacecolor": "white", "capsize": 2, "linewidth": 1.0}


def dodge_unit(cells):
    """How far apart (in demos) lone points of different methods are drawn: 0.12 on an axis of one count, a fortieth
    of the axis's span when the study's counts widen it."""
    demos = [c.demos for c in cells]
    return max(0.12, (max(demos) - min(demos)) / 40)


def study_line(ax, study, set_name, label, subsample, color):
    """The study's mean score over tasks (hollow markers on a dashed line, error bars its 95% CI over seeds) of the
    study cells `study` labelled `label` on the set at that k, at every demo count it ran; returns the (x, n, mean,
    ci) rows, [] when it has none."""
    by_key = groups([c for c in study if c.set == set_name and c.label == label and c.subsample == subsample])
    rows = [(key.demos, len(runs), mean([c.mean_score for c in runs]), ci95([c.mean_score for c in runs]))
            for key, runs in sorted(by_key.items(), key=lambda item: item[0].demos)]
    if rows:
        ax.errorbar([r[0] for r in rows], [r[2] for r in rows], yerr=np.nan_to_num([r[3] for r in rows]),
                    color=color, **STUDY_STYLE)
    return rows


def steps_and_seeds(cells):
    """"1000 steps, 2 seeds" (seeds per point; ranges where they differ)."""
    steps = "/".join(str(s) for s in sorted({c.steps for c in cells}))
    per_point = sorted(len(runs) for runs in groups(cells).values())
    return f"{steps} steps, {span(per_point)} seed{'s' if per_point[-1] > 1 else ''}"


def study_legend(ax, cells, drawn):
    """The legend's two entries that tell the suite's points from the study's (added to ax's labelled lines):
    "filled: this suite (1000 steps, 2 seeds)", "hollow, dashed: study (20000 steps, 5 seeds)"."""
    ax.errorbar([], [], yerr=[], color="0.35", fmt="o", capsize=4,
                label=f"filled: this suite ({steps_and_seeds(cells)})")
    ax.errorbar([], [], yerr=[], color="0.35", label=f"hollow, dashed: study ({steps_and_seeds(drawn)})",
                **STUDY_STYLE)


def score_limits(ax, set_name, cells, means):
    """0 to just above 1 for success rates; for normalised returns (not capped) enough for the largest mean. Bands
    and error bars past it are clipped."""
    top = 1.05 if success_scored(set_name, cells) else max(1.1, 1.2 * max(means, default=1.0))
    ax.set_ylim(0, top)


def seeds(n):
    return f"{n} seed{'' if n == 1 else 's'}"


def legend_below(fig, axes, columns):
    """One legend for the figure, below the panels, from the labelled lines and bars of all axes."""
    handles = {}
    for ax in axes:
        for handle, text in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(text, handle)
    fig.legend(handles.values(), handles.keys(), loc="lower center", ncol=min(columns, len(handles)),
               frameon=False)


def fig2_scores(cells, out, study=None, variants_are_methods=False):
    """One panel per set: each method's mean score over tasks against demos per task, band: 95% CI over seeds; with
    `study` (the study's cells beside a quick-scale suite), the study's scores of the same methods, hollow and
    dashed. `variants_are_methods` (report.holm "set"): every variant a line of its own (compared_cells)."""
    cells = compared_cells(cells, variants_are_methods)
    sets = order(SET_ORDER, {c.set for c in cells})
    if not sets:
        return []
    study = base_cells(study or [])
    fig, axes = plt.subplots(1, len(sets), figsize=(max(6.5, 5.2 * len(sets)), 5.0), squeeze=False)
    rows, study_rows, drawn = [], [], []
    every_label = methods_of(cells)
    for ax, set_name in zip(axes[0], sets):
        mine = [c for c in cells if c.set == set_name]
        by_key = groups(mine)
        several_k = len({k.subsample for k in by_key}) > 1
        means = []
        lone = len({c.demos for c in mine}) == 1
        here = [c for c in study if c.set == set_name and c.label in {key.label for key in by_key}
                and c.subsample in {key.subsample for key in by_key}]
        apart = dodge_unit(mine + here)
        labels = methods_of(mine)
        for i, method in enumerate(labels):
            style = label_style(method, every_label)
            style.pop("hatch", None)
            for k in sorted({key.subsample for key in by_key if key.label == method}):
                keys = [key for key in by_key if key.label == method and key.subsample == k]
                label = label_name(method) + (f", k = {k}" if several_k else "")
                dodge = apart * (i - (len(labels) - 1) / 2) if lone else 0.0
                points = line_with_band(ax, [key.demos for key in keys], [by_key[key] for key in keys],
                                        lambda c: c.mean_score, dodge=dodge, label=label, **style)
                variant = shown_variant(by_key[keys[0]][0])
                rows += [[set_name, method_of_label(method), variant, x, k, n, m, h] for x, n, m, h in points]
                means += [m for _, _, m, _ in points]
                theirs = study_line(ax, study, set_name, method, k, style["color"])
                study_rows += [[set_name, method, "base", x, k, n, m, h] for x, n, m, h in theirs]
                means += [m for _, _, m, _ in theirs]
        drawn += here
        ax.set_title(f"{set_name} ({len(task_names(mine))} tasks)\n{describe_n(mine)}", fontsize=9)
        ax.set_xlabel("demonstrations per task")
        ax.set_ylabel(f"{score_name(set_name, mine, short=True)}\n(mean over tasks)")
        ax.set_xticks(sorted({c.demos for c in mine + here}))
        score_limits(ax, set_name, mine, means)
        ax.grid(alpha=0.3)
    if drawn:
        study_legend(axes[0][0], cells, drawn)
    entries = len({text for ax in axes[0] for text in ax.get_legend_handles_labels()[1]})
    columns = 3 if variants_are_methods else 6 if not drawn else 4
    extra_rows = max(0, -(-entries // columns) - (1 if not drawn else 2))
    # Room below the panels for the legend: 0.35 inches (0.6 with the study's two entries) and 0.25 a row more.
    height = 5.0 + 0.25 * extra_rows
    fig.set_figheight(height)
    legend_below(fig, axes[0], columns)
    fig.suptitle("Fig. 2: mean score over tasks against demos per task\n(mean over seeds, band: 95% CI)" if not drawn
                 else "Fig. 2: mean score over tasks against demos per task (mean over seeds, 95% CI)\nfilled: this"
                 f" suite at {'/'.join(str(s) for s in sorted({c.steps for c in cells}))} steps; hollow, dashed: the"
                 f" study at {'/'.join(str(s) for s in sorted({c.steps for c in drawn}))} steps, whose ranking this"
                 " is not")
    fig.tight_layout(rect=(0, ((0.35 if not drawn else 0.6) + 0.25 * extra_rows) / height, 1, 1))
    save(fig, out, "fig2_scores.png")
    header = ["set", "method", "variant", "demos", "subsample", "seeds", "mean", "ci95"]
    write_csv(out / "fig2_scores.csv", header, rows)
    drawn_as = ("each method and each of its variants (this suite's variants are methods of their own:"
                " report.holm \"set\"; a variant of a method drawn beside it is dashed, with squares)"
                if variants_are_methods else "each method (base variants)")
    caption = ("Fig. 2: each set's mean score over its tasks against the number of"
               f" demonstrations per task, for {drawn_as}; points are means over seeds, the band"
               f" the 95% CI over seeds (none where one seed ran). {describe_n(cells)}. Cheetah sets:"
               f" {score_name('gravity')}; MT10: {score_name('mt10')}.")
    if drawn:
        write_csv(out / "fig2_scores_study.csv", header, study_rows)
        caption += (" Hollow markers on dashed lines: the study's scores of the same methods at every count it ran"
                    f" (error bars: 95% CI over its seeds; {describe_n(drawn)}; fig2_scores_study.csv): this suite's"
                    " ranking is not the study's.")
    return [Figure("fig2_scores.png", caption)]


def fig2_tasks(cells, out, variants_are_methods=False):
    """Per set: one panel per (demos, k), each task's mean score per method with 95% CI error bars;
    `variants_are_methods` as in fig2_scores."""
    cells = compared_cells(cells, variants_are_methods)
    figures, rows = [], []
    for set_name in order(SET_ORDER, {c.set for c in cells}):
        mine = [c for c in cells if c.set == set_name]
        tasks, methods, by_key = task_names(mine), methods_of(mine), groups(mine)
        every_label = methods_of(cells)
        settings = sorted({(k.demos, k.subsample) for k in by_key})
        width = 0.8 / len(methods)
        fig, axes = plt.subplots(len(settings), 1, figsize=(max(7.0, 0.22 * len(tasks) * len(methods) + 2.5),
                                                             2.6 * len(settings) + 1.2), squeeze=False)
        for ax, (demos, k) in zip(axes[:, 0], settings):
            means = []
            for j, method in enumerate(methods):
                runs = by_key.get(next((key for key in by_key if key.label == method and key.demos == demos
                                        and key.subsample == k), None), [])
                if not runs:
                    continue
                scores = [[s for s in (task_score(c, t) for c in runs) if s is not None] for t in tasks]
                xs = np.arange(len(tasks)) - 0.4 + width * (j + 0.5)
                errors = [ci95(v) for v in scores]
                style = label_style(method, every_label)
                ax.bar(xs, [mean(v) for v in scores], width, capsize=2,
                       yerr=errors if any(np.isfinite(errors)) else None, color=style["color"],
                       hatch=style.get("hatch"), edgecolor="white" if "hatch" in style else None,
                       label=f"{label_name(method)} ({seeds(len(runs))})", error_kw={"lw": 0.8})
                means += [mean(v) for v in scores]
                for t in tasks:
                    vals = [s for s in (task_score(c, t) for c in runs) if s is not None]
                    rows.append([set_name, method_of_label(method), shown_variant(runs[0]), demos, k, t, len(vals),
                                 mean(vals), ci95(vals)])
            ax.set_title(f"{set_name}, {demos} demos per task, k = {k}")
            ax.set_xticks(range(len(tasks)), [short_task(t) for t in tasks], rotation=30 if len(tasks) > 5 else 0,
                          ha="right" if len(tasks) > 5 else "center")
            if ax is axes[-1, 0]:
                ax.set_xlabel(f"task ({set_name}/...)")
            ax.set_ylabel(score_name(set_name, mine, short=True).replace(" / ", " /\n"))
            score_limits(ax, set_name, mine, means)
            ax.grid(alpha=0.3, axis="y")
            ax.legend(loc="center left", bbox_to_anchor=(1.0, 0.5))
        fig.suptitle(f"Per-task scores, {set_name}: mean over seeds, bars: 95% CI\n{describe_n(mine)}")
        fig.tight_layout()
        file = f"fig2_tasks_{set_name}.png"
        save(fig, out, file)
        figures.append(Figure(file, f"Per-task scores on {set_name}: each task's mean over seeds per method and demo"
                              f" count, error bars the 95% CI over seeds (none where one seed ran; clipped at the"
                              f" top). {describe_n(mine)}. Score: {score_name(set_name, mine)}."))
    write_csv(out / "fig2_tasks.csv", ["set", "method", "variant", "demos", "subsample", "task", "seeds", "mean", "ci95"],
              rows)
    return figures


FIG3_BARS = [("better", "better"), ("worse", "worse"), ("much_better", f"better by > {100 * (MUCH_BETTER - 1):.0f}%"),
             ("significantly_better", "significantly\nbetter"), ("significantly_worse", "significantly\nworse")]


def fig3_vs_single_bc(cells, out):
    vs = vs_single_bc(cells)
    if not vs:
        return []
    methods = [m for m in order(METHOD_ORDER, {m for _, m in vs}) if ("all", m) in vs]
    fig, ax = plt.subplots(figsize=(max(7.5, 1.6 * len(FIG3_BARS) * len(methods) / 2 + 2), 4.6))
    width = 0.8 / len(methods)
    for j, method in enumerate(methods):
        v = vs[("all", method)]
        xs = np.arange(len(FIG3_BARS)) - 0.4 + width * (j + 0.5)
        shares = [v.share(field) for field, _ in FIG3_BARS]
        ax.bar(xs, shares, width, color=color(method), label=f"{name(method)} ({v.settings} settings)")
        for x, (field, _), share in zip(xs, FIG3_BARS, shares):
            ax.text(x, share + 0.01, f"{getattr(v, field)}", ha="center", va="bottom", fontsize=8)
    ax.set_xticks(range(len(FIG3_BARS)), [label for _, label in FIG3_BARS])
    ax.set_ylabel("share of (set, task, demos) settings")
    ax.set_ylim(0, 1.12)
    ax.grid(alpha=0.3, axis="y")
    ax.legend(loc="upper right")
    base = base_cells(cells)
    ax.set_title(f"Fig. 3: against Single BC, by each setting's mean score over seeds (numbers: counts)\n"
                 f"better by > {100 * (MUCH_BETTER - 1):.0f}%: score > {MUCH_BETTER} x Single BC's; significantly:"
                 f" paired over seeds, 95% CI of the difference excludes 0\n{describe_n(base)}", fontsize=9)
    fig.tight_layout()
    save(fig, out, "fig3_vs_single_bc.png")
    fields = [f for f in vs[next(iter(vs))].__dataclass_fields__]
    write_csv(out / "fig3_vs_single_bc.csv", ["set", "method"] + fields,
              [[where, method] + [getattr(v, f) for f in fields] for (where, method), v in
               sorted(vs.items(), key=lambda item: (item[0][0] == "all", item[0]))])
    return [Figure("fig3_vs_single_bc.png", "Fig. 3: for each method, the share of (set, task, demos) settings where"
                   " its mean score over seeds is better / worse than Single BC's, better by more than"
                   f" {100 * (MUCH_BETTER - 1):.0f}% (score > {MUCH_BETTER} x Single BC's), and significantly"
                   " better / worse (paired over the seeds both ran, 95% CI of the difference excluding 0; never with"
                   f" one seed). Per-setting counts are noisy at few seeds. {describe_n(base)}.")]


def variant_styles(labels):
    """Colours of Fig. 4's rows: base MAPS blue, each variant its own."""
    return {lab: ("tab:blue" if lab == "maps" else VARIANT_COLORS[i % len(VARIANT_COLORS)])
            for i, lab in enumerate(labels)}


def fig4_ablations(cells, out, study=None):
    sets = [s for s in order(SET_ORDER, {c.set for c in cells}) if ablation_cells([c for c in cells if c.set == s])]
    if not sets:
        return []
    study = study or []
    fig, axes = plt.subplots(len(sets), 3, figsize=(16, 4.6 * len(sets)), squeeze=False,
                             gridspec_kw={"width_ratios": [1.4, 0.9, 1.1]})
    rows, notes, study_rows, drawn = [], [], [], []
    for (ax_use, ax_tv, ax_score), set_name in zip(axes, sets):
        mine = [c for c in cells if c.set == set_name]
        ref = maps_reference(mine)
        by_key = ablation_groups(mine)
        ablations = [c for key, runs in by_key.items() if key.label != "maps" for c in runs]
        base = [c for key, runs in by_key.items() if key.label == "maps" for c in runs]
        labels = list(dict.fromkeys(key.label for key in by_key))
        colors = variant_styles(labels)
        top = max(c.demos for c in ablations)
        width = 0.8 / len(labels)
        means = []
        for j, lab in enumerate(labels):
            at_top = [c for key, runs in by_key.items() if key.label == lab and key.demos == top for c in runs
                      if c.has_usage]
            legend = lab if lab == "maps" else f"{lab}: {', '.join(at_top[0].zeroed_terms if at_top else ())} = 0"
            profile = sorted_usage(at_top)
            if profile:
                xs = np.arange(1, len(profile) + 1) - 0.4 + width * (j + 0.5)
                ax_use.bar(xs, profile, width, color=colors[lab], label=f"{legend} ({seeds(len(at_top))})")
                rows += [[set_name, lab, top, "sorted_usage", i + 1, len(at_top), u, ""] for i, u in enumerate(profile)]
                tv = [mean(usage_distances(c)) for c in at_top]
                m, h = stats(tv)
                ax_tv.bar(j, m, 0.7, yerr=h, capsize=3, color=colors[lab])
                ax_tv.annotate(f"{m:.2f}", (j, m + h), xytext=(0, 2), textcoords="offset points", ha="center",
                               va="bottom", fontsize=8)
                rows.append([set_name, lab, top, "usage_tv", "", len(tv), m, ci95(tv)])
            keys = [key for key in by_key if key.label == lab]
            lone = len({key.demos for key in by_key}) == 1
            apart = dodge_unit(base + ablations + [c for c in study if c.set == set_name and c.label in labels])
            points = line_with_band(ax_score, [k.demos for k in keys], [by_key[k] for k in keys],
                                    lambda c: c.mean_score, dodge=apart * (j - (len(labels) - 1) / 2) if lone else 0.0,
                                    color=colors[lab], label=legend)
            rows += [[set_name, lab, x, "score", "", n, m, h] for x, n, m, h in points]
            means += [m for _, _, m, _ in points]
            for k in sorted({key.subsample for key in keys}):
                theirs = study_line(ax_score, study, set_name, lab, k, colors[lab])
                study_rows += [[set_name, lab, x, "score", "", n, m, h] for x, n, m, h in theirs]
                means += [m for _, _, m, _ in theirs]
                drawn += [c for c in study if c.set == set_name and c.label == lab and c.subsample == k]
        ax_use.set_title(f"{set_name}, {top} demos: each task's module usage sorted,\nmean over tasks and seeds")
        ax_use.set_xlabel("module rank within the task (1 = most used)")
        ax_use.set_ylabel("share of the selector's score")
        ax_use.set_xticks(range(1, ref[0] + 1))
        ax_use.legend(fontsize=8, title="colours: the same in all three panels", title_fontsize=8)
        ax_tv.set_title(f"{top} demos: how differently tasks use the modules\n(TV from the tasks' mean usage)")
        ax_tv.set_xticks(range(len(labels)), [lab.replace("maps (", "").rstrip(")") for lab in labels],
                         rotation=30, ha="right")
        ax_tv.set_ylabel("total-variation distance, mean over tasks")
        ax_tv.set_ylim(0, max(0.05, ax_tv.get_ylim()[1] * 1.1))  # room for the value labels
        theirs = [c for c in drawn if c.set == set_name]
        ax_score.set_title(f"{set_name}: score per variant (M = {ref[0]}), band: 95% CI\n"
                           f"{describe_n(base + ablations)}"
                           + (f"\nhollow, dashed: study ({steps_and_seeds(theirs)})" if theirs else ""), fontsize=9)
        ax_score.set_xlabel("demonstrations per task")
        ax_score.set_ylabel(f"{score_name(set_name, mine, short=True)} (mean over tasks)")
        ax_score.set_xticks(sorted({c.demos for c in base + ablations + theirs}))
        score_limits(ax_score, set_name, mine, means)
        for ax in (ax_use, ax_tv, ax_score):
            ax.grid(alpha=0.3, axis="y")
        notes.append(f"{set_name}: {describe_n(base + ablations)}, M = {ref[0]}")
    fig.suptitle("Fig. 4: MAPS with one selector-loss term zeroed (from each cell's config) against MAPS")
    fig.tight_layout()
    save(fig, out, "fig4_ablations.png")
    header = ["set", "variant", "demos", "quantity", "index", "seeds", "mean", "ci95"]
    write_csv(out / "fig4_ablations.csv", header, rows)
    caption = ("Fig. 4: MAPS's ablations against MAPS at the largest demo count: left, each"
               " task's module usage sorted from the most used module, averaged over tasks and seeds (a single"
               " tall bar: one module per task); middle, how far each task's usage is from the tasks' mean usage"
               " (0: all tasks route alike; computed per seed); right, the mean score over tasks against demos per"
               f" task (band: 95% CI over seeds). {'; '.join(notes)}.")
    if drawn:
        write_csv(out / "fig4_ablations_study.csv", header, study_rows)
        caption += (" Right, hollow markers on dashed lines: the study's scores of the same variants at every count it"
                    f" ran (error bars: 95% CI over its seeds; {describe_n(drawn)}; fig4_ablations_study.csv).")
    return [Figure("fig4_ablations.png", caption)]


def fig5_modules_heatmap(cells, out):
    sets = [s for s in order(SET_ORDER, {c.set for c in cells}) if module_sweep_cells([c for c in cells if c.set == s])]
    if not sets:
        return []
    fig, axes = plt.subplots(1, len(sets), figsize=(max(6.0, 4.8 * len(sets) + 0.8), 4.8), squeeze=False)
    rows, notes = [], []
    for ax, set_name in zip(axes[0], sets):
        sweep = module_sweep_cells([c for c in cells if c.set == set_name])
        ms, counts = sorted({c.modules for c in sweep}), sorted({c.demos for c in sweep})
        grid = np.full((len(ms), len(counts)), np.nan)
        for i, m in enumerate(ms):
            for j, demos in enumerate(counts):
                vals = [c.mean_score for c in sweep if c.modules == m and c.demos == demos]
                if vals:
                    grid[i, j] = mean(vals)
                    rows.append([set_name, m, demos, len(vals), mean(vals), ci95(vals)])
        vmax = max(1.0, float(np.nanmax(grid)))
        image = ax.imshow(grid, cmap="viridis", vmin=0.0, vmax=vmax, aspect="auto")
        for i, m in enumerate(ms):
            for j, demos in enumerate(counts):
                n = sum(1 for c in sweep if c.modules == m and c.demos == demos)
                text = f"{grid[i, j]:.2f}\nn={n}" if n else "-"
                dark = n and grid[i, j] < 0.6 * vmax
                ax.text(j, i, text, ha="center", va="center", fontsize=9, color="w" if dark else "k")
        ax.set_xticks(range(len(counts)), [str(d) for d in counts])
        ax.set_yticks(range(len(ms)), [str(m) for m in ms])
        ax.set_xlabel("demonstrations per task")
        ax.set_ylabel("modules M")
        ax.set_title(f"{set_name}: {score_name(set_name, sweep, short=True)}\n{describe_n(sweep)}", fontsize=9)
        fig.colorbar(image, ax=ax, fraction=0.046, label="mean over tasks and seeds")
        notes.append(f"{set_name}: {describe_n(sweep)}")
    fig.suptitle("Fig. 5: MAPS's mean score over tasks\nby number of modules M and demos (n = seeds per square)")
    fig.tight_layout()
    save(fig, out, "fig5_modules_heatmap.png")
    write_csv(out / "fig5_modules_heatmap.csv", ["set", "modules", "demos", "seeds", "mean", "ci95"], rows)
    return [Figure("fig5_modules_heatmap.png", "Fig. 5: MAPS's mean score over tasks, averaged over seeds, for each"
                   " number of modules M (rows, from each cell's config) and number of demos per task (columns); n in"
                   f" each square is its number of seeds. {'; '.join(notes)}. Cheetah sets: {score_name('gravity')};"
                   f" MT10: {score_name('mt10')}.")]


def fig6_module_usage(cells, out):
    """Base MAPS's per-task module usage, one seed (module indices mean nothing across seeds): MT10, else the first
    set that has it."""
    usable = [c for c in cells if c.label == "maps" and c.has_usage]
    sets = order(SET_ORDER, {c.set for c in usable})
    if not sets:
        return []
    set_name = "mt10" if "mt10" in sets else sets[0]
    mine = [c for c in usable if c.set == set_name]
    ref = maps_reference(mine)
    mine = [c for c in mine if c.modules == ref[0] and c.selector_losses == ref[1]]
    by_key = groups(mine)
    tasks = task_names(mine)
    modules = ref[0]
    palette = plt.get_cmap("tab10" if modules <= 10 else "tab20").colors
    fig, axes = plt.subplots(len(by_key), 1, figsize=(max(8.0, 0.11 * len(tasks) * modules + 3), 2.8 * len(by_key)
                                                       + 1.0), squeeze=False)
    rows = []
    width = 0.85 / modules
    for ax, (key, runs) in zip(axes[:, 0], by_key.items()):
        run = runs[0]
        for m in range(modules):
            xs = np.arange(len(tasks)) - 0.425 + width * (m + 0.5)
            usage = [next(t.usage[m] for t in run.tasks if t.task == task) for task in tasks]
            ax.bar(xs, usage, width, color=palette[m % len(palette)], label=f"m{m}")
            rows += [[set_name, key.demos, key.subsample, run.seed, task, m, u] for task, u in zip(tasks, usage)]
        ax.set_title(f"{set_name}, {key.demos} demos per task, k = {key.subsample}: seed {run.seed}"
                     f" ({run.episodes} episodes per task, {run.steps} training steps)")
        ax.set_xticks(range(len(tasks)), [short_task(t) for t in tasks], rotation=30 if len(tasks) > 5 else 0,
                      ha="right" if len(tasks) > 5 else "center")
        ax.set_ylabel("module usage")
        ax.set_ylim(0, 1)
        ax.grid(alpha=0.3, axis="y")
        if ax is axes[0, 0]:
            ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), ncol=1 if modules <= 10 else 2, fontsize=8)
    fig.suptitle(f"Fig. 6: MAPS's module usage per task on {set_name} (M = {modules}): mean selector score over\n"
                 "the task's evaluation states, one seed's run (module indices differ between seeds)")
    fig.tight_layout()
    save(fig, out, "fig6_module_usage.png")
    write_csv(out / "fig6_module_usage.csv", ["set", "demos", "subsample", "seed", "task", "module", "usage"], rows)
    seeds = ", ".join(f"{key.demos} demos: seed {runs[0].seed}" for key, runs in by_key.items())
    return [Figure("fig6_module_usage.png", f"Fig. 6 (left): MAPS's module usage per task on {set_name} (M ="
                   f" {modules}): each bar is the mean selector score of one module over the states of that task's"
                   f" evaluation episodes, from one seed's run (the lowest finished seed; {seeds}), since module"
                   f" indices mean nothing across seeds. n = one seed, {describe_n(mine).split(', ', 1)[1]}.")]


def zoo_routing(cells, out, variants_are_methods=False):
    """Every routing method's per-task module usage as a heatmap (tasks x modules), one seed each (module indices
    mean nothing across seeds), on MT10 (else the first set that has them) at the largest demonstration count: the
    task division of MAPS and of the zoo's methods side by side. Drawn only when something besides base MAPS routes.
    `variants_are_methods` (report.holm "set"): a variant that routes (the modular denoisers) is a panel of its own."""
    usable = [c for c in compared_cells(cells, variants_are_methods) if c.has_usage]
    if not any(c.label != "maps" for c in usable):
        return []
    sets = order(SET_ORDER, {c.set for c in usable if c.label != "maps"})
    set_name = "mt10" if "mt10" in sets else sets[0]
    mine = [c for c in usable if c.set == set_name]
    methods = methods_of(mine)
    with_variants = any(c.label != c.method for c in mine)
    panels = []
    for method in methods:
        runs = [c for c in mine if c.label == method]
        demos = max(c.demos for c in runs)
        runs = sorted((c for c in runs if c.demos == demos), key=lambda c: c.seed)
        panels.append((method, demos, runs[0]))
    tasks = task_names(mine)
    usages = [np.array([next(t.usage for t in run.tasks if t.task == task) for task in tasks]) for _, _, run in panels]
    # One colour scale for every panel: usage over the uniform share (usage x the method's M; 1: uniform), since
    # methods with 4 modules and with 10 reach different shares.
    # Capped at 4x: past it a module carries the task either way, and the cap keeps 1.5-2x (a module used) visible.
    relative = [u * u.shape[1] for u in usages]
    norm = matplotlib.colors.TwoSlopeNorm(vmin=0.0, vcenter=1.0, vmax=4.0)
    fig, axes = plt.subplots(1, len(panels), figsize=(2.4 + 2.2 * len(panels), 0.32 * len(tasks) + 2.6),
                             squeeze=False, layout="constrained")
    rows = []
    for ax, (method, demos, run), usage, scaled in zip(axes[0], panels, usages, relative):
        image = ax.imshow(scaled, norm=norm, cmap="RdBu_r", aspect="auto")
        title = label_name(method).replace(" (", "\n(")  # a variant's name on a line of its own
        ax.set_title(f"{title}\n{demos} demos, seed {run.seed}", fontsize=9)
        per_layer = int(run.config.get("soft_modularization", {}).get("modules", 0)) if run.method == \
            "soft_modularization" else 0
        ticks = ([f"{m // per_layer}.{m % per_layer}" for m in range(usage.shape[1])] if per_layer
                 else [str(m) for m in range(usage.shape[1])])
        ax.set_xticks(range(usage.shape[1]), ticks, fontsize=6 if usage.shape[1] > 10 else 7,
                      rotation=90 if per_layer else 0)
        ax.set_xlabel("layer.module" if per_layer else "module")
        ax.set_yticks(range(len(tasks)), [short_task(t) for t in tasks] if ax is axes[0, 0] else [], fontsize=8)
        for task, values in zip(tasks, usage):
            rows += [[set_name, run.method, shown_variant(run), demos, run.seed, task, m, float(u)]
                     for m, u in enumerate(values)]
    fig.colorbar(image, ax=list(axes[0]), fraction=0.03, pad=0.02, extend="max",
                 label="usage / uniform share (1: uniform; 4: 4x or more)")
    fig.suptitle(f"Module usage per task on {set_name}, each routing method (one seed): MAPS's selector scores,\n"
                 "MOORE's and PaCo's task-weight shares, the CARE-style attention, the top-k gates, Soft"
                 " Modularization's per-layer use" + (", the modular denoisers' scores and gates" if with_variants else "")
                 + "; red above the uniform share, blue below",
                 fontsize=9)
    save(fig, out, "zoo_routing.png")
    write_csv(out / "zoo_routing.csv", ["set", "method", "variant", "demos", "seed", "task", "module", "usage"], rows)
    return [Figure("zoo_routing.png", f"Module usage per task on {set_name} for every method that routes, each at its"
                   " largest demonstration count and lowest finished seed (module indices mean nothing across"
                   " seeds): a column used by every task is a shared module, one used by few tasks a specific one."
                   " Usage is what each method records (docs/zoo.md): MAPS's mean selector score, MOORE's and PaCo's"
                   " |w| shares (constant within a task), the mean CARE-style attention, the mean top-k gate, Soft"
                   " Modularization's mean per-layer use (columns layer.module)"
                   + ("; Diffusion Policy's denoiser with MAPS's modules its mean selector score, its MoE denoiser"
                      " each state's kept gates scaled to sum 1" if with_variants else "")
                   + ". Colours are usage over the uniform"
                   " share (usage x the method's module count; red above 1, blue below, the darkest red 4x or more),"
                   " one scale for every panel; zoo_routing.csv has the usage itself.")]


def log_ticks(ax):
    """Plain-number labels on a log y axis (0.03, not 3 x 10^-2), with labelled minor ticks where the axis spans
    two decades or less."""
    lo, hi = ax.get_ylim()
    decades = math.log10(hi / lo)
    fine = [1.5, 2, 2.5, 3, 4, 5, 6, 8]
    if decades <= 0.6:
        ax.yaxis.set_minor_locator(ticker.LogLocator(subs=fine))
    keep = set(fine) if decades <= 0.6 else {2, 3, 4, 5, 6, 8} if decades <= 1 else {2, 5} if decades <= 2 else set()

    def minor(y, _):
        mantissa = round(y / 10 ** math.floor(math.log10(y)), 6)
        return f"{y:g}" if mantissa in keep else ""

    ax.yaxis.set_major_formatter(ticker.FuncFormatter(lambda y, _: f"{y:g}"))
    ax.yaxis.set_minor_formatter(ticker.FuncFormatter(minor))


def setting_panels(settings_per_set):
    """(figure, axes, height in inches) with one row of panels per set and a column per setting of the set with the
    most: settings_per_set holds each set's settings (its (demos, k) pairs)."""
    columns = max(len(settings) for settings in settings_per_set)
    height = 3.6 * len(settings_per_set) + 1.2
    fig, axes = plt.subplots(len(settings_per_set), columns, figsize=(max(7.5, 4.6 * columns), height), squeeze=False)
    return fig, axes, height


def setting_axes(axes, sets, cells):
    """(axis, set, (demos, k), the setting's cells) for each panel of setting_panels' grid, a row per set; a row's
    spare panels are hidden."""
    for axes_row, set_name in zip(axes, sets):
        mine = [c for c in cells if c.set == set_name]
        settings = sorted({(c.demos, c.subsample) for c in mine})
        for ax in axes_row[len(settings):]:
            ax.set_visible(False)
        for ax, (demos, k) in zip(axes_row, settings):
            yield ax, set_name, (demos, k), [c for c in mine if (c.demos, c.subsample) == (demos, k)]


def mean_validation_curve(runs):
    """(steps, mean validation loss, the runs with a curve) at the steps every such run's curve.csv logged; empty
    lists where no run has a curve or they share no step."""
    with_curve = [(c, dict(zip(*curve))) for c, curve in ((c, c.curve()) for c in runs) if curve[0]]
    if not with_curve:
        return [], [], []
    steps = sorted(set.intersection(*(set(curve) for _, curve in with_curve)))
    return steps, [mean([curve[s] for _, curve in with_curve]) for s in steps], [c for c, _ in with_curve]


def loss_panel(ax, set_name, demos, k, ylabel):
    """A validation-loss panel's axes: log scale, its setting as the title."""
    ax.set_yscale("log")
    if ax.lines:
        log_ticks(ax)
    ax.set_title(f"{set_name}, {demos} demos per task, k = {k}")
    ax.set_xlabel("training step")
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3, which="both")


def denoising_validation(cells, out):
    """Diffusion Policy's validation loss (the denoising loss on the validation states, on one fixed draw of steps and
    noise: docs/zoo.md) against the training step, one line per denoiser (the cells' label), mean over seeds, a panel
    per set and setting: the curve its checkpoint rule reads, apart from the BC losses of validation.png (another
    quantity on another scale)."""
    cells = [c for c in cells if c.method == "diffusion_policy"]
    sets = order(SET_ORDER, {c.set for c in cells})
    if not sets:
        return []
    labels = methods_of(cells)
    fig, axes, height = setting_panels([{(c.demos, c.subsample) for c in cells if c.set == s} for s in sets])
    rows, drawn = [], []
    for ax, set_name, (demos, k), mine in setting_axes(axes, sets, cells):
        for label in labels:
            steps, means, used = mean_validation_curve([c for c in mine if c.label == label])
            if not steps:
                continue
            style = label_style(label, labels)
            ax.plot(steps, means, color=style["color"], linestyle=style.get("linestyle", "-"), label=label)
            rows += [[set_name, label, demos, k, s, len(used), m] for s, m in zip(steps, means)]
            drawn += used
        loss_panel(ax, set_name, demos, k, "validation denoising loss")
        ax.locator_params(axis="x", nbins=5)
    if not drawn:
        plt.close(fig)
        return []
    legend_below(fig, axes.flat, 3)
    fig.suptitle("Diffusion Policy: validation denoising loss against training step, mean over seeds\n"
                 f"{describe_n(drawn)}")
    fig.tight_layout(rect=(0, 0.5 / height, 1, 1))
    save(fig, out, "denoising_validation.png")
    write_csv(out / "denoising_validation.csv", ["set", "label", "demos", "subsample", "step", "seeds",
                                                  "validation_denoising"], rows)
    return [Figure("denoising_validation.png", "Diffusion Policy's validation loss, the denoising loss on the"
                   " validation states at one fixed draw of steps and noise, against the training step, mean over seeds"
                   " per denoiser (log scale); the checkpoint evaluated is each run's step of lowest loss, which a curve"
                   f" that falls and rises again shows early. {describe_n(drawn)}.")]


def validation(cells, out):
    # Diffusion Policy's validation loss is the denoising loss, another quantity: its own figure.
    cells = [c for c in base_cells(cells) if c.method != "diffusion_policy"]
    sets = order(SET_ORDER, {c.set for c in cells})
    if not sets:
        return []
    fig, axes, height = setting_panels([{(c.demos, c.subsample) for c in cells if c.set == s} for s in sets])
    rows, drawn = [], []
    for ax, set_name, (demos, k), mine in setting_axes(axes, sets, cells):
        for method in methods_of(mine):
            steps, means, used = mean_validation_curve([c for c in mine if c.method == method])
            if not steps:
                continue
            ax.plot(steps, means, color=color(method), label=name(method))
            rows += [[set_name, method, demos, k, s, len(used), m] for s, m in zip(steps, means)]
            drawn += used
        loss_panel(ax, set_name, demos, k, "validation BC loss")
    if not drawn:
        plt.close(fig)
        return []
    legend_below(fig, axes.flat, 6)
    fig.suptitle(f"Validation BC loss (held-out states) against training step, mean over seeds\n{describe_n(drawn)}")
    fig.tight_layout(rect=(0, 0.5 / height, 1, 1))
    save(fig, out, "validation.png")
    write_csv(out / "validation.csv", ["set", "method", "demos", "subsample", "step", "seeds", "validation_bc"], rows)
    return [Figure("validation.png", "Validation BC loss on held-out states against the training step, mean over"
                   " seeds per method (base variants; log scale); the checkpoint evaluated is each run's step of"
                   f" lowest loss. {describe_n(drawn)}.")]
