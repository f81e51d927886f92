#!/usr/bin/python3
"""docs/transfer.md's score, difference and cost tables against the committed results: transfer_table.py on
results/transfer must give every number the tables quote, and the table of all methods must have every method the
results have all 5 seeds of, so that a table copied by hand, or left behind when more cells finish, fails here.
Run by ctest (tests/CMakeLists.txt)."""
import pathlib
import re
import subprocess
import tempfile
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "transfer.md"
RESULTS = ROOT / "results" / "transfer"

# The doc's short names for the report's rows.
DOC_NAMES = {
    "frozen": "MAPS transfer",
    "tuned": "MAPS transfer (tuned)",
    "MAPS transfer (frozen)": "MAPS transfer",
    "MAPS transfer (tuned)": "MAPS transfer (tuned)",
    "MAPS from scratch": "MAPS from scratch (all tasks)",
    "Single BC": "Single BC (new task alone)",
    "MT-BC": "MT-BC (all tasks)",
    "MAPS without the new task (transfer's source)": "MAPS without the new task (transfer's source)",
}
SCORE = re.compile(r"^(\d\.\d\d \+- \d\.\d\d) \((\d+)\)$")


def cells(line):
    return [c.strip() for c in line.strip().strip("|").split("|")]


def report_scores(text):
    """{(task, method): [(score text, seeds) per count]} from the report's first table of each task."""
    scores, task, in_table = {}, None, False
    for line in text.splitlines():
        if line.startswith("## "):
            task, in_table = line[3:].strip(), False
        elif task and line.startswith("| method | 1 demo"):
            in_table = True
        elif in_table and line.startswith("|") and not line.startswith("|---"):
            row = cells(line)
            scores[(task, row[0])] = [SCORE.match(c).groups() if SCORE.match(c) else (c, None) for c in row[1:]]
        elif in_table and not line.startswith("|"):
            in_table = False
    return scores


def doc_rows(text):
    """(table's first line, task, method, [score texts]) for every row of the doc's tables of new-task scores."""
    rows, header, task = [], None, None
    for line in text.splitlines():
        if line.startswith("| new task | arm |") or line.startswith("| new task | method |"):
            header, task = line, None
        elif header and line.startswith("|---"):
            continue
        elif header and line.startswith("|"):
            row = cells(line)
            task = row[0] or task
            rows.append((header, task, row[1], row[2:]))
        else:
            header = None
    return rows


ACROSS_HEADER = "| transfer | method | tasks |"  # the table of differences "Across the tasks"
COST_HEADER = "| set | method | CPU |"  # the table "Training cost across the tasks"


def keyed_rows(text, header, key_cells):
    """{(the first key_cells cells): [the other cells]} of the rows of every table whose first line starts with
    header."""
    rows, in_table = {}, False
    for line in text.splitlines():
        if line.startswith(header):
            in_table = True
        elif in_table and line.startswith("|") and not line.startswith("|---"):
            row = cells(line)
            rows[tuple(row[:key_cells])] = row[key_cells:]
        elif not line.startswith("|"):
            in_table = False
    return rows


def across_rows(text):
    return keyed_rows(text, ACROSS_HEADER, 3)


def cost_rows(text):
    return keyed_rows(text, COST_HEADER, 3)


