#!/usr/bin/python3
"""Which settings of a suite need more seeds: the rule of docs/zoo.md ("3 seeds, 5 where the intervals overlap").

    python3 experiments/report/more_seeds.py results/zoo experiments/suites/zoo.json [--seeds 3,4] [--write]

For every grid of the config that runs none of --seeds, and every (set, demos) of it, each method other
than MAPS is paired with MAPS over the seeds both finished (MAPS of the same grid where the grid has it, else base
MAPS at that set and count, as report.md pairs a variant). A method gets more seeds where the 95% interval of its
paired difference includes 0, or where fewer than 2 pairs finished. MAPS gets them too wherever a method it pairs
with does. A grid's cells are the ones suite.json plans for it (a result copied from another suite may name that
suite's grid), and a method is judged once its own cells and its MAPS partner's have finished (a failed cell holds
back its method only).

Without --write it prints the settings and the grids it would add. With --write it appends those grids to the config,
named <grid>_seeds_<a>_<b> (with _1, _2, ... where one grid's new cells need several: a grid is a product of sets,
methods and counts, and only the cells asked for are added; or where an earlier run added some of the grid's), so
`maps suite run` runs them after everything else. Cells the config or suite.json plan already are never added again,
so a second run adds only the settings the first could not judge yet (not ready then). The pairing is the report's (suite_stats.paired,
significance); a method whose cells have not all finished is listed as not ready and gets nothing, so run this when
the first seeds are done. The comparisons the config's report.compare names ("A - B", report.md's "Chosen
comparisons") follow the same rule: where A - B's interval includes 0, A's and B's cells there get the new seeds."""
import argparse
import copy
import json
import pathlib
import re
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

from suite_results import SuiteError, is_keep_only, label, load_suite, maps_partner, read_json  # noqa: E402
from suite_stats import fmt, paired, significance  # noqa: E402


def file_indent(text):
    """The indent of the file's first indented line (1 if none), so that a rewrite changes only what it appends."""
    for line in text.splitlines()[1:]:
        if line.startswith(" "):
            return len(line) - len(line.lstrip(" "))
    return 1


def grid_demos(config, grid, set_name):
    """The demo counts a grid runs on a set: its own (a list, or per set), else the set's (as `maps suite` reads a
    grid whose per-set counts do not name the set)."""
    demos = grid.get("demos")
    if isinstance(demos, dict):
        demos = demos.get(set_name)
    if demos is None:
        demos = config.get("sets", {}).get(set_name, {}).get("demos", [])
    return list(demos)


def planned_names(suite):
    """{grid: {cell name, ...}} from suite.json's planned cells."""
    names = {}
    for ident in suite.planned:
        if isinstance(ident, dict):
            names.setdefault(str(ident.get("grid", "")), set()).add(str(ident.get("name", "")))
    return names


def cell_names(set_name, method, variants, demos, seeds):
    """The suite's names of a method's cells (docs/suite.md: <set>/<method>[-<variant>]_d<demos>_s<seed>)."""
    return {f"{set_name}/{method}{'-' + v if v and v != 'base' else ''}_d{demos}_s{seed}"
            for v in (variants or [None]) for seed in seeds}


def planned_already(set_name, method, variant, demos, seeds, everywhere):
    """Whether the method's cells for the seeds are planned: under the variant, or, for the base, under a keep-only
    variant (keep<N>: train.keep_every alone), whose cells stand for the base where it has none."""
    if cell_names(set_name, method, [variant], demos, seeds) <= everywhere:
        return True
    if variant not in (None, "base"):
        return False
    return all(any(re.fullmatch(re.escape(f"{set_name}/{method}-") + r"keep\d+" + re.escape(f"_d{demos}_s{seed}"), name)
                   for name in everywhere) for seed in seeds)


def planned_label(method, variant):
    """The label a planned cell's result will have: a keep-only variant of a setting without base cells stands for
    the base (suite_results.stands_for_base), so its MAPS is the base MAPS partner."""
    variant = str(variant or "base")
    return str(method) if variant == "base" or is_keep_only(variant) else label(str(method), variant)


