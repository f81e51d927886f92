"""GAIL against BC (issue 45, docs/adversarial.md): the report's tables on the imitation objective. A cell trained by
GAIL says so in its resolved config ("imitation": "gail"); it is paired with the cell of the same set, method, demos,
k and seed trained by BC with the same network on the same tasks (the method's base cells, or a width control's for a
GAIL run of that width: bc_partner). Four tables, each a list of Markdown lines:

- objective_table: every method's GAIL - BC difference in mean score, paired by seed, Holm over the whole table (one
  question, asked at every set, method and demo count);
- maps_table: MAPS against each other method under each objective, paired by seed, Holm within each objective (does
  MAPS's lead, or its lack, survive the change of objective?);
- speed_table: how fast each method learns under GAIL (the area under its training curve, the env steps to 0.9 of
  the expert's return), MAPS against each other method paired by seed (the final scores of the cheetah sets saturate
  near the expert's, so a difference between methods shows in how soon, not how high);
- routing_table: MAPS's routing under each objective (how far each task's module usage is from the tasks' mean, the
  per-state entropy and top score, the shared and task-specific modules), GAIL - BC paired by seed.

The figures are in imitation_figures.py."""
import csv
import math
from collections import namedtuple

from suite_results import METHOD_NAMES, SET_ORDER, method_rank, order, success_scored
from suite_stats import USED_FACTOR, division, fmt, holm, mean, paired, paired_p, usage_distances
from tables import against_columns, holm_columns, table

Setting = namedtuple("Setting", "set method variant demos subsample")
OBJECTIVES = ["bc", "gail"]
# The suite's own GAIL runs: "gail" on the cheetah sets and "gail_mt10" on MT10 (10 rollout episodes per task per
# iteration, as MT10's pilot; its label keeps the name, its settings being another's). Any other GAIL variant is a
# control or a pilot, which asks a question of its own.
MAIN_VARIANTS = ("gail", "gail_mt10")


def objective(cell):
    """"gail" or "bc" (a config written before the key existed trained by BC)."""
    return str(cell.config.get("imitation", "bc"))


def clamp(cell):
    """The bound a cell's standardised inputs are clamped to (data.observation_clip); 0, none, for a config written
    before the key."""
    return float(cell.config.get("data", {}).get("observation_clip", 0) or 0)


def network(cell):
    """What a cell's network is, what it sees and what it learns: MAPS's module count and widths, or a baseline's
    hidden widths, the bound its standardised inputs are clamped to (data.observation_clip: 0, none, for a config
    written before the key), and the tasks it trains on (data.tasks: [] for all of the set's)."""
    tasks = tuple(cell.config.get("data", {}).get("tasks", []) or [])
    clip = clamp(cell)
    if cell.method == "maps":
        maps = cell.config.get("maps", {})
        return ("maps", cell.modules, tuple(maps.get("module_hidden", ())), tuple(maps.get("selector_hidden", ())),
                clip, tasks)
    return (cell.method, cell.hidden, clip, tasks)


def bc_partner(bc_cells, gail_cells, base_networks):
    """The BC cells a GAIL setting is paired with, among one set, method, demos and k's BC cells (bc_cells): where the
    GAIL run has a network the method's base cells have anywhere on the set (base_networks), the base cells of that
    network; where its network is another (a width control, or inputs clamped otherwise), the cells of the one BC
    variant that has it ("mt_bc (w430)" for a GAIL run at 3 x 430, "mt_bc (clip10)" for one on clamped inputs); []
    where none or several do. So a variant of the BC protocol (an ablation, the
    paper's options) is never the partner: its network is the base's."""
    shape = network(gail_cells[0])
    method = gail_cells[0].method
    same = {}
    for c in bc_cells:
        if network(c) == shape:
            same.setdefault(c.label, []).append(c)
    if shape in base_networks or not base_networks:
        return same.get(method, [])
    controls = [runs for label, runs in same.items() if label != method]
    return controls[0] if len(controls) == 1 else []


