#!/usr/bin/python3
"""experiments/report/check_quotes.py (issue 46, item 7): a quote that matches its table passes (a mean +- interval,
a range over rows, one number, a sign, a filter on the sub-heading, a section of another report file, a column name
the header repeats); a stale
number, a missing section, column or row fails naming the page's line; and every quote in docs/ holds. Run by ctest
as: check_quotes_test.py."""
import itertools
import pathlib
import sys
import tempfile
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "experiments" / "report"))

import check_quotes  # noqa: E402

PAGE = """# Results

<!-- report.md: Against MAPS -->
#### gravity

| method | demos | difference | p (Holm) |
|---|---|---|---|
| moore | 5 | -0.47 +- 0.17 | 0.066 |
| care | 5 | -0.38 +- 0.08 | 0.027 |
| care | 25 | -0.07 +- 0.04 | 0.111 |

#### mt10

| method | demos | difference | p (Holm) |
|---|---|---|---|
| care | 2 | +0.12 +- 0.18 | 1.000 |
<!-- /report.md -->

"""


# One folder for the module's pages, removed when the tests end (a folder a page leaked into /tmp).
PAGES = tempfile.TemporaryDirectory(prefix="check-quotes-")
PAGE_NUMBERS = itertools.count()


def tearDownModule():
    PAGES.cleanup()


def page_with(prose):
    path = pathlib.Path(PAGES.name) / f"page{next(PAGE_NUMBERS)}.md"
    path.write_text(PAGE + prose + "\n")
    return path


class CheckQuotes(unittest.TestCase):
    def problems(self, prose):
        return check_quotes.check_page(page_with(prose))

    def test_quotes_that_match_their_table_pass(self):
        for prose in [
            "CARE at 5: -0.38 +- 0.08<!-- quote: Against MAPS | heading=gravity; method=care; demos=5 | difference -->.",
            "CARE differs by -0.38 to -0.07<!-- quote: Against MAPS | heading=gravity; method=care | difference -->.",
            "Holm p 0.027-0.111<!-- quote: Against MAPS | heading=gravity; method=care | p (Holm) -->",
            "MT10: +0.12<!-- quote: Against MAPS | heading=mt10 | difference --> (one row)",
            "rounded: -0.4<!-- quote: Against MAPS | method=care; demos=5 | difference -->",
            "others: -0.47 to -0.38<!-- quote: Against MAPS | heading=gravity; demos!=25 | difference -->",
            "either: -0.47 to -0.07<!-- quote: Against MAPS | method=moore/care; demos=5/25 | difference -->",
            "in code: `0.9<!-- quote: No such section | * | x -->` is an example",
            "```\n0.9<!-- quote: No such section | * | x -->\n```",
        ]:
            with self.subTest(prose=prose):
                self.assertEqual(self.problems(prose), [])

    def test_a_stale_number_fails_naming_its_line(self):
        problems = self.problems("line one\nMOORE -0.45 +- 0.17<!-- quote: Against MAPS | method=moore | difference -->")
        self.assertEqual(len(problems), 1)
        line, problem = problems[0]
        self.assertEqual(line, PAGE.count("\n") + 2)
        self.assertIn("the table says '-0.47 +- 0.17'", problem)
        problems = self.problems("TV 0.11-0.15<!-- quote: Against MAPS | method=care | p (Holm) -->")
        self.assertIn("range 0.027 to 1", problems[0][1])
        problems = self.problems("+0.13<!-- quote: Against MAPS | heading=mt10 | difference -->")
        self.assertIn("quoted +0.13, the table's rows have 0.12", problems[0][1])
        # A mean +- interval names one row.
        problems = self.problems("-0.38 +- 0.08<!-- quote: Against MAPS | method=care | difference -->")
        self.assertIn("quotes one row, and 3 rows", problems[0][1])

    def test_a_quote_naming_nothing_that_exists_fails(self):
        cases = [
            ("0.1<!-- quote: Against every method | * | difference -->", "has no block <!-- report.md: Against every"),
            ("0.1<!-- quote: Against MAPS | method=paco | difference -->", "no row of 'Against MAPS' has method=paco"),
            ("0.1<!-- quote: Against MAPS | * | score -->", "has no column 'score'"),
            ("0.1<!-- quote: Against MAPS | method | score -->", "filter 'method' is not column=value or column!=value"),
            ("0.1<!-- quote: Against MAPS | score -->", "is not 'SECTION | FILTERS | COLUMN'"),
            ("none<!-- quote: Against MAPS | * | difference -->", "no number just before the quote"),
            ("0.1<!-- quote: results/none.md#Compute | * | x -->", "no file results/none.md"),
            ("0.1<!-- quote: docs/zoo.md#No such section | * | x -->", "has no section '## No such section'"),
        ]
        for prose, message in cases:
            with self.subTest(prose=prose):
                problems = self.problems(prose)
                self.assertEqual(len(problems), 1, problems)
                self.assertIn(message, problems[0][1])

    def test_a_section_of_another_report_file(self):
        where = ("results/transfer/report/transfer.md#Across the tasks | transfer=MAPS transfer; method=Single BC (new"
                 " task alone); tasks=all (6) | above")
        self.assertEqual(self.problems(f"18<!-- quote: {where} -->"), [])
        self.assertIn("quoted 17", self.problems(f"17<!-- quote: {where} -->")[0][1])
        self.assertEqual(check_quotes.main([str(page_with("+0.01<!-- quote: Against MAPS | * | p (Holm) -->"))]), 1)

    def test_a_repeated_column_name_names_its_first_column(self):
        table = ("\n<!-- report.md: Variants -->\n| variant | demos | base | variant | difference |\n|---|---|---|---|---|\n"
                 "| maps (h16) | 2 | 0.48 +- 0.17 | 0.58 +- 0.07 | +0.10 +- 0.21 |\n<!-- /report.md -->\n\n")
        self.assertEqual(self.problems(table + "+0.10 +- 0.21<!-- quote: Variants | variant=maps (h16) | difference -->"),
                         [])
        self.assertEqual(self.problems(table + "0.58<!-- quote: Variants | variant=maps (h16) | variant (2) -->"), [])
        # A column named like another's numbered form is not a repeat of it.
        other = ("\n<!-- report.md: Scores -->\n| method | score (95% CI) | score |\n|---|---|---|\n| maps | 0.1 | 0.7 |\n"
                 "<!-- /report.md -->\n\n")
        self.assertEqual(self.problems(other + "0.7<!-- quote: Scores | method=maps | score -->"), [])

    def test_every_quote_in_the_docs_holds(self):
        pages = sorted((ROOT / "docs").glob("*.md"))
        quoted = [p for p in pages if check_quotes.QUOTE.search(p.read_text())]
        self.assertTrue(quoted, "no page of docs/ quotes a report table")
        for page in quoted:
            with self.subTest(page=page.name):
                self.assertEqual(check_quotes.check_page(page), [])


if __name__ == "__main__":
    unittest.main(verbosity=2)
