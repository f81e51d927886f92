"""Statistics of a suite's cells: means with 95% confidence intervals over seeds (t distribution), paired
differences over the seeds two groups both ran, module usage and routing (computed per seed before averaging,
since module indices mean nothing across seeds), and the comparison with Single BC of the paper's Fig. 3."""
import math
import statistics
from dataclasses import dataclass

from scipy.stats import t as scipy_t

from suite_results import groups, task_names, task_score

# Fig. 3's "much better": the method's mean score above this factor times Single BC's.
MUCH_BETTER = 1.1
# A task uses a module when the module's share of the task's selector scores is at least USED_FACTOR / M (1.5x the
# uniform share): uniform mixing then counts as using none, and a module that carries a task visibly counts.
USED_FACTOR = 1.5


def t95(degrees_of_freedom):
    """The two-sided 95% quantile of Student's t (as maps::core::t_quantile_95 computes it in C++)."""
    return float(scipy_t.ppf(0.975, degrees_of_freedom))


def ci95(values):
    """Half-width of the 95% confidence interval of the mean (t distribution); nan for fewer than 2 values."""
    if len(values) < 2:
        return float("nan")
    return t95(len(values) - 1) * statistics.stdev(values) / math.sqrt(len(values))


def mean(values):
    return statistics.mean(values) if values else float("nan")


def fmt(values, signed=False):
    """"0.70 +- 1.27" (mean +- 95% CI half-width); the value alone when there is one (no interval: a grid still
    running, or one seed)."""
    if len(values) == 1:
        return f"{values[0]:{'+' if signed else ''}.2f}"
    return f"{mean(values):{'+' if signed else ''}.2f} +- {ci95(values):.2f}"


def span(values):
    """"100-200", or "100" when all are equal."""
    return f"{min(values)}-{max(values)}" if min(values) != max(values) else str(values[0])


def span_fixed(values, digits, collapse=True):
    """"0.12-0.18" at `digits` decimals; with collapse, one value where both ends print alike."""
    lo, hi = f"{min(values):.{digits}f}", f"{max(values):.{digits}f}"
    return lo if collapse and lo == hi else f"{lo}-{hi}"


def paired(cells_a, cells_b, value):
    """value(a) - value(b) over the seeds both lists ran, by seed."""
    b_by_seed = {c.seed: c for c in cells_b}
    return [value(a) - value(b_by_seed[a.seed]) for a in cells_a if a.seed in b_by_seed
            and value(a) is not None and value(b_by_seed[a.seed]) is not None]


def significance(diffs):
    """+1 / -1 when the 95% CI of the mean difference lies above / below 0; 0 otherwise (or with one pair)."""
    half = ci95(diffs)
    if math.isnan(half):
        return 0
    m = mean(diffs)
    return 1 if m - half > 0 else -1 if m + half < 0 else 0


def paired_p(diffs):
    """Two-sided p-value of the paired t test (the mean difference is 0); nan with fewer than 2 pairs."""
    if len(diffs) < 2:
        return float("nan")
    spread = statistics.stdev(diffs)
    if spread == 0:
        return 1.0 if mean(diffs) == 0 else 0.0
    t = mean(diffs) / (spread / math.sqrt(len(diffs)))
    return float(2 * scipy_t.sf(abs(t), len(diffs) - 1))


def holm(p_values):
    """Holm's step-down adjustment of a family of p-values (nan ones are not in the family and stay nan)."""
    order = sorted((i for i, p in enumerate(p_values) if not math.isnan(p)), key=lambda i: p_values[i])
    adjusted, running = [float("nan")] * len(p_values), 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (len(order) - rank) * p_values[i]))
        adjusted[i] = running
    return adjusted


def holm_within(p_values, families):
    """Holm's adjustment within each family: p_values[i] belongs to families[i]."""
    adjusted = [float("nan")] * len(p_values)
    for family in dict.fromkeys(families):
        members = [i for i, f in enumerate(families) if f == family]
        for i, a in zip(members, holm([p_values[i] for i in members])):
            adjusted[i] = a
    return adjusted


def fmt_p(p):
    return "-" if math.isnan(p) else f"{p:.3f}"


def total_variation(p, q):
    if len(p) != len(q):
        raise ValueError(f"usage over {len(p)} modules compared with usage over {len(q)}")
    return 0.5 * sum(abs(a - b) for a, b in zip(p, q))


