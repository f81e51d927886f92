#!/usr/bin/python3
"""The layout docs/architecture.md describes, checked on the tree (issue 42):
- a layer includes only the layers below it (io < autograd < nn < envs < maps < experiments; envs knows no autograd);
- inside experiments/, a folder includes only folders below it, so no two folders call each other;
- experiments/ has no source file at its top but main.cpp, and experiments/suites/ holds suite configs only;
- every file path under experiments/ and tests/ that README.md and docs/*.md name exists (a moved file leaves no
  stale path behind in the docs).
Run by ctest as: layering_test.py."""
import pathlib
import re
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]

# What each layer may include (besides itself): envs reaches policies as plain Eigen vectors, never autograd.
LAYER_USES = {
    "io": set(),
    "autograd": set(),
    "nn": {"autograd", "io"},
    "envs": {"io"},
    "maps": {"nn", "autograd", "envs", "io"},
    "experiments": {"maps", "nn", "autograd", "envs", "io"},
}
# experiments/'s folders, lowest first: a folder includes only folders of a lower rank (and itself).
EXPERIMENTS_RANK = {"process": 0, "run": 1, "experts": 1, "interop": 1, "render": 2, "bench": 2, "suite": 2,
                    "report": 3, "cli": 4}
# Paths a historical record names on purpose (docs/results-gravity.md: tools of an earlier commit, `git show` them).
HISTORICAL = {"experiments/suites/aggregate.py", "experiments/suites/plot.py", "experiments/suites/run_grid.sh",
              "experiments/suites/variants/sparse05.json"}
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.MULTILINE)


def sources(folder):
    return sorted(p for p in (ROOT / folder).rglob("*") if p.suffix in (".cpp", ".h") and p.is_file())


class Layering(unittest.TestCase):
    def test_layers_include_only_lower_layers(self):
        for layer, uses in LAYER_USES.items():
            for path in sources(layer):
                for included in INCLUDE.findall(path.read_text()):
                    top = included.split("/")[0]
                    if top in LAYER_USES and top != layer:
                        with self.subTest(file=str(path.relative_to(ROOT)), include=included):
                            self.assertIn(top, uses, f"{layer}/ may include only {sorted(uses)}")

    def test_experiments_folders_include_only_lower_folders(self):
        for path in sources("experiments"):
            parts = path.relative_to(ROOT / "experiments").parts
            if len(parts) == 1:
                continue  # main.cpp: the top
            folder = parts[0]
            with self.subTest(file=str(path.relative_to(ROOT))):
                self.assertIn(folder, EXPERIMENTS_RANK, "a folder of experiments/ that docs/architecture.md lacks")
            for included in INCLUDE.findall(path.read_text()):
                bits = included.split("/")
                if bits[0] != "experiments" or len(bits) < 3 or bits[1] == folder:
                    continue
                with self.subTest(file=str(path.relative_to(ROOT)), include=included):
                    self.assertIn(bits[1], EXPERIMENTS_RANK)
                    self.assertLess(EXPERIMENTS_RANK[bits[1]], EXPERIMENTS_RANK[folder],
                                    f"experiments/{folder}/ includes experiments/{bits[1]}/, which is not below it")

    def test_experiments_top_holds_main_only_and_suites_configs_only(self):
        top = sorted(p.name for p in (ROOT / "experiments").iterdir() if p.is_file())
        self.assertEqual(top, ["CMakeLists.txt", "main.cpp"])
        code = [p.name for p in (ROOT / "experiments" / "suites").rglob("*") if p.is_file() and p.suffix != ".json"]
        self.assertEqual(code, [], "experiments/suites/ holds suite configs (and the cost table) only")

    def test_main_is_a_dispatch_table(self):
        self.assertLess(len((ROOT / "experiments" / "main.cpp").read_text().splitlines()), 100)

    def test_every_path_the_docs_name_exists(self):
        # experiments/ and tests/ only: the docs also name the installed headers (maps/nn/mlp.h), other projects'
        # files (robomimic's scripts/, the paper's maps/train.py) and files a reader would write.
        pattern = re.compile(r"(?<![\w/.-])((?:experiments|tests)/[A-Za-z0-9_./-]*[A-Za-z0-9_])")
        for doc in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
            for number, line in enumerate(doc.read_text().splitlines(), 1):
                for path in pattern.findall(line):
                    if path in HISTORICAL or "*" in path or "<" in path:
                        continue
                    if not re.search(r"\.[a-z]+$", path) and not path.endswith("/"):
                        continue  # a folder or a name without an extension (a target, a task): not checked
                    with self.subTest(doc=f"{doc.name}:{number}", path=path):
                        self.assertTrue((ROOT / path).exists(), f"{doc.name}:{number} names {path}, which is missing")


if __name__ == "__main__":
    unittest.main()