class TransferDoc(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.out = tempfile.TemporaryDirectory(prefix="maps-transfer-doc-")
        proc = subprocess.run(["/usr/bin/python3", str(ROOT / "experiments" / "report" / "transfer_table.py"),
                               str(RESULTS), "--out", cls.out.name], capture_output=True, text=True)
        if proc.returncode != 0:
            raise AssertionError(f"transfer_table.py failed: {proc.stderr}")
        report = (pathlib.Path(cls.out.name) / "transfer.md").read_text()
        cls.report = report_scores(report)
        cls.report_across = across_rows(report)
        cls.report_cost = cost_rows(report)

    @classmethod
    def tearDownClass(cls):
        cls.out.cleanup()

    def test_every_quoted_score_is_the_results(self):
        rows = doc_rows(DOC.read_text())
        self.assertGreaterEqual(len(rows), 12 + 20, "the doc's two score tables were not found")
        for header, task, method, scores in rows:
            with self.subTest(task=task, method=method):
                self.assertIn(method, DOC_NAMES, f"a row of {header!r} names an unknown method")
                measured = self.report.get((task, DOC_NAMES[method]))
                self.assertIsNotNone(measured, f"results/transfer has no row for {task}, {method}")
                self.assertEqual(len(scores), len(measured))
                for quoted, (score, seeds) in zip(scores, measured):
                    self.assertEqual(quoted, score)
                    # The doc's tables are of 5 seeds: a row that the results have fewer of is not to be quoted yet.
                    self.assertEqual(seeds, "5", f"{task}, {method}: {quoted} is over {seeds} seeds")

    def test_every_finished_method_is_in_the_comparison_table(self):
        # A method whose every count has its 5 seeds in the results belongs in the table of all methods: a row left
        # out when its last cells finish fails here.
        quoted = {(task, DOC_NAMES.get(method)) for header, task, method, _ in doc_rows(DOC.read_text())
                  if header.startswith("| new task | method |")}
        for (task, method), scores in self.report.items():
            if all(seeds == "5" for _, seeds in scores):
                self.assertTrue((task, method) in quoted, f"{task}, {method} is finished but not in the table")

    def test_the_summary_across_the_tasks_is_the_results(self):
        quoted = across_rows(DOC.read_text())
        self.assertGreaterEqual(len(quoted), 4, "the doc's table of differences across the tasks was not found")
        for (transfer, method, scope), values in quoted.items():
            with self.subTest(transfer=transfer, method=method, tasks=scope):
                key = (DOC_NAMES.get(transfer), DOC_NAMES.get(method, method), scope)
                self.assertIn(key, self.report_across, "no such row in transfer_table.py's summary")
                self.assertEqual(values, self.report_across[key])
                # Quoted only once both methods have their 5 seeds on every task and count the row sums up.
                set_name = scope.split(" ")[0]
                for (task, name), scores in self.report.items():
                    if name in key[:2] and set_name in ("all", task.split("/")[0]):
                        self.assertTrue(all(seeds == "5" for _, seeds in scores), f"{task}, {name} lacks seeds")

    def test_the_training_cost_across_the_tasks_is_the_results(self):
        quoted = cost_rows(DOC.read_text())
        self.assertGreaterEqual(len(quoted), 18, "the doc's table of training cost across the tasks was not found")
        cells_of = {}
        for (set_name, method, cpu), values in quoted.items():
            with self.subTest(set=set_name, method=method, cpu=cpu):
                key = (set_name, DOC_NAMES.get(method, method), cpu)
                self.assertIn(key, self.report_cost, "no such row in transfer_table.py's summary")
                self.assertEqual(values, self.report_cost[key])
                cells_of[key[:2]] = cells_of.get(key[:2], 0) + int(values[0])
        # Quoted once finished, every machine's row: 2 new tasks x 4 counts x 5 seeds, or a source run per task and
        # seed.
        for (set_name, method), count in cells_of.items():
            self.assertEqual(count, 10 if "source" in method else 40, f"{set_name}, {method}: {count} cells quoted")

    def test_the_parser_reads_a_report_row(self):
        text = "## gravity/0.5\n\n| method | 1 demo | 2 demos |\n|---|---|---|\n| MT-BC (all tasks) | 0.24 +- 0.24 (5) " \
               "| - |\n\nnext"
        self.assertEqual(report_scores(text), {("gravity/0.5", "MT-BC (all tasks)"): [("0.24 +- 0.24", "5"),
                                                                                       ("-", None)]})


if __name__ == "__main__":
    unittest.main()