def by_objective(cells):
    """{Setting: {"bc": [cells], "gail": [cells]}}: a method's cells trained by GAIL under one variant, and beside them
    the BC cells of the method at the same set, demos and k and with the same network (bc_partner: the base cells, or
    a width control's for a GAIL run of that width), in report order (set, method, variant, demos, k). A suite may
    hold several GAIL variants (a pilot's settings): each is its own setting. Other variants of the BC protocol
    (ablations, the paper's options) are not the BC a GAIL cell is paired with."""
    bc, gail, base_networks = {}, {}, {}
    for c in cells:
        if objective(c) == "gail":
            gail.setdefault(Setting(c.set, c.method, c.variant, c.demos, c.subsample), []).append(c)
        else:
            bc.setdefault((c.set, c.method, c.demos, c.subsample), []).append(c)
            if c.label == c.method:
                base_networks.setdefault((c.set, c.method), set()).add(network(c))
    sets = order(SET_ORDER, {s.set for s in gail})
    found = {s: {"bc": bc_partner(bc.get((s.set, s.method, s.demos, s.subsample), []), runs,
                                  base_networks.get((s.set, s.method), set())), "gail": runs}
             for s, runs in gail.items()}
    return dict(sorted(found.items(), key=lambda item: (sets.index(item[0].set), method_rank(item[0].method),
                                                        item[0].method, item[0].variant, item[0].demos,
                                                        item[0].subsample)))


def maps_setting(settings, setting):
    """MAPS's setting to pair a GAIL setting with: MAPS under the same GAIL variant, else under one of the suite's own
    (MAIN_VARIANTS) where that ran GAIL alike (the same gail settings and input clamp: a width control such as
    gail_w430 has no MAPS of its own); (None, None) otherwise."""
    own = settings.get(setting._replace(method="maps"))
    if own:
        return setting._replace(method="maps"), own
    runs = settings.get(setting, {}).get("gail", [])
    for variant in MAIN_VARIANTS:
        key = setting._replace(method="maps", variant=variant)
        found = settings.get(key)
        if (found and runs and found["gail"] and found["gail"][0].config.get("gail") == runs[0].config.get("gail")
                and clamp(found["gail"][0]) == clamp(runs[0])):
            return key, found
    return None, None


def has_gail(cells):
    return any(objective(c) == "gail" for c in cells)


def name(method, variant="gail"):
    """"MAPS"; "MAPS (gail_mt10)" for any GAIL variant but "gail", the suite's own among them (a table names the
    settings each row ran; the figures name only the others, imitation_figures.variant_name)."""
    return METHOD_NAMES.get(method, method) + ("" if variant == "gail" else f" ({variant})")


def budget_line(cells):
    """What GAIL ran: its env steps per task and checkpoint rule, from the GAIL cells' configs."""
    gail = [c for c in cells if objective(c) == "gail"]
    steps = sorted({int(c.config.get("gail", {}).get("env_steps_per_task", 0)) for c in gail})
    rules = sorted({str(c.config.get("gail", {}).get("checkpoint", "last")) for c in gail})
    bc = [c for c in cells if objective(c) == "bc"]
    return (f"GAIL: {'/'.join(f'{s:,}' for s in steps)} env steps per task, checkpoint {'/'.join(rules)}"
            f" ({'the policy after the last iteration' if rules == ['last'] else 'gail.checkpoint'}); BC:"
            f" {'/'.join(str(s) for s in sorted({c.steps for c in bc}))} steps, the best-validation checkpoint."
            " Both evaluated alike (the suite's eval settings, the mean action).")


def expert_returns(cell):
    """{task: the return its score is divided by}: the evaluation's expert_return, else (a result written before maps
    eval recorded it) its return over its score where the score is above 0: an estimate, off where some episode's
    score was floored at 0 (the score is the mean of per-episode max(0, return / expert))."""
    found = {}
    for t in cell.tasks:
        expert = t.expert_return
        if expert is None and t.score > 0 and math.isfinite(t.return_mean):
            expert = t.return_mean / t.score
        if expert is not None and math.isfinite(expert) and expert != 0:
            found[t.task] = expert
    return found


def training_curve(cell):
    """{env steps per task: the mean over tasks of the iteration's mean training return over the task's expert
    return (expert_returns)} from a GAIL cell's curve.csv. {} when the curve is missing or unreadable, or a task has
    no expert return to divide by."""
    if success_scored(cell.set, [cell]):
        return success_curve(cell)
    experts = expert_returns(cell)
    if not experts or set(experts) != {t.task for t in cell.tasks}:
        return {}
    curve = {}
    try:
        with (cell.folder / "curve.csv").open() as f:
            for row in csv.DictReader(f):
                values = [float(row[f"return:{task}"]) / expert for task, expert in experts.items()]
                curve[int(row["env_steps_per_task"])] = mean(values)
    except (OSError, KeyError, ValueError, TypeError, ZeroDivisionError):
        return {}
    return curve