def verdict(diffs):
    """(whether the rule asks for more seeds: the 95% interval of the paired differences includes 0, or fewer than 2
    pairs; what to print: "-0.05 +- 0.64 (2 pairs): more seeds")."""
    overlaps = len(diffs) < 2 or significance(diffs) == 0
    text = fmt(diffs, signed=True) if diffs else "no pairs"
    return overlaps, f"{text} ({len(diffs)} pairs): {'more seeds' if overlaps else 'separated, stays'}"


def split_label(text):
    """"diffusion_policy (dp_mlp_h16)" -> ("diffusion_policy", "dp_mlp_h16"); "maps" -> ("maps", None)."""
    match = re.fullmatch(r"(\S+) \((.+)\)", text)
    return (match.group(1), match.group(2)) if match else (text, None)


def home_grid(config, method, variant, set_name, demos, new_seeds):
    """The first grid of the config (not one this tool added) that runs the method under the variant at the set and
    count: where its new seeds go."""
    suffix = re.compile("_seeds_" + "_".join(map(str, new_seeds)) + r"(_\d+)?$")
    for grid in config.get("grids", []):
        if (not suffix.search(str(grid.get("name", ""))) and method in grid.get("methods", [])
                and (variant or "base") in (grid.get("variants") or ["base"]) and set_name in grid.get("sets", [])
                and demos in grid_demos(config, grid, set_name)):
            return grid
    return None


def judge_comparisons(suite, config, new_seeds, finished, idents, everywhere, wanted):
    """The same rule for the comparisons the config's report.compare names ("A - B", report.md's "Chosen
    comparisons"): at every set and count where both rows are planned and finished, A - B paired by seed; where its
    interval includes 0, both rows get the new seeds in the grids that run them (added to wanted). Lines to print."""
    report = config.get("report") or {}
    entries = report.get("compare", []) if isinstance(report, dict) else []
    lines = []
    if not isinstance(entries, list):
        return [f"- report.compare: {entries!r} is not a list of \"A - B\" entries (`maps suite plan` says what is"
                " wrong), skipped"]
    for entry in entries:
        parts = str(entry).split(" - ")
        if len(parts) != 2:
            lines.append(f"- compare {entry!r}: not \"A - B\", skipped")
            continue
        rows = {}  # over the first seeds: the new ones may be planned already (by the rule above, or a run before)
        for ident in idents:
            row = planned_label(ident.get("method"), ident.get("variant"))
            if row in parts and ident.get("seed") not in new_seeds:
                rows.setdefault((str(ident.get("set")), ident.get("demos"), row), []).append(str(ident.get("name")))
        settings = sorted({(s, d) for (s, d, _) in rows if (s, d, parts[0]) in rows and (s, d, parts[1]) in rows},
                          key=lambda item: (str(item[0]), item[1]))
        for set_name, demos in settings:
            names = {row: rows[(set_name, demos, row)] for row in parts}
            waiting = sorted(n for row in parts for n in names[row] if n not in finished)
            if waiting:
                lines.append(f"- compare {entry}, {set_name} at {demos}: not ready ({len(waiting)} cells not finished"
                             f" (failed or to run), e.g. {waiting[0]})")
                continue
            cells = {row: [finished[n] for n in names[row]] for row in parts}
            overlaps, text = verdict(paired(cells[parts[0]], cells[parts[1]], lambda c: c.mean_score))
            lines.append(f"- compare {entry}, {set_name} at {demos}: {text}")
            if not overlaps:
                continue
            for row in parts:
                method, variant = split_label(row)
                if cell_names(set_name, method, [variant], demos, new_seeds) <= everywhere:
                    continue
                home = home_grid(config, method, variant, set_name, demos, new_seeds)
                if home is None:
                    lines.append(f"- {row} at {set_name} {demos}: no grid of the config runs it; add its seeds by"
                                 " hand")
                    continue
                wanted.setdefault((home["name"], set_name, demos, variant or "base"), set()).add(method)
    return lines


