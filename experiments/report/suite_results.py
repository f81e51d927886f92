"""Reading a suite folder written by `maps suite`:

    DIR/suite.json                                 the suite: its config and every cell, finished or not
    DIR/cells/<set>/<cell>/result.json             a finished cell (written atomically: present means finished)
    DIR/cells/<set>/<cell>/curve.csv               its validation curve (columns read by name)
    DIR/cells/<set>/<cell>/replaced/<time>/        the results of the cell's earlier runs

What each cell is (finished, failed, damaged, left, run again) is not decided here: the tool decides it, in one place
for itself and for the report (experiments/suite/status.h), and says it in `maps suite status --json DIR`, which
load_suite() reads (from the file `maps report` passes, or by running the tool). This module reads the numbers of
the results the tool counts. load_suite() returns a Suite: the finished cells (Cell), the failed, missing and
damaged ones. A cell's kind is
read from its resolved config where it matters: M = config.maps.modules, the zeroed selector terms =
config.maps.selector_losses. Rows are labelled by method and variant (label()); groups() collects the seeds of one
(set, label, demos, subsample)."""
import csv
import json
import math
import os
import pathlib
import re
import shutil
import statistics
import subprocess
import sys
from collections import Counter, namedtuple
from dataclasses import dataclass, field

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "process"))
from json_input import MAX_JSON_DEPTH, JsonTooDeep, read_json  # noqa: E402,F401  (the report's modules import them here)

SUITE_FORMAT = "maps-suite/1"
CELL_FORMAT = "maps-suite-cell/1"
STATUS_FORMAT = "maps-suite-status/1"
# The task sets in the tool's order (envs::task_set_names()), filled in from the status load_suite() reads.
SET_ORDER = []
METHOD_ORDER = ["maps", "single_bc", "mt_bc", "mt_mh_bc", "maml", "transfer", "moore", "paco", "care", "top_k_moe",
                "soft_modularization"]
# Each method's name in the report's text and figures.
METHOD_NAMES = {"maps": "MAPS", "single_bc": "Single BC", "mt_bc": "MT-BC", "mt_mh_bc": "MT-MH-BC", "maml": "MAML",
         "transfer": "MAPS transfer", "moore": "MOORE", "paco": "PaCo", "care": "CARE-style",
         "top_k_moe": "top-k MoE", "soft_modularization": "Soft Modularization", "diffusion_policy": "Diffusion Policy"}
SELECTOR_TERMS = ["share", "explore", "sparse", "smooth"]
# A GAIL iteration timed over this many times its run's median was a stopped process, not work: maps/training/
# curve_cost.h's kStoppedFactor, which `maps suite status` uses (tests/experiments/imitation_test.py checks they agree).
STOPPED_FACTOR = 30.0

GroupKey = namedtuple("GroupKey", "set label demos subsample")


class SuiteError(Exception):
    """A suite folder that cannot be reported at all (no suite.json, nothing finished)."""


@dataclass
class TaskResult:
    task: str
    score: float
    success: float
    success_at_end: float  # the success test at the episode's last step (nan where eval.json predates it)
    return_mean: float
    usage: list = None  # MAPS: mean selector score per module over the task's evaluation states
    entropy: float = None
    top_score: float = None
    # HalfCheetah: the return with Gym's control cost on the unclipped action (nan where eval.json predates it)
    return_unclipped_cost: float = float("nan")
    scored_by: str = None  # "success" or "return", as maps eval scored it (None where eval.json predates the key)
    # The return the score is divided by (maps eval writes it since 2026-12-03 where it scores by return), else None.
    expert_return: float = None


