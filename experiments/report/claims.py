"""The paper's claims (its Sec. V, Figs. 2-6) checked against a suite's cells: each claim as the paper states it, the
paper's figure, ours computed from the finished cells, and a verdict by a rule stated beside it, so that the table is
recomputed as cells land and nobody judges a claim by eye.

Verdicts: "holds", "partly" (the rule says what that means for each claim), "does not hold", and "not measured" where
the cells a claim needs are not finished. Scores are in [0, 1] (success rate, or return / expert return), so the
paper's "4-15%" is read as 0.04-0.15 of the score. Paired differences are over the seeds both sides ran (for the
ablations and the module sweep pooled over the (demos, seed) blocks, as tables.ablation_table does); "significant"
means a Holm-adjusted p below 0.05 within the family the claim names."""
import math
from dataclasses import dataclass

from suite_results import METHOD_NAMES, ablation_groups, groups, module_sweep_cells
from suite_stats import USED_FACTOR, division, holm, mean, paired, paired_p, usage_distances, vs_single_bc

BASELINES = ["single_bc", "mt_bc", "mt_mh_bc", "maml"]
COMPARED = ["maps"] + BASELINES
# The paper's methods, by the report's names.
NAMES = {method: METHOD_NAMES[method] for method in ("maps", "single_bc", "mt_bc", "mt_mh_bc", "maml")}
ALPHA = 0.05
# The paper's example (Fig. 6): window-open and drawer-close share their modules; drawer-open shares one of them
# and has a task-specific one.
EXAMPLE = ("mt10/window-open", "mt10/drawer-close", "mt10/drawer-open")

HOLDS, PARTLY, NO, NOT_MEASURED = "holds", "partly", "does not hold", "not measured"


@dataclass
class Claim:
    claim: str  # as the paper states it (quoted or closely paraphrased)
    where: str  # the paper's figure and the set
    paper: str  # the paper's number
    ours: str  # ours, from the cells
    verdict: str
    rule: str  # how the verdict is decided


def signed(x):
    return f"{x:+.2f}"


def base_groups(cells):
    """{(set, method, demos): [cells by seed]} of the base variants of the compared methods, k folded (one per set)."""
    out = {}
    for key, runs in groups([c for c in cells if c.label == c.method and c.method in COMPARED]).items():
        out.setdefault((key.set, key.label, key.demos), []).extend(runs)
    return out


def sets_with(by, methods):
    """The sets (in order) where every method in `methods` has a finished base cell."""
    sets = []
    for set_name, method, _ in by:
        if set_name not in sets and all(any(k[0] == set_name and k[1] == m for k in by) for m in methods):
            sets.append(set_name)
    return sets


def counts_of(by, set_name, methods):
    """The demo counts of a set at which every method in `methods` has a finished base cell."""
    return sorted({d for s, m, d in by if s == set_name}
                  & set.intersection(*({d for s, m2, d in by if s == set_name and m2 == m} for m in methods)))


def set_mean(runs):
    return mean([c.mean_score for c in runs])


def beats_all_baselines(by):
    """Fig. 2: "MAPS with 10 modules performs significantly better than all the baselines", per set."""
    found = []
    for set_name in sets_with(by, ["maps"]):
        pairs = []
        for method in BASELINES:
            for demos in counts_of(by, set_name, ["maps", method]):
                diffs = paired(by[(set_name, "maps", demos)], by[(set_name, method, demos)], lambda c: c.mean_score)
                pairs.append((method, demos, diffs, paired_p(diffs)))
        if not pairs:
            continue
        adjusted = holm([p for *_, p in pairs])
        better = [(m, d) for (m, d, diffs, _), a in zip(pairs, adjusted) if a < ALPHA and mean(diffs) > 0]
        worse = [(m, d) for (m, d, diffs, _), a in zip(pairs, adjusted) if a < ALPHA and mean(diffs) < 0]
        tested = sum(1 for *_, p in pairs if not math.isnan(p))
        detail = ", ".join(f"{NAMES[m]} at {d}" for m, d in better)
        # A baseline paired on one seed only has no p: it is not tested, so it does not count as run.
        ran = [m for m in BASELINES if any(m == method and not math.isnan(p) for method, _, _, p in pairs)]
        ours = (f"significantly better in {len(better)} of {tested} (baseline, count) comparisons"
                + (f" ({detail})" if better else "") + f"; significantly worse in {len(worse)}"
                + ("" if len(ran) == len(BASELINES) else
                   f"; only {', '.join(NAMES[m] for m in ran) or 'none'} of the four baselines tested"))
        verdict = HOLDS if tested and len(better) == tested else PARTLY if better else NO if tested else NOT_MEASURED
        # Beating the baselines that ran cannot show beating all four; failing against one already refutes it.
        if verdict == HOLDS and len(ran) < len(BASELINES):
            verdict = NOT_MEASURED
        found.append(Claim("MAPS (M = 10) performs significantly better than all the baselines", f"Fig. 2, {set_name}",
                            "better than all four at every count", ours, verdict,
                            "holds: MAPS significantly better (paired over seeds, Holm over the set's comparisons) in"
                            " every comparison, all four baselines tested; partly: in some"))
    return found


