"""The Markdown tables of a suite report, each a list of lines: the protocol and cell counts, the main results, and
per set the score table (per-task mean +- 95% CI over seeds), paired differences from MAPS, MAPS's module usage
and routing, Fig. 3's comparison with Single BC, the ablations and the module-count sweep."""
import math

from suite_results import (STOPPED_FACTOR, ablation_groups, compared_cells, control_cells, display_label, groups,
                           maps_partner, module_sweep_cells, score_name, short_task, task_names, task_score)
from suite_stats import (MUCH_BETTER, USED_FACTOR, division, fmt, fmt_p, holm, holm_within, mean, mean_entropy, paired,
                         paired_p, routing, span, span_fixed, top_share, usage_distances)


MISSING_SHOWN = 40


def table(header, rows):
    lines = ["| " + " | ".join(header) + " |", "|---" * len(header) + "|"]
    return lines + ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]


def holm_columns(rows, families=None):
    """Rows whose last cell is a p value, with that p and its Holm-adjusted value formatted as the last two cells
    (Holm over all rows, or within each family of holm_within), and {family: comparisons adjusted} (one family,
    None, without families)."""
    p_values = [row[-1] for row in rows]
    adjusted = holm(p_values) if families is None else holm_within(p_values, families)
    families = families or [None] * len(rows)
    sizes = {f: sum(1 for g, a in zip(families, adjusted) if g == f and a == a) for f in families}
    return [row[:-1] + [fmt_p(row[-1]), fmt_p(a)] for row, a in zip(rows, adjusted)], sizes


def against_columns(runs, reference):
    """runs paired by seed with the reference's cells: [pairs, the reference's mean score, the runs' (both over the
    seeds both ran), difference runs - reference, p of the paired t test]; None without a pair."""
    diffs = paired(runs, reference, lambda c: c.mean_score)
    if not diffs:
        return None
    seeds = {c.seed for c in runs} & {c.seed for c in reference}
    return [len(diffs), fmt([c.mean_score for c in reference if c.seed in seeds]),
            fmt([c.mean_score for c in runs if c.seed in seeds]), fmt(diffs, signed=True), paired_p(diffs)]


def distinct(cells, field):
    """The values field(cell) takes over cells, sorted and comma-separated ("0, 1")."""
    return ", ".join(str(v) for v in sorted({field(c) for c in cells}, key=lambda v: (isinstance(v, str), v)))


def protocol(suite):
    """The header: what ran and how it was scored, read from the cells' configs."""
    lines = [f"Suite folder `{suite.root}`" + (f", config `{suite.config_file}`." if suite.config_file else "."), ""]
    for set_name in suite.sets():
        cells = suite.cells_of(set_name)
        train = lambda key: lambda c: c.config.get("train", {}).get(key, "?")  # noqa: E731
        lines.append(f"- **{set_name}** ({len(task_names(cells))} tasks): {distinct(cells, lambda c: c.steps)}"
                     f" training steps, validation BC loss every {distinct(cells, train('validate_every'))} steps on"
                     f" {distinct(cells, train('validation_states_per_task'))} held-out states per task; checkpoint ="
                     f" the step of the best validation BC loss; {distinct(cells, lambda c: c.episodes)} evaluation"
                     f" episodes per task; seeds {distinct(cells, lambda c: c.seed)}; demos per task"
                     f" {distinct(cells, lambda c: c.demos)}; subsample k = {distinct(cells, lambda c: c.subsample)};"
                     f" {score_name(set_name, cells)}.")
    lines += ["",
              "Scores: on the HalfCheetah sets (gravity, modified) the return of a 1000-step episode divided by the"
              " mean return of that task's expert demonstrations, floored at 0 and not capped at 1; on MT10 the"
              " success rate (an episode succeeds if the task's success test holds at any step of its 150 steps; the"
              " episode runs all 150 steps either way). Means are over seeds (each seed: the mean over the task's"
              " evaluation episodes), +- the half-width of the 95% confidence interval (t distribution; none with one seed)."]
    return lines