@dataclass
class Cell:
    folder: pathlib.Path
    name: str
    grid: str
    set: str
    method: str
    variant: str
    demos: int
    subsample: int
    seed: int
    config: dict
    steps: int
    best_step: int
    episodes: int
    wall_seconds: float
    tasks: list
    # The paper's checkpoint rule: the best mean score over the kept checkpoints and best.ckpt (train.keep_every and
    # `maps eval --checkpoints`); None where the cell kept no checkpoints.
    best_over_checkpoints: float = None
    # The same evaluation of the last kept checkpoint (step == steps): a rule without selection, for comparison.
    last_checkpoint: float = None
    # eval.json's seconds (one evaluator thread in a suite); None when not recorded.
    eval_seconds: float = None
    # A keep-only variant's cell (is_keep_only) where no base cell of its setting and seed exists: it trained as the
    # base does, so it is labelled, grouped, drawn and paired as the base method (load_suite sets this).
    stands_for_base: bool = False
    # The CPUs the cell's processes ran on: its training attempts' and its evaluation's (result.json's "cpu" and
    # "training_attempts", recorded since 2026-11-27); empty where not recorded.
    cpus: tuple = ()
    # train.best_validation_bc (None where not recorded).
    best_validation_bc: float = None
    # A GAIL run's train.env_steps_per_task: where its curve ends, past gail.env_steps_per_task when an iteration's
    # env steps do not divide the budget (MT10's 1,500 into 10^6: 1,000,500). None where not recorded.
    trained_env_steps: int = None

    @property
    def label(self):
        return self.method if self.stands_for_base else label(self.method, self.variant)

    @property
    def key(self):
        return GroupKey(self.set, self.label, self.demos, self.subsample)

    @property
    def modules(self):
        """MAPS's number of modules M (from the resolved config); None for the baselines."""
        if self.method != "maps":
            return None
        return int(self.config.get("maps", {}).get("modules", 10))

    @property
    def selector_kind(self):
        """MAPS's selector (config maps.selector: "learned", "uniform", "task"); None for the baselines."""
        if self.method != "maps":
            return None
        return self.config.get("maps", {}).get("selector", "learned")

    @property
    def hidden(self):
        """The baselines' hidden widths (config baselines.hidden) as a tuple; None for MAPS."""
        if self.method == "maps":
            return None
        return tuple(self.config.get("baselines", {}).get("hidden", ()))

    @property
    def selector_losses(self):
        losses = self.config.get("maps", {}).get("selector_losses", {})
        return tuple(optional_float(losses.get(term)) for term in SELECTOR_TERMS)

    @property
    def zeroed_terms(self):
        """The selector-loss terms whose weight is 0 in this cell's config."""
        return tuple(t for t, w in zip(SELECTOR_TERMS, self.selector_losses) if w == 0.0)

    @property
    def mean_score(self):
        return sum(t.score for t in self.tasks) / len(self.tasks)

    @property
    def has_usage(self):
        return all(t.usage for t in self.tasks)

    def curve(self):
        """(steps, validation BC losses) from curve.csv; empty lists when it is missing or unreadable."""
        path = self.folder / "curve.csv"
        steps, losses = [], []
        try:
            with path.open() as f:
                for row in csv.DictReader(f):
                    steps.append(int(row["step"]))
                    losses.append(float(row["validation_bc"]))
        except (OSError, KeyError, ValueError, TypeError):
            return [], []
        return steps, losses

    def training_seconds_to(self, step):
        """Seconds of training until `step`, summed over curve.csv's validation windows (each row: the steps since
        the row before at its steps_per_second, which times training and validation), so a resumed run counts the
        attempt that wrote each kept row and no evaluation. None when the curve is missing, unreadable or ends
        before `step`."""
        return self._curve_sum_to(step, lambda at, previous, row: (at - previous) / float(row["steps_per_second"]))

    def cpu_seconds_to(self, step):
        """CPU seconds of training until `step`: the sum of curve.csv's cpu_seconds (each validation window's process
        CPU time, training and validation), which does not grow when other work shares the cores as wall time
        does. None as training_seconds_to, or when the curve predates the column."""
        return self._curve_sum_to(step, lambda at, previous, row: float(row["cpu_seconds"]))

    def compute_seconds(self):
        """(seconds, how) this cell's result cost. wall_seconds times only the attempt that finished the cell (a cell
        resumed after a kill shows a fraction) and grows with pauses and shared cores, so the cost is training's
        seconds from curve.csv, summed over every attempt's kept rows (steps redone after a kill count once): CPU
        seconds where the curve has them (how "cpu"), else each validation window's wall seconds ("windows"), or a
        GAIL cell's iterations (gail_iteration_seconds, how "gail"); plus the evaluation's seconds. Falls back to
        wall_seconds ("attempt") where the curve or the evaluation time is missing."""
        if self.eval_seconds is not None:
            if self.config.get("imitation") == "gail":
                iterations = self.gail_iteration_seconds()
                if iterations is not None:
                    return iterations + self.eval_seconds, "gail"
            cpu = self.cpu_seconds_to(self.steps)
            if cpu is not None:
                return cpu + self.eval_seconds, "cpu"
            windows = self.training_seconds_to(self.steps)
            if windows is not None:
                return windows + self.eval_seconds, "windows"
        return self.wall_seconds, "attempt"

    def gail_iteration_seconds(self):
        """Seconds of a GAIL cell's iterations (rollouts, discriminator and PPO): the sum of curve.csv's cpu_seconds
        (each iteration's process CPU time) where the curve has them, else the sum over its rows of the iteration's
        env steps (its rise in env_steps_per_task over the row before, times the cell's tasks) over the
        env steps per second it logged (train.log's steps/s, wall time), so a resumed run counts the attempt that
        wrote each kept row and cores shared with other runs count; an iteration of a stopped process (over
        STOPPED_FACTOR times the run's median: SIGSTOP, a suspended machine) counts at the median, as `maps suite
        status` counts it (maps/training/curve_cost.h). None as _curve_sum_to: the curve missing or unreadable, its
        env steps not rising row by row, a speed not a positive finite number, or the rows not ending at the
        env steps per task the run trained (result.json's train.env_steps_per_task)."""
        budget = self.trained_env_steps  # as `maps suite status` reads it
        if budget is None:
            return None
        by_cpu = []

        def window(at, previous, row):
            if "cpu_seconds" in row:  # process CPU time, which a stop does not grow (curves since 2026-12-05)
                by_cpu.append(True)
                return float(row["cpu_seconds"])
            return (at - previous) * len(self.tasks) / float(row["env_steps_per_second"])

        windows = self._curve_windows_to(budget, window, column="env_steps_per_task")
        if windows is None:
            return None
        if by_cpu:
            return sum(windows)
        median = statistics.median(windows)
        return sum(median if w > STOPPED_FACTOR * median else w for w in windows)

    def _curve_sum_to(self, step, window, column="step"):
        """The sum of window(at, previous, row) over curve.csv's rows up to `step` in its `column`; None as
        _curve_windows_to."""
        windows = self._curve_windows_to(step, window, column)
        return None if windows is None else sum(windows)

    def _curve_windows_to(self, step, window, column="step"):
        """[window(at, previous, row)] of curve.csv's rows up to `step` in its `column`; None where the curve is
        missing or unreadable, a window is not a positive number, or the rows do not end at `step`."""
        seconds, previous = [], 0
        try:
            with (self.folder / "curve.csv").open() as f:
                for row in csv.DictReader(f):
                    at = int(row[column])
                    if at > step:
                        break
                    value = window(at, previous, row)
                    if not value > 0:
                        return None
                    seconds.append(value)
                    previous = at
        except (OSError, KeyError, ValueError, TypeError, ZeroDivisionError):
            return None
        return seconds if previous == step else None