def mt_mh_bc_margin(by):
    """Fig. 2: "The MT-MH BC baseline performs worse than MAPS by 4-15%", per set."""
    found = []
    for set_name in sets_with(by, ["maps", "mt_mh_bc"]):
        counts = counts_of(by, set_name, ["maps", "mt_mh_bc"])
        margins = [set_mean(by[(set_name, "maps", d)]) - set_mean(by[(set_name, "mt_mh_bc", d)]) for d in counts]
        inside = sum(1 for m in margins if m >= 0.04)
        ours = ", ".join(f"{signed(m)} at {d}" for m, d in zip(margins, counts)) + " (MAPS - MT-MH-BC, mean score)"
        verdict = HOLDS if inside == len(margins) else PARTLY if inside else NO
        found.append(Claim("MT-MH-BC performs worse than MAPS by 4-15%", f"Fig. 2, {set_name}", "0.04-0.15 below MAPS",
                            ours, verdict, "holds: MAPS above MT-MH-BC by at least 0.04 at every count; partly: at"
                                           " some counts"))
    return found


def against_single(cells, method, claim, paper, threshold, partly_threshold=None):
    """A Fig. 3 claim: `method` better than Single BC in more than `threshold` of the (task, count) settings, over
    every set with both."""
    vs = vs_single_bc(cells).get(("all", method))
    if vs is None or not vs.settings:
        return [Claim(claim, "Fig. 3, all sets", paper, "no settings with both finished", NOT_MEASURED, "")]
    share = vs.share("better")
    per_set = "; ".join(f"{s}: {v.better} of {v.settings}" for (s, m), v in sorted(vs_single_bc(cells).items())
                        if m == method and s != "all")
    ours = (f"better in {vs.better} of {vs.settings} settings ({100 * share:.0f}%; {per_set}); significantly better"
            f" in {vs.significantly_better}, significantly worse in {vs.significantly_worse}")
    if share > threshold:
        verdict = HOLDS
    elif partly_threshold is not None and share > partly_threshold:
        verdict = PARTLY
    else:
        verdict = NO
    rule = f"holds: better (mean over seeds) in more than {100 * threshold:.0f}% of the (task, count) settings"
    if partly_threshold is not None:
        rule += f"; partly: in more than {100 * partly_threshold:.0f}%"
    return [Claim(claim, "Fig. 3, all sets", paper, ours, verdict, rule)]


def maps_much_better(cells):
    """Fig. 3: "... with 50% of that being a significant (more than 10%) improvement"."""
    vs = vs_single_bc(cells).get(("all", "maps"))
    if vs is None or not vs.settings:
        return []
    of_better = vs.much_better / vs.better if vs.better else 0.0
    ours = (f"better by > 10% in {vs.much_better} of {vs.settings} settings ({100 * vs.share('much_better'):.0f}% of"
            f" all, {100 * of_better:.0f}% of the {vs.better} better ones)")
    verdict = HOLDS if of_better >= 0.5 else PARTLY if of_better >= 0.25 else NO
    return [Claim("of MAPS's better settings, 50% are better by more than 10%", "Fig. 3, all sets",
                  "50% of the > 90%", ours, verdict,
                  "holds: at least half of the settings where MAPS is better are better by > 10% (mean score > 1.1"
                  " x Single BC's); partly: at least a quarter")]


