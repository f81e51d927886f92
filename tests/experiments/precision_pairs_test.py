#!/usr/bin/python3
"""Tests of issue 44's paired comparison (experiments/report/precision_pairs.py): on the committed results/precision
it prints the table docs/performance.md shows; on a copy whose bf16 cells of one group score 0.3 more, that group is
judged beyond the seeds' spread and named in the verdict; a bf16 cell gone leaves its group with a pair fewer and the
cell listed as not used. Run by ctest (tests/CMakeLists.txt) with MAPS_TOOL set to the tool built here."""
import json
import pathlib
import shutil
import subprocess
import tempfile
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "experiments" / "report" / "precision_pairs.py"
RESULTS = ROOT / "results" / "precision"
DOC = ROOT / "docs" / "performance.md"
HEADER = "| set | method | demos | pairs |"


def run(folder, check=True):
    proc = subprocess.run(["/usr/bin/python3", str(SCRIPT), str(folder)], capture_output=True, text=True)
    if check and proc.returncode != 0:
        raise AssertionError(f"precision_pairs.py exited {proc.returncode}:\n{proc.stderr}")
    return proc


def table_lines(text):
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(HEADER))
    end = start
    while end < len(lines) and lines[end].startswith("|"):
        end += 1
    return lines[start:end]


def copy_suite(to):
    """suite.json and every cell's result.json and curve.csv (what the report reads), as a clone holds them."""
    for path in [RESULTS / "suite.json", *RESULTS.glob("cells/*/*/result.json"), *RESULTS.glob("cells/*/*/curve.csv")]:
        target = to / path.relative_to(RESULTS)
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(path, target)


class PrecisionPairsTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = pathlib.Path(self.tmp.name) / "precision"
        copy_suite(self.dir)

    def tearDown(self):
        self.tmp.cleanup()

    def test_the_committed_results_give_the_docs_table_and_verdict(self):
        out = run(RESULTS).stdout
        self.assertEqual(table_lines(out), table_lines(DOC.read_text()))
        verdict = next(line for line in out.splitlines() if line.startswith("Verdict:"))
        self.assertIn(verdict, DOC.read_text())

    def test_a_group_shifted_by_more_than_its_spread_is_judged_different(self):
        for path in self.dir.glob("cells/gravity/maps-bf16_d5_s*/result.json"):
            result = json.loads(path.read_text())
            for task in result["eval"]["tasks"]:
                task["score"] += 0.3
            path.write_text(json.dumps(result))
        out = run(self.dir).stdout
        row = [line for line in table_lines(out) if line.startswith("| gravity | maps | 5 |")][0]
        cells = [c.strip() for c in row.strip("|").split("|")]
        self.assertTrue(cells[6].startswith("0.2"), row)  # the paired difference, 0.3 minus the original's
        self.assertEqual(cells[10], "NO")
        self.assertIn("beyond it: gravity/maps/5.", out)
        # The other groups are untouched.
        self.assertEqual(sum(1 for line in table_lines(out)[2:] if line.split("|")[11].strip() == "yes"), 7)

    def test_a_missing_cell_leaves_a_pair_fewer_and_is_listed(self):
        shutil.rmtree(self.dir / "cells" / "mt10" / "maps-bf16_d2_s3")
        proc = run(self.dir)
        row = [line for line in table_lines(proc.stdout) if line.startswith("| mt10 | maps | 2 |")][0]
        self.assertEqual(row.split("|")[4].strip(), "4")
        self.assertIn("mt10/maps-bf16_d2_s3: not finished", proc.stdout)
        self.assertIn("mt10/maps-bf16_d2_s3", proc.stderr)

    def test_a_folder_without_bf16_cells_is_refused_with_the_reason(self):
        for folder in self.dir.glob("cells/*/*-bf16_*"):
            shutil.rmtree(folder)
        proc = run(self.dir, check=False)
        self.assertEqual(proc.returncode, 2)
        self.assertIn("no (set, method, demos) has float32 and bf16 cells", proc.stderr)

    def test_a_folder_that_is_not_a_suite_is_refused(self):
        proc = run(self.dir / "cells", check=False)
        self.assertEqual(proc.returncode, 2)
        self.assertIn("suite.json: no such file", proc.stderr)


if __name__ == "__main__":
    unittest.main()