def decide(suite, config, new_seeds):
    """(lines to print, grids to add)."""
    finished = {c.name: c for c in suite.cells}
    planned = planned_names(suite)
    # Cells planned already: suite.json's, and those of the config's grids that suite.json has not planned yet (an
    # earlier --write before `maps suite run`), so that a second run adds nothing twice.
    everywhere = set().union(*planned.values()) if planned else set()
    for grid in config.get("grids", []):
        for set_name in grid.get("sets", []):
            for demos in grid_demos(config, grid, set_name):
                for method in grid.get("methods", []):
                    everywhere |= cell_names(set_name, method, grid.get("variants"), demos, grid.get("seeds", []))
    idents = [i for i in suite.planned if isinstance(i, dict)]
    maps_by = {}  # (set, demos, label) -> MAPS cells, label "maps" or "maps (variant)"
    for c in suite.cells:
        if c.method == "maps":
            maps_by.setdefault((c.set, c.demos, c.label), []).append(c)
    lines, wanted = [], {}  # wanted[(grid name, set, demos, variant name or "base")] = set of methods
    needs_maps = set()  # (set, demos, variant or None): a MAPS reference from another grid needs the new seeds
    for grid in config.get("grids", []):
        name = grid.get("name", "")
        added_here = re.search("_seeds_" + "_".join(map(str, new_seeds)) + r"(_\d+)?$", name)
        if set(new_seeds) & set(grid.get("seeds", [])) or added_here:
            continue  # it runs (some of) those seeds already, or it is a grid this tool added
        grid_seeds = set(grid.get("seeds", []))
        for set_name in grid.get("sets", []):
            for demos in grid_demos(config, grid, set_name):
                # The grid's cells by the names suite.json plans for it (a result copied from another suite may
                # name another grid), per method and variant.
                mine = {}
                for ident in idents:
                    if ident.get("grid") == name and ident.get("set") == set_name and ident.get("demos") == demos:
                        key = (str(ident.get("method", "")), str(ident.get("variant", "base") or "base"))
                        mine.setdefault(key, []).append(str(ident.get("name", "")))
                in_grid = "maps" in grid.get("methods", [])
                grid_variants = [None if v == "base" else v for v in (grid.get("variants") or ["base"])]
                maps_planned = [i for i in idents if i.get("method") == "maps" and i.get("set") == set_name
                                and i.get("demos") == demos]
                # MAPS's labels at this setting that finished, or that suite.json plans (a MAPS variant not finished
                # yet is still the partner the report will pair with: wait for it rather than judge against base).
                maps_labels = {label for (s_, d_, label) in maps_by if (s_, d_) == (set_name, demos)}
                maps_labels |= {planned_label(i.get("method"), i.get("variant")) for i in maps_planned}
                for (method, variant_name), names in sorted(mine.items()):
                    if method == "maps":
                        continue
                    cells = [finished[n] for n in names if n in finished]
                    method_label = cells[0].label if cells else planned_label(method, variant_name)
                    reference = maps_partner(method_label, lambda maps_label: maps_label in maps_labels)
                    # A method is judged once its cells and its MAPS partner's (in whichever grid) have all finished:
                    # one failed cell holds back that method, not the setting's others.
                    waiting = sorted(n for n in names if n not in finished)
                    waiting += sorted(str(i.get("name")) for i in maps_planned if i.get("name") not in finished
                                      and (not grid_seeds or i.get("seed") in grid_seeds)
                                      and planned_label(i.get("method"), i.get("variant")) == reference)
                    if waiting:
                        lines.append(f"- {name}, {set_name} at {demos}: {method_label}: not ready ({len(waiting)} cells"
                                     f" not finished (failed or to run), e.g. {waiting[0]})")
                        continue
                    variant = variant_name if variant_name != "base" else None
                    overlaps, text = verdict(paired(cells, maps_by.get((set_name, demos, reference), []),
                                                    lambda c: c.mean_score))
                    lines.append(f"- {name}, {set_name} at {demos}: {method_label} - {reference} {text}")
                    if not overlaps:
                        continue
                    if not cell_names(set_name, method, [variant], demos, new_seeds) <= everywhere:
                        wanted.setdefault((name, set_name, demos, variant or "base"), set()).add(method)
                    ref_variant = reference[len("maps ("):-1] if reference != "maps" else (
                        variant if variant and is_keep_only(variant) else None)
                    if planned_already(set_name, "maps", ref_variant, demos, new_seeds, everywhere):
                        continue
                    if in_grid and ref_variant in grid_variants:
                        wanted.setdefault((name, set_name, demos, ref_variant or "base"), set()).add("maps")
                    else:
                        needs_maps.add((set_name, demos, ref_variant))
    lines += judge_comparisons(suite, config, new_seeds, finished, idents, everywhere, wanted)
    # A grid without its MAPS reference: the grid that runs that MAPS there runs its new seeds too.
    for set_name, demos, variant in sorted(needs_maps, key=str):
        home = next((g for g in config.get("grids", []) if "maps" in g.get("methods", [])
                     and (g.get("variants") or [None]) == [variant] and set_name in g.get("sets", [])
                     and demos in grid_demos(config, g, set_name)), None)
        if home is None:
            lines.append(f"- MAPS{f' ({variant})' if variant else ''} at {set_name} {demos}: no grid of the config"
                         " runs it alone; add its seeds by hand")
            continue
        wanted.setdefault((home["name"], set_name, demos, variant or "base"), set()).add("maps")
    grids, existing = [], {str(g.get("name", "")) for g in config.get("grids", [])}
    suffix = "_seeds_" + "_".join(map(str, new_seeds))
    for grid in config.get("grids", []):
        name = grid.get("name", "")
        # Exactly the cells asked for: one new grid per set, variant and set of methods, over the counts that asked
        # for it (a grid is a product of its sets, methods, variants and counts; one grid for all would add cells
        # nobody asked for).
        parts = {}
        for (grid_name, set_name, demos, variant), methods in wanted.items():
            if grid_name == name:
                parts.setdefault((set_name, variant, frozenset(methods)), []).append(demos)
        variants = list(grid.get("variants") or ["base"])
        ordered = sorted(parts.items(), key=lambda item: (grid.get("sets", []).index(item[0][0]),
                                                          variants.index(item[0][1]) if item[0][1] in variants
                                                          else len(variants), sorted(item[1])))
        # Numbered where several, or where an earlier run added this grid's first ones (its cells are not asked again).
        numbered = len(ordered) > 1 or any(e == name + suffix or e.startswith(name + suffix + "_") for e in existing)
        index = 0
        for (set_name, variant, methods), counts in ordered:
            new = copy.deepcopy(grid)
            new["name"] = name + suffix
            while numbered and (new["name"] == name + suffix or new["name"] in existing):
                index += 1
                new["name"] = f"{name}{suffix}_{index}"
            existing.add(new["name"])
            new["methods"] = [m for m in grid.get("methods", []) if m in methods]
            new["sets"] = [set_name]
            if "variants" in grid:
                new["variants"] = [variant]
            new["demos"] = {set_name: sorted(counts)}
            new["seeds"] = list(new_seeds)
            grids.append(new)
    return lines, grids


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dir", help="the suite folder (e.g. results/zoo)")
    parser.add_argument("config", help="its suite config (e.g. experiments/suites/zoo.json)")
    parser.add_argument("--seeds", default="3,4", help="the seeds to add (default 3,4)")
    parser.add_argument("--write", action="store_true", help="append the new grids to the config")
    args = parser.parse_args(argv)
    try:
        new_seeds = [int(s) for s in args.seeds.split(",")]
    except ValueError:
        parser.error(f"--seeds {args.seeds!r}: expected comma-separated integers, e.g. 3,4")
    config_path = pathlib.Path(args.config)
    try:
        config = read_json(config_path)
    except (OSError, ValueError) as e:
        print(f"more_seeds: {config_path}: unreadable ({e}); expected a suite config JSON", file=sys.stderr)
        return 2
    if not isinstance(config, dict) or not isinstance(config.get("grids"), list):
        print(f"more_seeds: {config_path}: expected a suite config with a \"grids\" list", file=sys.stderr)
        return 2
    try:
        suite = load_suite(args.dir)
    except SuiteError as e:
        print(f"more_seeds: {e}", file=sys.stderr)
        return 2
    lines, grids = decide(suite, config, new_seeds)
    print("\n".join(lines) if lines else "no settings to judge")
    if not grids:
        print("no grids to add")
        return 0
    print(f"grids to add ({len(grids)}):")
    print(json.dumps(grids, indent=1))
    if args.write:
        config["grids"] += grids
        config_path.write_text(json.dumps(config, indent=file_indent(config_path.read_text())) + "\n")
        print(f"appended to {config_path}; `maps suite plan {config_path}` lists the new cells")
    return 0


if __name__ == "__main__":
    sys.exit(main())