def maml_worst(by):
    """Fig. 2/3: "The worst performing one is MAML", per set."""
    found = []
    for set_name in sets_with(by, COMPARED):
        counts = counts_of(by, set_name, COMPARED)
        lowest = []
        for d in counts:
            scores = {m: set_mean(by[(set_name, m, d)]) for m in COMPARED}
            lowest.append(min(scores, key=scores.get))
        worst = sum(1 for m in lowest if m == "maml")
        ours = ", ".join(f"{d}: {NAMES[m]}" for d, m in zip(counts, lowest)) + " (lowest mean score per count)"
        verdict = HOLDS if worst == len(counts) else PARTLY if worst else NO
        found.append(Claim("MAML is the worst performing method", f"Fig. 2, {set_name}", "lowest", ours, verdict,
                            "holds: MAML has the lowest mean score of the five at every count; partly: at some"))
    return found


def pooled_ablations(cells):
    """{zeroed term: (pooled paired score differences from MAPS, usage TV differences)} of one set's ablations, and
    the base MAPS groups; ({}, {}) without ablations."""
    by_key = ablation_groups(cells)
    scores, tvs = {}, {}
    for key, runs in by_key.items():
        if key.label == "maps":
            continue
        base = by_key.get(key._replace(label="maps"), [])
        term = runs[0].zeroed_terms[0]
        scores.setdefault(term, []).extend(paired(runs, base, lambda c: c.mean_score))
        tvs.setdefault(term, []).extend(paired([c for c in runs if c.has_usage], [c for c in base if c.has_usage],
                                               mean_usage_distance))
    return scores, tvs


def mean_usage_distance(cell):
    return mean(usage_distances(cell))


def ablation_claims(cells):
    """Fig. 4 (MT10): explore matters most, smooth least; without share tasks specialise, without explore every task
    uses one module."""
    mt10 = [c for c in cells if c.set == "mt10"]
    scores, tvs = pooled_ablations(mt10)
    where = "Fig. 4, mt10"
    found = [] if scores else [Claim("removing exploration costs the most success on MT10", where,
                                      "the largest drop of the four", "no ablation cells beside base MAPS cells",
                                      NOT_MEASURED, "")]
    terms = [t for t in scores if scores[t]]
    adjusted = dict(zip(terms, holm([paired_p(scores[t]) for t in terms])))
    means = {t: mean(scores[t]) for t in terms}
    table = "; ".join(f"no {t} {signed(means[t])} (Holm p {adjusted[t]:.2f}, {len(scores[t])} pairs)" for t in terms)
    complete = all(t in means for t in ("share", "explore", "sparse", "smooth"))
    if "explore" in means:
        most = min(means, key=means.get) == "explore"
        significant = adjusted["explore"] < ALPHA and means["explore"] < 0
        verdict = (HOLDS if most and significant else PARTLY if most or significant else NO) if complete else \
            NOT_MEASURED
        found.append(Claim("removing exploration costs the most success on MT10", where,
                            "the largest drop of the four", "score difference from MAPS, pooled over counts: " + table,
                            verdict, "holds: no-explore's drop is the largest of the four and significant (Holm over"
                                     " the four); partly: one of the two; not measured until all four ran"))
    if "smooth" in means:
        least = min(means, key=lambda t: abs(means[t])) == "smooth"
        found.append(Claim("smoothing has the least impact on performance", where, "the smallest change",
                            f"|difference| of no smooth {abs(means['smooth']):.2f}; smallest: "
                            f"no {min(means, key=lambda t: abs(means[t]))}", HOLDS if least and complete else
                            NO if complete else NOT_MEASURED,
                            "holds: no-smooth's mean score difference from MAPS is the smallest in size of the four"))
    if "share" in tvs and tvs["share"]:
        diffs = tvs["share"]
        verdict = directional(diffs, +1)
        found.append(Claim("without sharing, the modules become task-specific", where + " (top)",
                            "tasks use separate modules", f"usage distance between tasks (TV), no share - MAPS:"
                            f" {signed(mean(diffs))} (p {paired_p(diffs):.2f}, {len(diffs)} pairs)", verdict,
                            "holds: the tasks' module usage differs more without share, by at least 0.05 TV (paired"
                            " over (demos, seed), p < 0.05); partly: more on the mean only"))
    if "sparse" in tvs and tvs["sparse"]:
        diffs = tvs["sparse"]
        found.append(Claim("sparsity makes modules task-specific (without it, tasks mix the same modules)",
                            where + " (top)", "less task-specific without it",
                            f"usage distance between tasks (TV), no sparse - MAPS: {signed(mean(diffs))} (p"
                            f" {paired_p(diffs):.2f}, {len(diffs)} pairs); score {signed(means.get('sparse', math.nan))}",
                            directional(diffs, -1), "holds: the tasks' module usage differs less without sparse,"
                                                    " by at least 0.05 TV (p < 0.05); partly: less on the mean only"))
    no_explore = [c for c in mt10 if c.has_usage and c.zeroed_terms == ("explore",) and c.method == "maps"]
    if no_explore:
        tops = [mean([max(t.usage) for t in c.tasks]) for c in no_explore]
        same = sum(1 for c in no_explore if len({t.usage.index(max(t.usage)) for t in c.tasks}) == 1)
        verdict = HOLDS if same == len(no_explore) and min(tops) >= 0.8 else PARTLY if same or mean(tops) >= 0.8 \
            else NO
        found.append(Claim("without exploration, all the tasks end up using only one module", where + " (top)",
                            "one module for every task", f"the top module's share {min(tops):.2f}-{max(tops):.2f};"
                            f" one top module for all tasks in {same} of {len(no_explore)} runs", verdict,
                            "holds: in every run one module is every task's most used, with a share of at least 0.8;"
                            " partly: one of the two"))
    return found