def usage_distances(cell):
    """Each task's total-variation distance of its module usage from the mean usage over the cell's tasks
    (0: every task uses the modules alike)."""
    usages = [t.usage for t in cell.tasks]
    center = [statistics.mean(col) for col in zip(*usages)]
    return [total_variation(u, center) for u in usages]


def top_share(cell):
    """The most used module's share, mean over the cell's tasks."""
    return mean([max(t.usage) for t in cell.tasks])


def mean_entropy(cell):
    values = [t.entropy for t in cell.tasks if t.entropy is not None]
    return mean(values) if values else None


def sorted_usage(cells):
    """Each task's usage sorted from the most used module down, averaged over tasks and cells (seeds)."""
    rows = [sorted(t.usage, reverse=True) for c in cells for t in c.tasks]
    return [statistics.mean(col) for col in zip(*rows)] if rows else []


def routing(cells, tasks):
    """Per task: (TV distances from the tasks' mean usage, per-state entropies, per-state top scores), one value per
    seed (entropy and top score lists are empty where the results lack them)."""
    out = {}
    for task in tasks:
        tv, entropy, top = [], [], []
        for cell in cells:
            index = [t.task for t in cell.tasks].index(task) if task in [t.task for t in cell.tasks] else None
            if index is None:
                continue
            tv.append(usage_distances(cell)[index])
            if cell.tasks[index].entropy is not None:
                entropy.append(cell.tasks[index].entropy)
            if cell.tasks[index].top_score is not None:
                top.append(cell.tasks[index].top_score)
        out[task] = (tv, entropy, top)
    return out


@dataclass
class VsSingle:
    """Fig. 3: a method's (task, demos) settings against Single BC's, by mean score over seeds and paired."""
    settings: int = 0
    better: int = 0
    worse: int = 0
    ties: int = 0
    much_better: int = 0  # mean score > MUCH_BETTER x Single BC's
    significantly_better: int = 0  # the 95% CI of the paired difference over seeds is above 0
    significantly_worse: int = 0

    def add(self, other):
        for name in self.__dataclass_fields__:
            setattr(self, name, getattr(self, name) + getattr(other, name))

    def share(self, name):
        return getattr(self, name) / self.settings if self.settings else float("nan")


def vs_single_bc(cells):
    """{(set or "all", method): VsSingle} over the base variants: every (set, task, demos, subsample) setting both the
    method and Single BC have at least one finished seed of."""
    by_key = groups([c for c in cells if c.label == c.method])
    out = {}
    for key, runs in by_key.items():
        single = by_key.get(key._replace(label="single_bc"))
        if key.label == "single_bc" or not single:
            continue
        counts = VsSingle()
        for task in task_names(runs + single):
            mine = [s for s in (task_score(c, task) for c in runs) if s is not None]
            theirs = [s for s in (task_score(c, task) for c in single) if s is not None]
            if not mine or not theirs:
                continue
            m, s = mean(mine), mean(theirs)
            counts.settings += 1
            counts.better += m > s
            counts.worse += m < s
            counts.ties += m == s
            counts.much_better += m > MUCH_BETTER * s
            sign = significance(paired(runs, single, lambda c: task_score(c, task)))
            counts.significantly_better += sign > 0
            counts.significantly_worse += sign < 0
        for where in (key.set, "all"):
            out.setdefault((where, key.label), VsSingle()).add(counts)
    return out


def describe_n(cells):
    """"n = 2 seeds per point, 10 episodes per task, 1000 training steps" (ranges where the cells differ)."""
    seeds = sorted(len(runs) for runs in groups(cells).values())
    episodes = "/".join(str(e) for e in sorted({c.episodes for c in cells}))
    steps = "/".join(str(s) for s in sorted({c.steps for c in cells}))
    return (f"n = {span(seeds)} seed{'s' if seeds[-1] > 1 else ''} per point, {episodes} episodes per task,"
            f" {steps} training steps")


def used_modules(task, modules):
    return {j for j, u in enumerate(task.usage) if u >= USED_FACTOR / modules}


def division(cell):
    """(shared modules, task-specific modules, tasks using both kinds, each task's used modules) of one run's
    evaluation usage: a module used by two or more tasks is shared, by one task specific."""
    used = {t.task: used_modules(t, len(t.usage)) for t in cell.tasks}
    users = {}
    for task, mods in used.items():
        for j in mods:
            users.setdefault(j, set()).add(task)
    shared = {j for j, u in users.items() if len(u) > 1}
    specific = {j for j, u in users.items() if len(u) == 1}
    both = sum(1 for mods in used.values() if mods & shared and mods & specific)
    return shared, specific, both, used