def cell_counts(suite):
    planned = len(suite.planned)
    # A grid taken out of the config before its cells finished is a decision, not work left: counted apart from the
    # missing cells.
    dropped = (f", {len(suite.dropped)} dropped (no longer in the suite config, never finished)" if suite.dropped
               else "")
    lines = [f"Cells: {len(suite.cells)} finished, {len(suite.missing)} missing (not run or not finished),"
             f" {len(suite.failed)} failed, {len(suite.damaged)} damaged{dropped}, of {planned} in suite.json."]
    if suite.failed:
        lines += ["", "Failed cells:", ""] + [f"- `{name}` ({stage}): {message}" for name, stage, message in
                                              suite.failed]
    if suite.damaged:
        lines += ["", "Damaged results (skipped):", ""] + [f"- `{path}`: {reason}" for path, reason in suite.damaged]
    if suite.missing:
        shown = ", ".join(f"`{name}`" for name in suite.missing[:MISSING_SHOWN])
        more = len(suite.missing) - MISSING_SHOWN
        lines += ["", "Missing cells: " + shown + (f" and {more} more (`maps suite status` lists them)" if more > 0
                                                   else "")]
    return lines


def main_results(cells):
    """Per set, method and demo count: the mean score over tasks, mean +- CI over seeds."""
    rows = [[key.set, key.label, key.demos, key.subsample, len(runs), fmt([c.mean_score for c in runs])]
            for key, runs in groups(cells).items()]
    return table(["set", "method", "demos", "k", "seeds", "mean score over tasks"], rows)


def success_rules_table(cells):
    """Success at any step (the score) beside success at the episode's last step, mean over tasks, per method and
    count; [] where the evaluations predate the second."""
    rows = []
    for key, runs in groups(cells).items():
        ends = [mean([t.success_at_end for t in c.tasks]) for c in runs]
        if not ends or any(math.isnan(e) for e in ends):
            continue
        rows.append([key.label, key.demos, key.subsample, len(runs),
                     fmt([mean([t.success for t in c.tasks]) for c in runs]), fmt(ends)])
    if not rows:
        return []
    return (["Success at any step of the episode (the score) and at its last step (the policy holds the goal), mean"
             " over tasks, mean +- 95% CI over seeds:", ""]
            + table(["method", "demos", "k", "seeds", "success at any step", "success at the last step"], rows))


def score_table(cells):
    tasks = task_names(cells)
    rows = []
    for key, runs in groups(cells).items():
        row = [key.label, key.demos, key.subsample, len(runs), span(sorted({c.steps for c in runs}))]
        scores = [[s for s in (task_score(c, t) for c in runs) if s is not None] for t in tasks]
        row += [fmt(values) if values else "-" for values in scores]  # "-": a task these cells did not train on
        row.append(f"**{fmt([c.mean_score for c in runs])}**")
        row.append(span(sorted(c.best_step for c in runs)))
        rows.append(row)
    return table(["method", "demos", "k", "seeds", "steps"] + [short_task(t) for t in tasks] + ["mean",
                                                                                                "best step"], rows)