def success_curve(cell):
    """{env steps per task: the share of the iteration's training episodes that succeeded at some step, over all
    tasks} from curve.csv's success column: the curve of a set scored by success (MT10)."""
    curve = {}
    try:
        with (cell.folder / "curve.csv").open() as f:
            for row in csv.DictReader(f):
                curve[int(row["env_steps_per_task"])] = float(row["success"])
    except (OSError, KeyError, ValueError, TypeError):
        return {}
    return curve


def objective_table(cells):
    """Per set, method and demo count: BC's and GAIL's mean score over tasks over the seeds both ran, the paired
    difference GAIL - BC and its p; Holm over every row. [] without a pair."""
    rows, signs = [], []
    for setting, runs in by_objective(cells).items():
        columns = against_columns(runs["gail"], runs["bc"])  # pairs, BC, GAIL, GAIL - BC, p
        if columns:
            rows.append([setting.set, name(setting.method, setting.variant), setting.demos, setting.subsample]
                        + columns)
            signs.append(mean(paired(runs["gail"], runs["bc"], lambda c: c.mean_score)))
    if not rows:
        return []
    adjusted = holm([row[-1] for row in rows])
    tested = sum(1 for a in adjusted if a == a)
    higher = sum(1 for sign, a in zip(signs, adjusted) if a < 0.05 and sign > 0)
    lower = sum(1 for sign, a in zip(signs, adjusted) if a < 0.05 and sign < 0)
    shown, _ = holm_columns(rows)
    return ([budget_line(cells), "",
             "Mean score over tasks, mean +- 95% CI over the seeds both objectives ran; difference = GAIL - BC, paired"
             f" by seed; p: paired t test; Holm over all {tested} rows with a p (one question: does the objective"
             " change the score?):", ""]
            + table(["set", "method", "demos", "k", "pairs", "BC", "GAIL", "GAIL - BC", "p", "p (Holm)"], shown)
            + ["", f"GAIL above BC after Holm in {higher} of {tested} settings, below in {lower}."])


def maps_table(cells):
    """Under each objective, MAPS against each other method at the same set, demos, k and seeds: the paired
    difference MAPS - other, p, Holm within the objective. [] where MAPS or another method is missing."""
    settings = by_objective(cells)
    rows, families = [], []
    for setting, runs in settings.items():
        if setting.method == "maps":
            continue
        maps_key, partner = maps_setting(settings, setting)
        if not partner:
            continue
        row = [setting.set, f"{name('maps', maps_key.variant)} - {name(setting.method, setting.variant)}",
               setting.demos, setting.subsample]
        for kind in OBJECTIVES:
            diffs = paired(partner[kind], runs[kind], lambda c: c.mean_score)
            rows.append(row + [kind, len(diffs), fmt(diffs, signed=True) if diffs else "-",
                               paired_p(diffs) if diffs else float("nan")])
            families.append((kind, holm_family(setting)))
    if not rows:
        return []
    merged = {}
    for row in holm_columns(rows, families)[0]:
        merged.setdefault(tuple(row[:4]), {})[row[4]] = row[5:]
    empty = [0, "-", "-", "-"]
    shown = [list(key) + merged[key].get("bc", empty) + merged[key].get("gail", empty) for key in merged]
    return (["MAPS against each other method under each objective: difference = MAPS - the other, mean over tasks,"
             " paired by seed (mean +- 95% CI); p: paired t test; Holm within each objective's column, a control's"
             f" rows (a GAIL variant other than the suite's own, {' and '.join(MAIN_VARIANTS)}) a family of their own:",
             ""]
            + table(["set", "comparison", "demos", "k", "BC pairs", "BC difference", "BC p", "BC p (Holm)",
                     "GAIL pairs", "GAIL difference", "GAIL p", "GAIL p (Holm)"], shown))