# A usage claim ("modules become task-specific") needs the tasks' usage distance (TV, in [0, 1]) to move by at least
# this much: a significant 0.01 is no change of kind.
USAGE_EFFECT = 0.05


def directional(diffs, sign):
    """HOLDS when the paired differences are significantly of `sign` and at least USAGE_EFFECT on the mean, PARTLY
    when their mean is of `sign`, else NO."""
    m, p = mean(diffs), paired_p(diffs)
    if sign * m >= USAGE_EFFECT and p < ALPHA:
        return HOLDS
    return PARTLY if sign * m > 0 else NO


def module_claims(cells):
    """Fig. 5: M = 5 comparable to M = 10 on MT10; more modules than tasks beneficial only on Gravity."""
    found = []
    by_m = {}
    for set_name in {c.set for c in cells}:
        for c in module_sweep_cells([c for c in cells if c.set == set_name]):
            by_m.setdefault((c.set, c.modules), []).append(c)

    def pooled(set_name, m_a, m_b):
        a, b = by_m.get((set_name, m_a), []), by_m.get((set_name, m_b), [])
        index = {(c.demos, c.seed): c for c in b}
        return [x.mean_score - index[(x.demos, x.seed)].mean_score for x in a if (x.demos, x.seed) in index]

    diffs = pooled("mt10", 5, 10)
    if diffs:
        m, p = mean(diffs), paired_p(diffs)
        verdict = HOLDS if abs(m) <= 0.05 and not p < ALPHA else PARTLY if not p < ALPHA else NO
        found.append(Claim("on MT10 the success of M = 5 is comparable to that of M = 10", "Fig. 5, mt10",
                            "comparable", f"M = 5 - M = 10: {signed(m)} (p {paired_p(diffs):.2f}, {len(diffs)}"
                                          " (demos, seed) pairs)", verdict,
                            "holds: no significant difference and |mean| <= 0.05; partly: no significant difference"
                            " but a larger mean gap"))
    else:
        found.append(Claim("on MT10 the success of M = 5 is comparable to that of M = 10", "Fig. 5, mt10",
                            "comparable", "no M = 5 cells finished", NOT_MEASURED, ""))
    rows, verdicts = [], {}
    for set_name, tasks in (("gravity", 5), ("mt10", 10)):
        more = [m for (s, m) in by_m if s == set_name and m > tasks]
        if not more or (set_name, tasks) not in by_m:
            continue
        diffs = pooled(set_name, max(more), tasks)
        if not diffs:
            continue
        verdicts[set_name] = mean(diffs) > 0 and paired_p(diffs) < ALPHA
        rows.append(f"{set_name}: M = {max(more)} - M = {tasks} {signed(mean(diffs))} (p {paired_p(diffs):.2f},"
                    f" {len(diffs)} pairs)")
    if len(verdicts) == 2:
        verdict = HOLDS if verdicts["gravity"] and not verdicts["mt10"] else PARTLY if not verdicts["mt10"] else NO
    else:
        verdict = NOT_MEASURED
    found.append(Claim("more modules than tasks helps only on Gravity", "Fig. 5, gravity and mt10",
                        "better on Gravity, plateau at M = 10 elsewhere", "; ".join(rows) or "no cells at M = 10 and"
                        " M above the task count on both sets", verdict,
                        "holds: significantly better with the most modules than with M = number of tasks on Gravity"
                        " and not on MT10; partly: not on MT10 and not significantly on Gravity"))
    return found