def paired_table(cells, family="variant"):
    """Every method other than MAPS against MAPS, paired by seed. A variant ("mt_bc (paper_protocol)") is paired with
    MAPS under the same variant when that ran, else with base MAPS (a control such as the wide MT-BC); MAPS's own
    variants are in variant_table. Holm adjusts within a family: with family "variant" (the default) the comparisons
    made under one variant, with "set" every comparison of this table (one set's; MAPS's own variants stay in
    variant_table's families), for a suite whose variants are methods of their own (the suite config's report.holm)."""
    if family not in ("variant", "set"):
        raise ValueError(f"report.holm: expected 'variant' or 'set', got {family!r}")
    by_key = groups(cells)
    rows, families = [], []
    for key, runs in by_key.items():
        method, _, variant = key.label.partition(" ")
        if method == "maps":
            continue
        against = maps_partner(key.label, lambda label: by_key.get(key._replace(label=label)))
        variant = variant.strip("()")
        maps = by_key.get(key._replace(label=against))
        diffs = paired(runs, maps, lambda c: c.mean_score) if maps else []
        if diffs:
            rows.append([key.label, against, key.demos, key.subsample, len(diffs), fmt(diffs, signed=True),
                         paired_p(diffs)])
            families.append(variant if family == "variant" else "set")
    if not rows:
        return []
    rows, sizes = holm_columns(rows, families)
    if family == "set":
        family_text = f"Holm: p adjusted over all {sizes['set']} comparisons of this table (one family: the suite's" \
                      " report.holm \"set\")"
    else:
        family_text = "Holm: p adjusted within the comparisons of one variant (" + ("; ".join(
            f"{'the base methods' if not f else f}: {n}" for f, n in sizes.items() if n) or "none") + ")"
    return (["Paired difference of the mean score over tasks, method - MAPS, over the seeds both ran (mean +- 95% CI;"
             " p: paired t test; a variant is paired with MAPS under the same variant where that ran, else with base"
             " MAPS; " + family_text + "; a difference holds where the Holm p is below 0.05):", ""]
            + table(["method", "against", "demos", "k", "pairs", "difference", "p", "p (Holm)"], rows))



def pooling_table(cells):
    """Does learning the tasks together beat learning each alone? Every base multi-task method (no variant) against
    Single BC, paired by seed, Holm over all of the set's comparisons (one family: methods x counts)."""
    by_key = groups(cells)
    rows = []
    for key, runs in by_key.items():
        if key.label == "single_bc" or " " in key.label:
            continue
        alone = by_key.get(key._replace(label="single_bc"))
        diffs = paired(runs, alone, lambda c: c.mean_score) if alone else []
        if diffs:
            rows.append([key.label, key.demos, key.subsample, len(diffs), fmt(diffs, signed=True), paired_p(diffs)])
    if not rows:
        return []
    rows, sizes = holm_columns(rows)
    size = sizes[None]
    return ([f"Paired difference of the mean score over tasks, method - Single BC, over the seeds both ran (mean +- 95%"
             f" CI; p: paired t test; Holm over the {size} comparisons of this table; a difference holds where the Holm"
             " p is below 0.05):", ""]
            + table(["method", "demos", "k", "pairs", "difference", "p", "p (Holm)"], rows))

USAGE_MEANING = {"maps": "mean selector score", "moore": "share |w_k,i| / sum |w_k|", "paco": "share |w_k,p| / sum |w_k|",
                 "care": "mean attention", "top_k_moe": "mean gate", "soft_modularization": "mean use per layer / L"}
# Where a method's routing measures cannot reach what another's can.
ROUTING_NOTE = {"soft_modularization": "Soft Modularization's modules are its L layers' n modules, each layer's shares"
                " summing to 1/L: a state's top score is at most 1/L and its entropy at least ln L however decisive"
                " each layer's routing is; read its numbers against its own uniform reference, not against another"
                " method's.",
                "moore": "MOORE's and PaCo's usage is the share of |w| (the task weights have signs): two tasks that"
                " weigh the same modules with opposite signs look alike here.",
                "paco": "PaCo's usage is the share of |w| over its parameter sets (the weights have signs), and its"
                " parameter sets start identical, so shares say little until training has set them apart."}


def denoiser_of(cell):
    """Diffusion Policy's denoiser ("maps", "moe", ...; the config's, default unet); None for other methods."""
    if cell.method != "diffusion_policy":
        return None
    return str(cell.config.get("diffusion_policy", {}).get("denoiser", "unet"))