def routing_values(cell):
    """(mean TV of the tasks' usage from their mean usage, mean per-state entropy, mean per-state top score, shared
    modules, task-specific modules) of one MAPS cell; entropy and top score None where the results lack them."""
    entropy = [t.entropy for t in cell.tasks if t.entropy is not None]
    top = [t.top_score for t in cell.tasks if t.top_score is not None]
    shared, specific, _, _ = division(cell)
    return (mean(usage_distances(cell)), mean(entropy) if entropy else None, mean(top) if top else None,
            len(shared), len(specific))


ROUTING_COLUMNS = ["usage distance between tasks (TV)", "per-state entropy (nats)", "per-state top score",
                   "shared modules", "specific modules"]


def routing_table(cells):
    """MAPS's routing per set, demos and k under BC and GAIL (per seed, then mean +- CI), the paired GAIL - BC
    difference of the usage distance between tasks (does the adversarial signal divide the tasks otherwise?) and its
    p, Holm over the rows. [] without MAPS cells with module usage under both."""
    rows = []
    modules = None
    for setting, runs in by_objective(cells).items():
        if setting.method != "maps":
            continue
        bc = [c for c in runs["bc"] if c.has_usage]
        gail = [c for c in runs["gail"] if c.has_usage]
        if not bc or not gail:
            continue
        modules = len(gail[0].tasks[0].usage)
        row = [setting.set, setting.demos, setting.subsample]
        for kind, kind_runs in (("BC", bc), ("GAIL" if setting.variant == "gail" else f"GAIL ({setting.variant})",
                                             gail)):
            values = [routing_values(c) for c in kind_runs]
            columns = [fmt([v[i] for v in values]) if all(v[i] is not None for v in values) else "-"
                       for i in range(5)]
            rows.append(row + [kind, len(kind_runs)] + columns + ["", math.nan])
        diffs = paired(gail, bc, lambda c: routing_values(c)[0])
        rows[-1][-2] = fmt(diffs, signed=True) if diffs else "-"
        rows[-1][-1] = paired_p(diffs) if diffs else math.nan
    if not rows:
        return []
    shown, _ = holm_columns(rows)
    return ([f"MAPS's routing on the evaluation states (per seed, then mean +- 95% CI over seeds; uniform over"
             f" {modules} modules: TV 0, entropy {math.log(modules):.2f}, top score {1 / modules:.2f}). A task uses a"
             f" module whose share of its usage is >= {USED_FACTOR:g}/{modules}; shared: used by two or more tasks,"
             " specific: by one. GAIL - BC: the paired difference of the usage distance between tasks (the task"
             " division), p: paired t test, Holm over the rows:", ""]
            + table(["set", "demos", "k", "objective", "seeds"] + ROUTING_COLUMNS
                    + ["GAIL - BC (TV)", "p", "p (Holm)"], shown))


# How fast GAIL learns: a curve's value (return over the expert's, or the success rate) counts as reached when the
# mean over a trailing window of iterations reaches it: one iteration's few training episodes per task are too noisy
# to read alone (the curves of gail_curves.png swing by 0.1 from one iteration to the next).
REACH = 0.9
WINDOW_ENV_STEPS = 20000


def learning_speed(curve, budget=None):
    """(area, env steps to REACH) of one GAIL cell's training curve {env steps per task: value}: area = the mean of
    the value over the iterations up to budget (env steps per task; all without one), the normalised area under the
    learning curve; env steps to REACH = the env steps per task at the end of the first trailing window of
    WINDOW_ENV_STEPS whose mean value is >= REACH, None where no window reaches it. (None, None) for an empty
    curve."""
    steps = sorted(s for s in curve if budget is None or s <= budget)
    if not steps:
        return None, None
    values = [curve[s] for s in steps]
    per_iteration = steps[0] if len(steps) == 1 else min(b - a for a, b in zip(steps, steps[1:]))
    window = max(1, round(WINDOW_ENV_STEPS / per_iteration)) if per_iteration > 0 else 1
    reached = None
    for end in range(window - 1, len(values)):
        if mean(values[end - window + 1:end + 1]) >= REACH:
            reached = steps[end]
            break
    return mean(values), reached


