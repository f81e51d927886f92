"""The field's aggregate statistics (Agarwal et al., "Deep Reinforcement Learning at the Edge of the Statistical
Precipice", NeurIPS 2021; rliable; issue 46, item 5), beside the report's means and paired t tests: the interquartile
mean (IQM) of every run x task score with a stratified bootstrap interval, and the probability of improvement of MAPS
over each other method with its interval. Scores are the report's (HalfCheetah: return over the expert's, MT10:
success rate), already on one scale per set. Written here after rliable's definitions
(../shared/reference/beyond.md, section 3):

- IQM: the mean of the middle half of all runs x tasks scores pooled (scipy's trim_mean with cut 0.25: floor(N / 4)
  values off each end), not per task.
- Stratified bootstrap: a replicate resamples the runs with replacement independently within each task (tasks fixed);
  the interval is the replicates' 2.5th and 97.5th percentiles (the percentile method).
- Probability of improvement P(X > Y): per task the Mann-Whitney U of X's runs against Y's over n_x n_y (a tie counts
  1/2), averaged over tasks; its interval resamples X's and Y's runs independently within each task.

rliable uses 50,000 replicates for aggregates and 2,000 for the probability of improvement; here both use
REPLICATES, from a fixed seed, so a report is the same at every run."""
import numpy as np
from scipy.stats import trim_mean

from suite_results import groups, maps_partner, task_names, task_score
from tables import table

REPLICATES = 20000
SEED = 20211206  # NeurIPS 2021's first day: any fixed seed keeps reports reproducible


def iqm(scores):
    """The interquartile mean of an array of scores (any shape; pooled)."""
    return float(trim_mean(np.asarray(scores, dtype=float).ravel(), proportiontocut=0.25))


def stratified_resamples(runs_by_tasks, replicates, rng):
    """[replicates, runs, tasks] arrays: each replicate's runs drawn with replacement within each task (column)."""
    m = np.asarray(runs_by_tasks, dtype=float)
    runs, tasks = m.shape
    picks = rng.integers(0, runs, size=(replicates, runs, tasks))
    return m[picks, np.arange(tasks)[None, None, :]]


def interval(values):
    """The percentile 95% interval of bootstrap replicates."""
    low, high = np.percentile(values, [2.5, 97.5])
    return float(low), float(high)


def iqm_interval(runs_by_tasks, replicates=REPLICATES, seed=SEED):
    """(IQM, (low, high)) of a runs x tasks matrix, the interval by the stratified bootstrap."""
    m = np.asarray(runs_by_tasks, dtype=float)
    samples = stratified_resamples(m, replicates, np.random.default_rng(seed))
    cut = int(0.25 * m.size)
    flat = np.sort(samples.reshape(replicates, -1), axis=1)
    per_replicate = flat[:, cut:m.size - cut].mean(axis=1)
    return iqm(m), interval(per_replicate)


def probability_of_improvement(x, y):
    """P(X > Y) + P(X = Y) / 2 averaged over tasks; x and y are runs x tasks matrices with the same tasks (runs may
    differ in number)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if x.ndim != 2 or y.ndim != 2 or x.shape[1] != y.shape[1] or x.shape[0] == 0 or y.shape[0] == 0:
        raise ValueError(f"probability_of_improvement: runs x tasks matrices with the same tasks, got {x.shape} and"
                         f" {y.shape}")
    return float(_poi(x[None], y[None])[0])


def _poi(x, y):
    """Vectorised over a leading replicate axis: x [R, n_x, T], y [R, n_y, T] -> [R]."""
    greater = (x[:, :, None, :] > y[:, None, :, :]).mean(axis=(1, 2))
    ties = (x[:, :, None, :] == y[:, None, :, :]).mean(axis=(1, 2))
    return (greater + 0.5 * ties).mean(axis=1)


def poi_interval(x, y, replicates=REPLICATES, seed=SEED):
    """(P(X > Y), (low, high)), X's and Y's runs resampled independently within each task."""
    rng = np.random.default_rng(seed)
    xs = stratified_resamples(x, replicates, rng)
    ys = stratified_resamples(y, replicates, rng)
    values = np.concatenate([_poi(xs[i:i + 1000], ys[i:i + 1000]) for i in range(0, replicates, 1000)])
    return probability_of_improvement(x, y), interval(values)


def runs_by_tasks(runs, tasks):
    """The cells' task scores as a runs x tasks matrix (cells sorted by seed); None when a cell lacks a task."""
    rows = []
    for cell in runs:
        row = [task_score(cell, t) for t in tasks]
        if any(v is None for v in row):
            return None
        rows.append(row)
    return np.asarray(rows, dtype=float) if rows else None


def fmt_interval(value, bounds):
    return f"{value:.3f} [{bounds[0]:.3f}, {bounds[1]:.3f}]"


def fmt_iqm(runs_by_tasks):
    """The IQM of a runs x tasks matrix with its stratified bootstrap interval; the estimate alone for one run (a
    bootstrap cannot vary a single run)."""
    value, bounds = iqm_interval(runs_by_tasks)
    return fmt_interval(value, bounds) if len(runs_by_tasks) > 1 else f"{value:.3f}"


def fmt_improvement(x, y):
    """P(X > Y) of two runs x tasks matrices with its interval; the estimate alone where a side has one run (a
    bootstrap cannot vary a single run, so its interval would be a point)."""
    if min(len(x), len(y)) < 2:
        return f"{probability_of_improvement(x, y):.3f}"
    return fmt_interval(*poi_interval(x, y))


def aggregate_table(cells):
    """One row per (method, demos) of a set's cells: runs, IQM with its interval, and, where MAPS ran at the same demos
    and subsample, P(MAPS > method) with its interval; [] without cells."""
    by_key = groups(cells)
    tasks = task_names(cells)
    rows = []
    for key, runs in by_key.items():
        matrix = runs_by_tasks(runs, tasks)
        if matrix is None:
            continue
        shown = fmt_iqm(matrix)
        poi = ""
        # A variant against MAPS under the same variant where that ran, else base MAPS (as the paired tables do).
        method = key.label.partition(" ")[0]
        maps = None if method == "maps" else by_key.get(
            key._replace(label=maps_partner(key.label, lambda label: by_key.get(key._replace(label=label)))))
        if maps:
            maps_matrix = runs_by_tasks(maps, tasks)
            if maps_matrix is not None:
                poi = fmt_improvement(maps_matrix, matrix)
        rows.append([key.label, key.demos, key.subsample, len(runs), shown, poi])
    if not rows:
        return []
    return ([f"Interquartile mean (IQM) of the {len(tasks)} tasks x runs scores with its 95% stratified bootstrap"
             " interval (runs resampled within each task), and the probability that a MAPS run beats this method's on"
             " a task, P(MAPS > method) (Mann-Whitney per task, ties 1/2, mean over tasks; 0.5: neither better;"
             f" interval: both methods' runs resampled within each task); {REPLICATES} replicates, fixed seed"
             " (Agarwal et al., NeurIPS 2021; aggregates.py):", ""]
            + table(["method", "demos", "k", "runs", "IQM [95% CI]", "P(MAPS > method) [95% CI]"], rows))