def routing_note(cell):
    """ROUTING_NOTE's text, and for a top-k gate (the top-k MoE's, the MoE denoiser's) the bounds it sets (from the
    cell's config)."""
    if cell.method == "top_k_moe" or denoiser_of(cell) == "moe":
        section = "top_k_moe" if cell.method == "top_k_moe" else "diffusion_policy"
        k = int(cell.config.get(section, {}).get("top_k", 2))
        who = "The top-k MoE's gate" if cell.method == "top_k_moe" else "The MoE denoiser's router"
        return (f"{who} keeps k = {k} experts per state (the others' gate is 0): a state's entropy is at"
                f" most ln {k} = {math.log(k):.2f} and its top score at least 1/{k} = {1 / k:.2f} however it routes;"
                " uniform over the kept experts is its reference, not uniform over all of them.")
    return ROUTING_NOTE.get(cell.method, "")


def usage_meaning(cell):
    """What a cell's module usage is, per method (Diffusion Policy: per denoiser)."""
    denoiser = denoiser_of(cell)
    if denoiser == "maps":
        return "mean selector score"
    if denoiser == "moe":
        return "mean of each state's kept gates scaled to sum 1"
    return USAGE_MEANING.get(cell.method, "mean routing share")


def routed(cells, variants_are_methods=False):
    """{GroupKey: the cells with module usage} of the base methods (no variants) that record it, in report order;
    with `variants_are_methods` (report.holm "set": zoo-modern's denoisers) every variant's too but the keep-only
    ones'."""
    return {key: [c for c in runs if c.has_usage]
            for key, runs in groups(compared_cells(cells, variants_are_methods)).items()
            if any(c.has_usage for c in runs)}


def usage_tables(cells, variants_are_methods=False):
    """Every routing method's per-task module usage (lowest seed) and routing (per seed, then mean +- CI): MAPS's,
    and the zoo's (docs/zoo.md), base methods only (no variants) unless `variants_are_methods` (routed)."""
    lines = []
    for key, runs in routed(cells, variants_are_methods).items():
        who = display_label(key.label)
        meaning = usage_meaning(runs[0])
        tasks = task_names(runs)
        modules = len(runs[0].tasks[0].usage)
        lines += ["", f"{who}, {key.demos} demos, k = {key.subsample}: module usage ({meaning} over the"
                  f" task's evaluation states) of seed {runs[0].seed}"
                  + (f", and the range over the {len(runs)} seeds of the most used module's share:" if len(runs) > 1
                     else " (the only seed with module usage):"), ""]
        rows = []
        for i, task in enumerate(tasks):
            tops = [max(c.tasks[i].usage) for c in runs]
            rows.append([short_task(task)] + [f"{u:.2f}" for u in runs[0].tasks[i].usage]
                        + ([span_fixed(tops, 2, collapse=False)] if len(runs) > 1 else []))
        lines += table(["task"] + [f"m{i}" for i in range(modules)]
                       + (["top module, all seeds"] if len(runs) > 1 else []), rows)
        note = routing_note(runs[0])
        over = (f"{len(runs)} seeds, each computed per seed, then mean +- 95% CI" if len(runs) > 1
                else f"seed {runs[0].seed} only")
        lines += ["", f"Routing ({over}; uniform over {modules} modules: entropy {math.log(modules):.2f}, top score"
                  f" {1 / modules:.2f}):", ""]
        rows = [[short_task(task), fmt(tv), fmt(entropy) if entropy else "-", fmt(top) if top else "-"]
                for task, (tv, entropy, top) in routing(runs, tasks).items()]
        lines += table(["task", "usage distance from the tasks' mean usage (TV)", "per-state entropy (nats)",
                        "per-state top score"], rows)
        if note:
            lines += ["", note]
        lines += ["", f"Task division per seed (a task uses a module whose share of its usage is >= {USED_FACTOR:g}/"
                  f"{modules}; shared: used by two or more tasks, specific: by one; counts of this method's {modules}"
                  " modules: with fewer modules than tasks most are shared whatever the routing, so compare methods"
                  " by these counts as shares of their own M, not by the counts):", ""]
        lines += table(["seed", "shared modules", "specific modules", "unused modules", "tasks using both kinds",
                        "modules per task"], division_rows(runs, modules))
    return lines


