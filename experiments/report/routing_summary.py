"""One table of every routing method's routing per setting, for comparing methods at a glance (the zoo, docs/zoo.md):
the per-set usage tables of tables.usage_tables give the per-task detail this summarises."""
import math

from suite_stats import fmt, mean, span, usage_distances
from suite_results import display_label, label_rank
from tables import division_counts, routed, routing_note, table


def per_seed_mean(runs, value):
    """value(task) averaged over each run's tasks: one number per seed (seeds lacking it are skipped)."""
    out = []
    for c in runs:
        values = [value(t) for t in c.tasks if value(t) is not None]
        if values:
            out.append(mean(values))
    return out


def over_seeds(values, seeds, uniform):
    """mean +- CI with the uniform reference in brackets, and how many seeds it is over when fewer than the row's."""
    if not values:
        return f"- ({uniform:.2f})"
    fewer = f", {len(values)} of {seeds} seeds" if len(values) < seeds else ""
    return f"{fmt(values)} ({uniform:.2f}{fewer})"


def summary_rows(runs, modules):
    tv = [mean(usage_distances(c)) for c in runs]
    entropy = per_seed_mean(runs, lambda t: t.entropy)
    top = per_seed_mean(runs, lambda t: t.top_score)
    _, shared, specific, both, _, _ = zip(*division_counts(runs))
    tasks = len(runs[0].tasks)
    return [fmt(tv), over_seeds(entropy, len(runs), math.log(modules)), over_seeds(top, len(runs), 1 / modules),
            f"{span(sorted(shared))} of {modules}",
            f"{span(sorted(specific))} of {modules}", f"{span(sorted(both))} of {tasks}"]


def routing_summary(cells, seeds_added=False, variants_are_methods=False):
    """Per set: a row per (routing method, demos) with seeds, M and the routing measures over seeds; the caveats of
    the methods present after the table. [] without two or more routing methods (MAPS alone: the usage tables
    say it all). seeds_added: more_seeds.py added seeds to some settings (the rows' seed counts then differ).
    variants_are_methods: a variant that routes is a row of its own (tables.routed)."""
    by_key = routed(cells, variants_are_methods)
    if len({key.label for key in by_key}) < 2:
        return []
    rows, notes = [], {}  # notes: each distinct text once (a method at two settings, e.g. two k, may need two)
    for key in sorted(by_key, key=lambda k: (k.set, k.demos, k.subsample, label_rank(k.label))):
        runs = by_key[key]
        modules = len(runs[0].tasks[0].usage)
        rows.append([key.set, key.demos, key.subsample, display_label(key.label), len(runs), modules]
                    + summary_rows(runs, modules))
        note = routing_note(runs[0])
        if note:
            notes[note] = None
    lines = ["Each method's routing per setting, over its seeds: the tasks' usage distance from their mean usage (TV,"
             " mean over tasks; 0: every task routes alike), the per-state entropy and top score (mean over tasks;"
             " in brackets the value of uniform routing over M, ln M and 1/M), and the task division (a task uses a"
             " module whose share of its usage is >= 1.5/M; shared: used by two or more tasks, specific: by one;"
             " range over seeds). Mean +- 95% CI over seeds. The per-set sections give each task's usage. Rows are not"
             " paired: each is over its own seeds" + (" (more_seeds.py added seeds where a difference from MAPS had"
                                                      " an interval including 0, so the rows' seed counts differ)"
                                                      if seeds_added else "")
             + "; compare rows by their intervals, not seed by seed.", ""]
    lines += table(["set", "demos", "k", "method", "seeds", "M", "TV from the tasks' mean", "per-state entropy (ln M)",
                    "per-state top score (1/M)", "shared modules", "specific modules", "tasks using both"], rows)
    if notes:
        lines += [""] + [f"- {note}" for note in notes]
    return lines