def division_claims(cells):
    """Fig. 6 (MT10): tasks divided into shared and task-specific modules, and the paper's example."""
    runs = [c for c in cells if c.set == "mt10" and c.label == "maps" and c.has_usage and c.modules == 10]
    if not runs:
        return [Claim("tasks are composed of shareable modules, task-specific modules, or a combination",
                      "Fig. 6, mt10", "both kinds", "no MAPS cells with module usage", NOT_MEASURED, "")]
    top = max(c.demos for c in runs)
    runs = sorted((c for c in runs if c.demos == top), key=lambda c: c.seed)
    divided, described = 0, []
    example = 0
    for c in runs:
        shared, specific, both, used = division(c)
        divided += bool(shared and specific)
        described.append(f"seed {c.seed}: {len(shared)} shared, {len(specific)} specific, {both} of {len(used)} tasks use"
                         " both")
        if all(t in used for t in EXAMPLE):
            wo, dc, do = (used[t] for t in EXAMPLE)
            others = set().union(*(m for t, m in used.items() if t != EXAMPLE[2]))
            example += bool(wo & dc and do & (wo | dc) and do - others)
    found = [Claim("tasks are composed of shareable modules, task-specific modules, or a combination",
                    f"Fig. 6, mt10 ({top} demos)", "both kinds", "; ".join(described), HOLDS if divided == len(runs)
                    else PARTLY if divided else NO,
                    f"a task uses a module whose share of its selector scores is >= {USED_FACTOR:g}/M; shared: used"
                    " by two or more tasks, specific: by one. holds: both kinds in every seed; partly: in some")]
    found.append(Claim("window-open and drawer-close share their modules; drawer-open shares one of them and has a"
                        " task-specific one", f"Fig. 6, mt10 ({top} demos)", "mu_5, mu_9 shared; mu_7 drawer-open's",
                        f"the pattern in {example} of {len(runs)} seeds", HOLDS if example * 2 > len(runs) else
                        PARTLY if example else NO,
                        "holds: in most seeds window-open and drawer-close use a common module, drawer-open uses one"
                        " of theirs and one no other task uses; partly: in some seeds"))
    return found


def claims(cells):
    """Every claim the cells can speak to, in the paper's order."""
    by = base_groups(cells)
    out = beats_all_baselines(by) + mt_mh_bc_margin(by)
    out += against_single(cells, "maps", "MAPS performs better than Single BC more than 90% of the time", "> 90%", 0.9,
                          0.5)
    out += maps_much_better(cells)
    out += against_single(cells, "mt_mh_bc", "MT-MH-BC is almost always better than Single BC", "almost always", 0.9,
                          0.5)
    out += against_single(cells, "mt_bc", "MT-BC performs better than Single BC in most of the tasks", "most", 0.5)
    out += maml_worst(by)
    out += ablation_claims(cells) + module_claims(cells) + division_claims(cells)
    return out


def claims_table(cells, table):
    """The claims as a Markdown table (table(header, rows) from tables.py), then each verdict's rule."""
    found = claims(cells)
    if not found:
        return []
    rows = [[i + 1, c.claim, c.where, c.paper, c.ours, f"**{c.verdict}**"] for i, c in enumerate(found)]
    lines = table(["#", "the paper's claim", "where", "paper", "here", "verdict"], rows)
    lines += ["", "Rules: " + " ".join(f"({i + 1}) {c.rule}." for i, c in enumerate(found) if c.rule)]
    return lines