def division_counts(runs):
    """Per run, by seed: (seed, shared modules, specific modules, tasks using both, tasks, each task's module count)."""
    out = []
    for c in sorted(runs, key=lambda c: c.seed):
        shared, specific, both, used = division(c)
        out.append((c.seed, len(shared), len(specific), both, len(used), [len(mods) for mods in used.values()]))
    return out


def division_rows(runs, modules):
    return [[seed, shared, specific, modules - shared - specific, f"{both} of {tasks}",
             f"{min(per_task)}-{max(per_task)}"]
            for seed, shared, specific, both, tasks, per_task in division_counts(runs)]


def percent(count, total):
    return f"{count} ({100 * count / total:.0f}%)" if total else "0"


def fig3_table(vs):
    """Fig. 3's counts: per set and over all sets."""
    rows = []
    for (where, method), v in sorted(vs.items(), key=lambda item: (item[0][0] == "all", item[0])):
        rows.append([where, method, v.settings] + [percent(getattr(v, name), v.settings) for name in
                                                   ("better", "worse", "ties", "much_better", "significantly_better",
                                                    "significantly_worse")])
    return table(["set", "method", "settings", "better", "worse", "ties", f"better by > {100 * (MUCH_BETTER - 1):.0f}%",
                  "significantly better", "significantly worse"], rows)


def ablation_table(cells):
    """Base MAPS and the ablations (a selector term zeroed, read from the config) of one set."""
    by_key = ablation_groups(cells)
    if not by_key:
        return []
    rows, pooled = [], {}
    for key, runs in by_key.items():
        maps = by_key.get(key._replace(label="maps"), [])
        diffs = paired(runs, maps, lambda c: c.mean_score) if key.label != "maps" else []
        if key.label != "maps":
            pooled.setdefault(key.label, []).extend(diffs)
        usage = [c for c in runs if c.has_usage]
        entropies = [e for e in (mean_entropy(c) for c in usage) if e is not None]
        rows.append([key.label, ", ".join(runs[0].zeroed_terms) or "-", runs[0].modules, key.demos, key.subsample,
                     len(runs), fmt([c.mean_score for c in runs]),
                     f"{fmt(diffs, signed=True)} ({len(diffs)})" if diffs else "-",
                     fmt([top_share(c) for c in usage]) if usage else "-",
                     fmt([mean(usage_distances(c)) for c in usage]) if usage else "-",
                     fmt(entropies) if entropies else "-"])
    lines = table(["variant", "zeroed selector terms", "M", "demos", "k", "seeds", "mean score over tasks",
                   "difference from MAPS (pairs)", "top-module share", "usage distance between tasks (TV)",
                   "per-state entropy"], rows)
    names = list(pooled)
    adjusted = holm([paired_p(pooled[name]) for name in names])
    lines += ["", "Pooled over demo counts (paired over the (demos, seed) blocks both ran; p: paired t test; Holm: "
              f"adjusted for the {sum(1 for a in adjusted if a == a)} ablations):", ""]
    lines += table(["variant", "pairs", "difference from MAPS", "p", "p (Holm)"],
                   [[name, len(pooled[name]), fmt(pooled[name], signed=True) if pooled[name] else "-",
                     fmt_p(paired_p(pooled[name])), fmt_p(a)] for name, a in zip(names, adjusted)])
    return lines


