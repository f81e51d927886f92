"""The comparisons a suite asks for by name (the suite config's report.compare: "A - B", each a row of the report such
as "diffusion_policy (dp_maps_h16)"), beside the report's comparisons with MAPS: a question such as "does Diffusion
Policy gain from MAPS's modules as its denoiser?" is the denoiser against the MLP one, not either against MAPS.

Per set, every (demos, k) where both rows ran: both mean scores over the seeds both ran, A - B paired by seed, the
paired t test's p with Holm over the set's rows, and the probability that an A run beats a B run on a task (the
aggregate statistics' estimator and interval, aggregates.py). `maps suite` has checked that every entry names two rows
of the suite."""
from suite_results import groups
from tables import against_columns, holm_columns, improvement, table


def parse(entry):
    """"A - B" -> ("A", "B"); ValueError naming the entry otherwise (`maps suite` refuses such a config)."""
    parts = str(entry).split(" - ")
    if len(parts) != 2 or not all(parts):
        raise ValueError(f"report.compare: expected \"A - B\", got {entry!r}")
    return parts[0], parts[1]


def compare_table(cells, entries):
    """One set's rows for the entries ("A - B"); [] when no entry has both rows at a demos and k."""
    by_key = groups(cells)
    rows = []
    for entry in entries:
        a, b = parse(entry)
        for key in sorted((k for k in by_key if k.label == a), key=lambda k: (k.demos, k.subsample)):
            runs_a, runs_b = by_key[key], by_key.get(key._replace(label=b))
            columns = against_columns(runs_a, runs_b) if runs_b else None  # pairs, B, A, A - B, p
            if columns:
                pairs, score_b, score_a, difference, p = columns
                rows.append([a, b, key.demos, key.subsample, pairs, score_a, score_b, difference,
                             improvement(runs_a, runs_b, cells), p])
    if not rows:
        return []
    shown, sizes = holm_columns(rows)
    return (["Each comparison the suite config names (report.compare), A - B: mean score over tasks of each over the"
             " seeds both ran (mean +- 95% CI), their paired difference, P(A > B) (the probability that an A run"
             " beats a B run on a task, with its stratified bootstrap interval: the aggregate statistics' estimator),"
             f" p: paired t test, Holm over this set's {sizes[None]} rows with a p:", ""]
            + table(["A", "B", "demos", "k", "pairs", "A's score", "B's score", "A - B", "P(A > B) [95% CI]", "p",
                     "p (Holm)"], shown))