@dataclass
class Suite:
    root: pathlib.Path
    config_file: str
    config: dict
    planned: list  # the cell identities of suite.json
    cells: list = field(default_factory=list)  # finished (Cell)
    failed: list = field(default_factory=list)  # (cell name, stage, message)
    damaged: list = field(default_factory=list)  # (path, reason)
    missing: list = field(default_factory=list)  # cell names neither finished nor failed (left, running, started)
    dropped: list = field(default_factory=list)  # unfinished cells of suite.json that the suite config no longer makes
    # The earlier runs' results of the cells (replaced/<time>/result.json), with the tool's verdict: (path,
    # "" when it is an earlier run of the cell's run config, else why not).
    replaced: list = field(default_factory=list)

    def sets(self):
        return order(SET_ORDER, {c.set for c in self.cells})

    def cells_of(self, set_name):
        return [c for c in self.cells if c.set == set_name]


def label(method, variant):
    """A row's name: the method, with its variant unless it is the base one ("maps (no_share)")."""
    return method if variant in ("", "base", None) else f"{method} ({variant})"


def method_of_label(row_label):
    """The method of a row's name: "maps" of "maps (no_share)"."""
    return row_label.split(" (", 1)[0]


def display_label(row_label, names=None):
    """A row's name for a reader: the method's name (METHOD_NAMES, or `names`) with the variant as written
    ("Diffusion Policy (dp_mlp_h16)")."""
    method = method_of_label(row_label)
    return (METHOD_NAMES if names is None else names).get(method, method) + row_label[len(method):]