def sweep_table(cells):
    """MAPS's mean score over tasks by number of modules M (rows) and demos (columns)."""
    sweep = module_sweep_cells(cells)
    if not sweep:
        return []
    counts = sorted({c.demos for c in sweep})
    rows = []
    for m in sorted({c.modules for c in sweep}):
        row = [m]
        for demos in counts:
            runs = [c for c in sweep if c.modules == m and c.demos == demos]
            row.append(f"{fmt([c.mean_score for c in runs])} (n={len(runs)})" if runs else "-")
        rows.append(row)
    return table(["M"] + [f"{d} demos" for d in counts], rows)



def variant_table(cells):
    """Every variant against its own method's base cells at the same demos and k, paired by seed: the paper's protocol
    options (the departures), the controls, the ablations and the module counts alike. Holm adjusts within a family:
    one variant's rows (the counts it ran at), since each variant asks its own question; a family's p values do not
    move when other variants are added."""
    by_key = groups(cells)
    rows = []
    for key, runs in by_key.items():
        method = runs[0].method
        base = by_key.get(key._replace(label=method))
        if key.label == method or not base:
            continue
        columns = against_columns(runs, base)
        if columns:
            rows.append([key.label, key.demos, key.subsample] + columns[:-1] + [improvement(runs, base, cells),
                                                                                  columns[-1]])
    if not rows:
        return []
    rows, _ = holm_columns(rows, [row[0] for row in rows])
    return (["Each variant against the same method without it (its base cells at the same demos, k and seeds): mean"
             " score over tasks, mean +- 95% CI over the seeds both ran (base and variant alike); difference = variant -"
             " base; P(variant > base): the probability that a variant run beats a base run on a task, with its"
             " stratified bootstrap interval (aggregates.py), over the same seeds; p: paired t test; Holm within each"
             " variant's rows (the counts it ran at):", ""]
            + table(["variant", "demos", "k", "pairs", "base", "variant", "difference", "P(variant > base) [95% CI]",
                     "p", "p (Holm)"], rows))


def improvement(runs, reference, cells):
    """P(a run of runs beats one of reference on a task) with its interval, over the seeds both ran (aggregates.py);
    "-" where a cell lacks a task's score."""
    import aggregates  # here: aggregates imports this module's table()
    seeds = {c.seed for c in runs} & {c.seed for c in reference}
    tasks = task_names(cells)
    a = aggregates.runs_by_tasks([c for c in runs if c.seed in seeds], tasks)
    b = aggregates.runs_by_tasks([c for c in reference if c.seed in seeds], tasks)
    return "-" if a is None or b is None else aggregates.fmt_improvement(a, b)


def control_meaning(cell):
    """What a control takes away from MAPS, in a few words."""
    if cell.method == "mt_bc":
        return f"modules and selector: one MLP on [state, task], {len(cell.hidden)} x {cell.hidden[0]}"
    if cell.selector_kind == "uniform":
        return "the selector: scores 1/M, so the task too (it enters MAPS only through the selector)"
    if cell.selector_kind == "task":
        return "the state from the selector: G(k), one mixture of modules per task"
    return f"selector {cell.selector_kind}"


def controls_table(cells):
    """Each control of MAPS (control_cells) against base MAPS at the same demos, k and seeds, paired by seed; Holm over
    the set's whole table, one family: every row asks what one part of MAPS is worth at one count."""
    by_key = groups(cells)
    rows = []
    for key, runs in groups(control_cells(cells)).items():
        columns = against_columns(runs, by_key.get(key._replace(label="maps"), []))
        if columns:
            rows.append([key.label, control_meaning(runs[0]), key.demos, key.subsample] + columns)
    if not rows:
        return []
    rows, sizes = holm_columns(rows)
    size = sizes[None]
    return ([f"Each control against base MAPS at the same demos, k and seeds: mean score over tasks, mean +- 95% CI over"
             f" the seeds both ran; difference = control - MAPS; p: paired t test; Holm over the {size} comparisons of"
             " this table; a difference holds where the Holm p is below 0.05:", ""]
            + table(["control", "takes away", "demos", "k", "pairs", "MAPS", "control", "difference", "p", "p (Holm)"],
                    rows))