def fmt_steps(values, budget):
    """The env steps to REACH over seeds, in millions: the median, a seed that never reached it counting as later than
    any that did, and the range, "0.17 (0.15-0.25)"; a seed that never reached it shows in the range as past the
    budget, "0.30 (0.15 to >1.00)", and where half or more never did the median is ">1.00" too; "not reached" where
    none did. One seed: its value."""
    ordered = sorted(values, key=lambda v: (v is None, v if v is not None else 0))
    shown = [f"{v / 1e6:.2f}" if v is not None else f">{budget / 1e6:.2f}" for v in ordered]
    if all(v is None for v in ordered):
        return "not reached"
    if len(shown) == 1:
        return shown[0]
    n = len(ordered)
    if n % 2:
        median = shown[n // 2]
    else:
        low, high = ordered[n // 2 - 1], ordered[n // 2]
        median = f"{(low + high) / 2e6:.2f}" if low is not None and high is not None else f">{budget / 1e6:.2f}"
    return f"{median} ({shown[0]}{' to ' if ordered[-1] is None else '-'}{shown[-1]})"


def holm_family(setting):
    """A comparison's Holm family in the speed and MAPS tables: the suite's own GAIL runs (MAIN_VARIANTS), or a
    control's variant on its own (a width control asks its own question, as each variant does in variant_table)."""
    return "main" if setting.variant in MAIN_VARIANTS else setting.variant


def speed_table(cells):
    """How fast each method learns under GAIL, per set and demo count: the normalised area under its training curve
    (mean over the run of the training episodes' return over the expert's, or of their success rate) and the env
    steps per task at which it first reaches REACH, per seed then over seeds; and MAPS - each other method's area,
    paired by seed, Holm over the rows with a p (a control's rows a family of their own). [] without GAIL cells with
    curves. The curves are compared over the budget all of a setting's cells and MAPS's ran (the shortest; MAPS's own
    row over its own cells')."""
    settings = by_objective(cells)
    curves = {id(c): training_curve(c) for runs in settings.values() for c in runs["gail"]}
    rows, families = [], []
    for setting, runs in settings.items():
        mine = [c for c in runs["gail"] if curves[id(c)]]
        if not mine:
            continue
        partner = maps_setting(settings, setting)[1] if setting.method != "maps" else None
        peers = [c for c in partner["gail"] if curves[id(c)]] if partner else []
        budget = min(max(curves[id(c)]) for c in mine + peers)
        speed = {c.seed: learning_speed(curves[id(c)], budget) for c in mine}
        speed = {seed: value for seed, value in speed.items() if value[0] is not None}  # a curve starting past it
        if not speed:
            continue
        row = [setting.set, name(setting.method, setting.variant), setting.demos, setting.subsample, len(speed),
               f"{budget:,}", fmt([a for a, _ in speed.values()]), fmt_steps([s for _, s in speed.values()], budget)]
        maps_area = {c.seed: learning_speed(curves[id(c)], budget)[0] for c in peers}
        diffs = [maps_area[seed] - area for seed, (area, _) in speed.items() if maps_area.get(seed) is not None]
        if diffs:
            row += [len(diffs), fmt(diffs, signed=True), paired_p(diffs)]
        else:
            row += ["", "", math.nan]
        rows.append(row)
        families.append(holm_family(setting))
    if not rows:
        return []
    shown, sizes = holm_columns(rows, families)
    counted = "; ".join(f"{'the suite' + chr(39) + 's GAIL runs' if f == 'main' else f}: {n}"
                        for f, n in sizes.items() if n)
    return ([f"How fast each method learns under GAIL: area = the mean over the run's iterations of its training"
             " episodes' return over the expert's (success-scored sets: their success rate), the normalised area"
             f" under the learning curve of gail_curves.png; reaches {REACH:g} = the env steps per task at the end of"
             f" the first trailing window of about {WINDOW_ENV_STEPS:,} env steps per task (the nearest whole number"
             f" of iterations) whose mean is >= {REACH:g}, in millions: the median over seeds (a seed that never"
             " reached it counts as later than any that did) and the range, '>' marking a seed past the budget. Both"
             " per seed, over the budget every cell of the row and MAPS's ran. MAPS - other: the area's difference,"
             " paired by seed; p: paired t test; Holm over the rows with a p within each family (" + (counted or "none")
             + "):", ""]
            + table(["set", "method", "demos", "k", "seeds", "budget", "area",
                     f"reaches {REACH:g} at (10^6 env steps): median (range)", "MAPS - other pairs",
                     "MAPS - other (area)", "p", "p (Holm)"], shown))