def is_keep_only(variant):
    """Whether a variant only keeps more checkpoints (named keep<N>: train.keep_every N, evaluated by the paper's
    rule too): its training and best-validation checkpoint are the base's."""
    return re.fullmatch(r"keep\d+", variant or "") is not None


def maps_partner(method_label, ran):
    """The MAPS label a method's cells are paired with: MAPS under the same variant where that ran (ran(label) is
    true), else base MAPS, so a control such as the wide MT-BC pairs with base MAPS."""
    _, _, variant = method_label.partition(" ")
    same = f"maps {variant}" if variant else "maps"
    return same if ran(same) else "maps"


def order(preferred, names):
    """names sorted with the preferred ones first, in that order, then the rest alphabetically."""
    names = set(names)
    return [n for n in preferred if n in names] + sorted(names - set(preferred))


def method_rank(method):
    return METHOD_ORDER.index(method) if method in METHOD_ORDER else len(METHOD_ORDER)


def label_rank(row_label):
    """A sort key of row names: by method in the report's order, each method's own row before its variants'."""
    method = method_of_label(row_label)
    return method_rank(method), method, row_label != method, row_label


def compared_cells(cells, variants_are_methods=False):
    """The cells compared as methods: the methods themselves (no variants), or, in a suite whose variants are methods
    of their own (report.holm "set": zoo-modern's denoisers and action chunks), every variant too but the keep-only
    ones (their training is the base's)."""
    return [c for c in cells if c.label == c.method or (variants_are_methods and not is_keep_only(c.variant))]


def shown_variant(cell):
    """The variant a cell is shown as: "base" where it stands for its method (its label is the method's)."""
    return "base" if cell.label == cell.method else cell.variant


def key_sort(key):
    """Sorting GroupKeys: set, then method in the paper's order, base variant first, then demos and k."""
    method, _, variant = key.label.partition(" ")
    set_rank = SET_ORDER.index(key.set) if key.set in SET_ORDER else len(SET_ORDER)
    return (set_rank, key.set, method_rank(method), method, variant, key.demos, key.subsample)


def optional_float(value):
    return None if value is None else float(value)