def checkpoint_rule_table(cells):
    """The paper's checkpoint rule (the best test score over the kept checkpoints) beside the best-validation one and
    the last checkpoint, in the same runs: how optimistic the paper's rule is, and whether the validation loss picks
    well (the last checkpoint involves no selection at all)."""
    rows = []
    for key, runs in groups(cells).items():
        kept = [c for c in runs if c.best_over_checkpoints is not None]
        if not kept:
            continue
        every = sorted({c.config.get("train", {}).get("keep_every", "?") for c in kept}, key=str)
        last = [c.last_checkpoint for c in kept if c.last_checkpoint is not None]
        rows.append([key.label, key.demos, key.subsample, len(kept), ", ".join(map(str, every)),
                     fmt([c.mean_score for c in kept]), fmt(last) if len(last) == len(kept) else "-",
                     fmt([c.best_over_checkpoints for c in kept]),
                     fmt([c.best_over_checkpoints - c.mean_score for c in kept], signed=True)])
    if not rows:
        return []
    return (["The same runs judged three ways: at the best-validation checkpoint (the headline rule), at the last"
             " checkpoint (no selection), and by the best test score over every kept checkpoint and best.ckpt (the"
             " paper's rule, `maps eval --checkpoints`; optimistic: the maximum of noisy scores); mean score over"
             " tasks, mean +- 95% CI over seeds:", ""]
            + table(["method", "demos", "k", "seeds", "kept every", "best validation", "last checkpoint",
                     "best over checkpoints", "paper's rule - best validation"], rows)
            + checkpoint_rule_pairs(cells))


def checkpoint_rule_pairs(cells):
    """Each method against its MAPS partner (MAPS under the same variant where that ran, else base MAPS, as
    paired_table pairs it), at each checkpoint rule: does the comparison depend on it?"""
    by_key = groups(cells)
    rules = [("best validation", lambda c: c.mean_score), ("last checkpoint", lambda c: c.last_checkpoint),
             ("best over checkpoints", lambda c: c.best_over_checkpoints)]
    found = []  # (key, [diffs per rule])
    for key, runs in by_key.items():
        method, _, variant = key.label.partition(" ")
        partner = maps_partner(key.label, lambda label: by_key.get(key._replace(label=label)))
        maps = by_key.get(key._replace(label=partner))
        kept = [c for c in runs if c.best_over_checkpoints is not None]
        if method == "maps" or not maps or not kept:
            continue
        maps_kept = [c for c in maps if c.best_over_checkpoints is not None]
        # The best-validation checkpoint needs no kept ones: a partner that kept none (the zoo's MAPS at MT10's 14,
        # paired with zoo-modern's Diffusion Policy there) still pairs at it.
        diffs = [paired(runs if name == "best validation" else kept,
                        maps if name == "best validation" else maps_kept, value) for name, value in rules]
        if any(diffs):
            found.append((key, diffs))
    if not found:
        return []
    # Each rule asks the table's question again, so Holm runs over a column's rows (the set's comparisons at that
    # rule), not over the whole table.
    p_raw = [[paired_p(d[r]) for _, d in found] for r in range(len(rules))]
    p_holm = [holm(column) for column in p_raw]
    rows = []
    for i, (key, diffs) in enumerate(found):
        cols = [f"{fmt(d, signed=True)} ({len(d)}), p {fmt_p(p_raw[r][i])}, Holm {fmt_p(p_holm[r][i])}" if d else "-"
                for r, d in enumerate(diffs)]
        rows.append([key.label, key.demos, key.subsample] + cols)
    sizes = ", ".join(f"{name} {sum(not math.isnan(p) for p in column)}" for (name, _), column in zip(rules, p_raw))
    return (["", "Method - MAPS (under the same variant where that ran, else base MAPS), paired over seeds, at each"
             " rule (mean +- 95% CI (pairs), p: paired t test; Holm: over the column's rows with a p, each rule one"
             f" family: {sizes}; the best-validation column's family is the rows that kept checkpoints, so its Holm"
             " can differ from the paired table's for the same comparison):", ""]
            + table(["method", "demos", "k"] + [name for name, _ in rules], rows))