def read_cell(path):
    """The Cell of one result.json; raises ValueError/KeyError/TypeError/... on a damaged file."""
    result = read_json(path)
    if result.get("format") != CELL_FORMAT:
        raise ValueError(f"format {result.get('format')!r}, expected {CELL_FORMAT!r}")
    ident, config, train, ev = result["cell"], result["config"], result["train"], result["eval"]
    tasks = []
    for t in ev["tasks"]:
        usage = [float(u) for u in t["module_usage"]] if "module_usage" in t else None
        tasks.append(TaskResult(str(t["task"]), float(t["score"]), float(t.get("success_rate", float("nan"))),
                                float(t.get("final_success_rate", float("nan"))),
                                float(t.get("return_mean", float("nan"))), usage,
                                optional_float(t.get("selector_entropy")), optional_float(t.get("selector_top_score")),
                                return_unclipped_cost=float(t.get("return_mean_unclipped_cost", float("nan"))),
                                scored_by=t.get("scored_by"), expert_return=optional_float(t.get("expert_return"))))
    if not tasks:
        raise ValueError("no tasks in eval")
    for t in tasks:
        if not math.isfinite(t.score):
            raise ValueError(f"task {t.task}: score {t.score} is not a finite number")
        if t.usage is not None and (len(t.usage) != len(tasks[0].usage or [])
                                    or not all(math.isfinite(u) and u >= 0 for u in t.usage)):
            raise ValueError(f"task {t.task}: module_usage {t.usage} is not a distribution over the same modules as"
                             f" {tasks[0].task}'s")
    best_over = ev.get("best_over_checkpoints")
    best_over = None if best_over is None else float(best_over["mean_score"])
    last = [float(c["mean_score"]) for c in ev.get("checkpoints", []) if int(c.get("step", -1)) == int(train["steps"])]
    return Cell(path.parent, str(ident["name"]), str(ident.get("grid", "")), str(ident["set"]), str(ident["method"]),
                str(ident.get("variant", "base")), int(ident["demos"]), int(ident["subsample"]), int(ident["seed"]),
                config, int(train["steps"]), int(ev.get("best_step", train.get("best_step"))),
                int(ev.get("episodes", config.get("eval", {}).get("episodes", 0))),
                float(result.get("wall_seconds", float("nan"))), tasks, best_over, last[0] if last else None,
                optional_float(ev.get("seconds")), cpus=cpus_of(result),
                best_validation_bc=optional_float(train.get("best_validation_bc")),
                trained_env_steps=train.get("env_steps_per_task") if type(train.get("env_steps_per_task")) is int
                else None)


def cpus_of(result):
    """The distinct CPU models a result.json names (its training attempts' and its own), sorted; "unknown" for an
    attempt that names none (a provenance record older than the "cpu" key, an unreadable provenance.json). () for a
    result.json older than the "cpu" key."""
    if not result.get("cpu"):
        return ()
    attempts = result.get("training_attempts") or []
    named = [str(a.get("cpu") or "unknown") if isinstance(a, dict) else "unknown" for a in attempts]
    return tuple(sorted(set(named + [str(result["cpu"])])))


def same_where_both_say(a, b):
    """Run configs agree on every key both name (objects compared key by key): a config written before a key
    existed (the tool then resolves it to its default, as maps suite does) still matches."""
    if isinstance(a, dict) and isinstance(b, dict):
        return all(same_where_both_say(a[k], b[k]) for k in a.keys() & b.keys())
    return a == b


def find_tool():
    """The `maps` tool to ask: $MAPS_TOOL, else this checkout's build/bin/maps, else `maps` on the PATH."""
    named = os.environ.get("MAPS_TOOL")
    if named:
        return named
    built = pathlib.Path(__file__).resolve().parents[2] / "build" / "bin" / "maps"
    if built.is_file():
        return str(built)
    return shutil.which("maps")


def suite_status(root, status_file=None):
    """The tool's verdict on every cell of the suite folder root: `maps suite status --json ROOT`, read from
    status_file when given (`maps report` writes it beside the report), else asked of find_tool()."""
    if status_file is not None:
        try:
            status = read_json(status_file)
        except (OSError, ValueError) as e:
            raise SuiteError(f"{status_file}: unreadable ({e})")
    else:
        tool = find_tool()
        if not tool:
            raise SuiteError("no `maps` tool to say what each cell is: build it (cmake --build build), set MAPS_TOOL,"
                             " or run `maps report DIR`")
        try:
            done = subprocess.run([tool, "suite", "status", "--json", str(root)], capture_output=True, text=True,
                                  timeout=600)
        except OSError as e:
            raise SuiteError(f"cannot run {tool}: {e}")
        if done.returncode != 0:
            said = (done.stderr.strip().splitlines() or ["(nothing on stderr)"])[-1]
            raise SuiteError(f"{tool} suite status --json {root} failed (exit {done.returncode}): {said}")
        try:
            status = json.loads(done.stdout)
        except ValueError as e:
            raise SuiteError(f"{tool} suite status --json {root} printed no JSON ({e})")
    if not isinstance(status, dict) or status.get("format") != STATUS_FORMAT or not isinstance(status.get("cells"), list):
        raise SuiteError(f"{status_file or root}: not a {STATUS_FORMAT} status (from `maps suite status --json`)")
    return status