def compute_table(cells):
    """CPU time per grid and method: each finished cell's cost (Cell.compute_seconds: training over every attempt from
    curve.csv, plus evaluation; each cell runs on one thread), summed."""
    by, hows = {}, {}  # by[(grid, set, label)] = [(seconds, cell), ...]
    for c in cells:
        seconds, how = c.compute_seconds()
        by.setdefault((c.grid or "-", c.set, c.label), []).append((seconds, c))
        hows[how] = hows.get(how, 0) + 1
    rows = []
    for (grid, set_name, label), costs in sorted(by.items(), key=lambda item: item[0]):
        seconds = [s for s, _ in costs]
        rows.append([grid, set_name, label, len(seconds), f"{sum(seconds) / 3600:.2f}",
                     f"{sum(seconds) / len(seconds) / 60:.1f}", machine_counts([c for _, c in costs])])
    total = sum(s for costs in by.values() for s, _ in costs if s == s)
    sources = {"cpu": "training's CPU seconds from curve.csv",
               "windows": "training's wall seconds per curve.csv window",
               "gail": "GAIL's iterations from curve.csv (their CPU seconds where the curve has them, else each"
                       " iteration's env steps over its logged env steps per second, so shared cores count, an"
                       f" iteration over {STOPPED_FACTOR:g} times its run's median, a stopped process's, at the"
                       " median)",
               "attempt": "the finishing attempt's wall seconds (no curve or evaluation time)"}
    counted = "; ".join(f"{hows[how]} by {text}" for how, text in sources.items() if hows.get(how))
    mixed = len([cpus for cpus in cpu_counts(cells) if cpus]) > 1
    return (table(["grid", "set", "method", "cells", "CPU-hours", "minutes per cell", "machines"], rows)
            + ["", f"In all: {total / 3600:.1f} CPU-hours over {len(cells)} finished cells (training, validation and"
                   " evaluation; one thread each). Training counts every attempt of a resumed cell (steps redone after"
                   f" a kill once) and the evaluation its own seconds. Cells counted: {counted}. Machines: the CPUs"
                   " the group's cells ran on (cells each; ?: not recorded)."
                   + (" The CPU-hours of different machines are summed as they are, though a CPU-second differs"
                      " between them (docs/performance.md): compare rows' costs only where the machines column"
                      " agrees." if mixed else ""), "",
               machines_line(cells)])


def cpu_counts(cells):
    """{the CPUs a cell ran on joined with " + ", or None where not recorded: cells}."""
    on = {}
    for c in cells:
        key = " + ".join(c.cpus) if c.cpus else None
        on[key] = on.get(key, 0) + 1
    return on


def machine_counts(cells):
    """The compute table's machines cell: each CPU (most cells first) with its count, "?" for unrecorded ones."""
    on = cpu_counts(cells)
    named = sorted(((k, n) for k, n in on.items() if k), key=lambda kn: (-kn[1], kn[0]))
    return ", ".join([f"{cpu} ({n})" for cpu, n in named] + ([f"? ({on[None]})"] if on.get(None) else []))


def machines_line(cells):
    """Which CPUs the cells ran on: a CPU-second differs between them (docs/performance.md)."""
    on = cpu_counts(cells)
    named = "; ".join(f"{cpu}: {n}" for cpu, n in sorted(((k, n) for k, n in on.items() if k), key=lambda kn: -kn[1]))
    unknown = on.get(None, 0)
    return ("Machines (the CPU models each cell's training and evaluation ran on, from result.json; a cell resumed on"
            " another kind names both): " + (named or "none recorded")
            + (f"; not recorded (finished before result.json named its CPU): {unknown}" if unknown else "") + ".")