def load_suite(root, status_file=None):
    root = pathlib.Path(root)
    suite_file = root / "suite.json"
    if not suite_file.is_file():
        raise SuiteError(f"{suite_file}: no such file; is {root} a suite folder written by `maps suite`?")
    try:
        meta = read_json(suite_file)
        planned = list(meta.get("cells", []))
        suite = Suite(root, str(meta.get("config_file", "")), dict(meta.get("config", {})), planned)
    except (OSError, ValueError, AttributeError, TypeError) as e:
        raise SuiteError(f"{suite_file}: unreadable ({e})")
    status = suite_status(root, status_file)
    SET_ORDER[:] = [str(name) for name in status.get("task_sets", [])]

    # The tool says which results count: a result that names another cell, was trained with another run config
    # than suite.json's (a stale one), or is damaged, is not finished; such cells come with the reason.
    finished = []
    for entry in status["cells"]:
        name, state = str(entry.get("name")), entry.get("state")
        folder = pathlib.Path(str(entry.get("folder", root / "cells" / name)))
        suite.replaced += [(pathlib.Path(str(r["folder"])) / "result.json", str(r.get("damage", "")))
                           for r in entry.get("replaced", [])]
        if entry.get("damage"):
            suite.damaged.append((folder / "result.json", str(entry["damage"])))
        elif state == "done":
            path = folder / "result.json"
            try:
                cell = read_cell(path)
            except (OSError, ValueError, KeyError, TypeError, AttributeError, IndexError) as e:
                suite.damaged.append((path, f"{type(e).__name__}: {e}"))
                continue
            if cell.name != name:
                suite.damaged.append((path, f"names another cell ({cell.name})"))
                continue
            finished.append(cell)
        elif state == "failed":
            error = entry.get("error") or {}
            suite.failed.append((name, str(error.get("stage", "?")), str(error.get("error", "(no message)"))))
        elif state == "dropped":
            suite.dropped.append(name)
        else:
            suite.missing.append(name)
    # In folder order, as the results table lists them.
    suite.cells = sorted(finished, key=lambda c: str(c.folder))
    suite.damaged.sort(key=lambda d: str(d[0]))
    suite.failed.sort()
    with_base = {(c.set, c.method, c.demos, c.subsample, c.seed) for c in suite.cells if c.variant in ("", "base")}
    for c in suite.cells:
        c.stands_for_base = is_keep_only(c.variant) and (c.set, c.method, c.demos, c.subsample, c.seed) not in with_base
    if not suite.cells:
        raise SuiteError(f"{root}: no finished cells (no readable cells/*/*/result.json; {len(planned)} planned,"
                         f" {len(suite.failed)} failed, {len(suite.damaged)} damaged)")
    return suite


def load_suite_or_exit(root, script):
    """load_suite(root), or exit with status 2 after `script: what is wrong` on stderr (a report script's start)."""
    try:
        return load_suite(root)
    except SuiteError as e:
        print(f"{script}: {e}", file=sys.stderr)
        sys.exit(2)


def groups(cells):
    """{GroupKey: [cells sorted by seed]}, in key_sort order."""
    out = {}
    for cell in cells:
        out.setdefault(cell.key, []).append(cell)
    return {key: sorted(out[key], key=lambda c: c.seed) for key in sorted(out, key=key_sort)}


def task_names(cells):
    """The tasks of a set, in the order of its first cell (then any others)."""
    names = []
    for cell in cells:
        names += [t.task for t in cell.tasks if t.task not in names]
    return names


def task_score(cell, task):
    for t in cell.tasks:
        if t.task == task:
            return t.score
    return None


def maps_reference(cells):
    """(M, selector losses) of the set's base MAPS cells (the most common, should they differ); None without any."""
    base = Counter((c.modules, c.selector_losses) for c in cells if c.method == "maps" and c.label == "maps")
    return base.most_common(1)[0][0] if base else None


def control_cells(cells):
    """The controls of MAPS (docs/results.md, item 7): MAPS at the base M with another selector than the learned
    one (uniform scores, the task-only G(k)), and MT-BC wider than the base MT-BC's (as many parameters as MAPS)."""
    ref = maps_reference(cells)
    base_hidden = Counter(c.hidden for c in cells if c.label == "mt_bc").most_common(1)
    base_width = max(base_hidden[0][0], default=0) if base_hidden else None

    def is_control(c):
        if c.method == "maps":
            return ref is not None and c.modules == ref[0] and c.selector_kind != "learned"
        return (c.method == "mt_bc" and c.label != "mt_bc" and base_width is not None and bool(c.hidden)
                and min(c.hidden) > base_width)

    return [c for c in cells if is_control(c)]


def ablation_cells(cells):
    """MAPS cells with the base M and at least one selector term zeroed that the base MAPS cells use."""
    ref = maps_reference(cells)
    if ref is None:
        return []
    base_zero = {t for t, w in zip(SELECTOR_TERMS, ref[1]) if w == 0.0}
    return [c for c in cells if c.method == "maps" and c.modules == ref[0] and set(c.zeroed_terms) - base_zero]


def ablation_groups(cells):
    """{GroupKey: cells} of the base MAPS cells (base M and losses) and the ablations, MAPS first, then by the first
    zeroed term in the order share, explore, sparse, smooth."""
    ablations = ablation_cells(cells)
    if not ablations:
        return {}
    ref = maps_reference(cells)
    base = [c for c in cells if c.label == "maps" and c.modules == ref[0] and c.selector_losses == ref[1]]

    def rank(item):
        key, runs = item
        zeroed = runs[0].zeroed_terms if key.label != "maps" else ()
        return (SELECTOR_TERMS.index(zeroed[0]) if zeroed else -1, key.label, key.demos, key.subsample)

    return dict(sorted(groups(base + ablations).items(), key=rank))


# Keys a module-count variant may differ in from the base MAPS cell of its seed and count: M itself, the identity of
# the run, and how it was computed (train.flush_denormal: denormals flushed or not, the same result).
SWEEP_FREE_KEYS = [("maps", "modules"), ("seed",), ("data", "demos_per_task"), ("train", "flush_denormal")]


def without_keys(config, keys):
    """A copy of a run config without the given (dotted, as tuples) keys."""
    out = json.loads(json.dumps(config))
    for key in keys:
        node = out
        for part in key[:-1]:
            node = node.get(part, {}) if isinstance(node, dict) else {}
        if isinstance(node, dict):
            node.pop(key[-1], None)
    return out


def module_sweep_cells(cells):
    """The base MAPS cells and the cells that differ from them in M alone (the m5 / m20 variants), [] when only one M
    ran. Other variants at the base M (a uniform selector, the paper's inputs, a rerun with denormals flushed) are
    not points of the sweep, nor is a variant that changes M and something else."""
    ref = maps_reference(cells)
    if ref is None:
        return []
    base = [c for c in cells if c.label == "maps" and c.modules == ref[0] and c.selector_losses == ref[1]]
    if not base:
        return []
    shapes = [without_keys(c.config, SWEEP_FREE_KEYS) for c in base]
    sweep = base + [c for c in cells if c.method == "maps" and c.label != "maps" and c.modules != ref[0]
                    and any(same_where_both_say(without_keys(c.config, SWEEP_FREE_KEYS), s) for s in shapes)]
    return sweep if len({c.modules for c in sweep}) > 1 else []


def success_scored(set_name, cells=()):
    """MT10 is scored by success rate, the cheetah sets by normalised return; a plugin's set as maps eval says."""
    return set_name == "mt10" or any(t.task.startswith("mt10/") or (t.scored_by == "success" and
                                                                    t.task.startswith(set_name + "/"))
                                     for c in cells for t in c.tasks)


def score_name(set_name, cells=(), short=False):
    """What a set's score is, for captions and axis labels."""
    if success_scored(set_name, cells):
        return "success rate" if short else "success rate (success at any step of a 150-step episode)"
    if short:
        return "score = return / expert demo return"
    return "normalised return = return / expert demo return (1000-step episodes; floored at 0, not capped)"


def short_task(name):
    """"gravity/0.5" -> "0.5"."""
    return name.split("/", 1)[-1]
