#!/usr/bin/python3
"""Checks that the numbers a results page's prose quotes from a report table are that table's.

A quoted number carries, right after it, an HTML comment (invisible in the rendered page) naming where it comes from:

    MOORE's weights stay near uniform (TV 0.11-0.14<!-- quote: Routing of every method (the zoo) | method=MOORE |
    TV from the tasks' mean -->)

    quote: SECTION | FILTERS | COLUMN

- SECTION: a `<!-- report.md: SECTION -->` block of the same page (sync_doc.py's), or FILE#SECTION: the `## SECTION`
  of a report file, FILE a .md path relative to the repository's root (results/transfer/report/transfer.md#The
  comparison), as sync_doc.py's blocks name a report.
- FILTERS: `column=value` or `column!=value` tests separated by `;` (a cell's text, exactly; `a/b` for either;
  `heading=gravity` matches the tables under the section's sub-heading "gravity"), or `*` for every row. Every table
  of the section is searched.
- COLUMN: the column whose cells are quoted.

The text just before the comment (on the same line) is compared with the matching rows' cells:
- "a +- b" must be the one matching row's cell;
- a range "a-b" or "a to b" must be the lowest and highest of the rows' values (a cell "0.48 +- 0.17" has the value
  0.48), printed at the quote's decimals;
- one number must be every matching row's value at its decimals.
A quote that names no existing section, column or row, or whose number differs, is an error naming the page's line.
Quotes inside code (an inline span or a fenced block: examples of the syntax) are not checked.

    python3 experiments/report/check_quotes.py docs/zoo.md docs/transfer.md   # exit 1 on a mismatch
"""
import argparse
import pathlib
import re
import sys

from sync_doc import NAMED, ROOT  # one reading of FILE#SECTION and of the repository's root for both scripts
QUOTE = re.compile(r"<!--\s*quote:\s*(?P<body>.*?)-->", re.S)
BLOCK = re.compile(r"^<!-- report\.md: (?P<title>[^>\n]*?) -->[ \t]*\n(?P<body>.*?)^<!-- /report\.md -->", re.S | re.M)
NUMBER = r"[+-]?\d+(?:\.\d+)?"
# What a quote can end with, tried in this order: a mean +- interval, a range, one number.
WITH_INTERVAL = re.compile(rf"({NUMBER}) \+- ({NUMBER})\s*$")
RANGE = re.compile(rf"({NUMBER})(?:-| to )({NUMBER})\s*$")
SINGLE = re.compile(rf"({NUMBER})\s*$")
HEADING = re.compile(r"^#{1,6} (.*)$")


class QuoteError(Exception):
    pass


def tables(text):
    """The Markdown tables of a text: lists of {column: cell} rows, each row also holding "heading" (the nearest
    heading above its table). A column name the header repeats names its first column; the later ones are "name (2)",
    "name (3)", ... (the variant table's "variant" is the row's name, then its score)."""
    found, heading, header, rows = [], "", None, []
    for line in text.splitlines() + [""]:
        match = HEADING.match(line)
        if line.startswith("|"):
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if header is None:
                header = []
                for i, name in enumerate(cells):
                    repeats = cells[:i].count(name)
                    header.append(f"{name} ({repeats + 1})" if repeats else name)
            elif not all(re.fullmatch(r":?-+:?", c) for c in cells):
                rows.append(dict(zip(header, cells), heading=heading))
            continue
        if header is not None:
            found.append(rows)
            header, rows = None, []
        if match:
            heading = match.group(1).strip()
    return found


def section_text(page_text, where, page):
    """The text of the section a quote names: a block of the page, or FILE#SECTION's `## SECTION`."""
    if named := NAMED.match(where):  # FILE#SECTION as sync_doc.py's blocks name a report
        file, title = named.group("file"), named.group("section")
        path = ROOT / file
        if not path.is_file():
            raise QuoteError(f"no file {file}")
        text = path.read_text()
        match = re.search(rf"^## {re.escape(title)}[ \t]*\n(.*?)(?=^## |\Z)", text, re.S | re.M)
        if not match:
            raise QuoteError(f"{file} has no section '## {title}'")
        return match.group(1)
    for block in BLOCK.finditer(page_text):
        if block.group("title") == where:
            return block.group("body")
    raise QuoteError(f"{page} has no block <!-- report.md: {where} -->")


def value(cell):
    match = re.match(rf"\s*({NUMBER})", cell)
    if not match:
        raise QuoteError(f"the cell '{cell}' holds no number")
    return float(match.group(1))


def decimals(number_text):
    return len(number_text.split(".")[1]) if "." in number_text else 0


def same(quoted, actual):
    """The quoted number's text is the actual value printed at the quote's decimals (a sign where it has one)."""
    places = decimals(quoted)
    printed = f"{actual:+.{places}f}" if quoted.startswith("+") else f"{actual:.{places}f}"
    return float(printed) == float(quoted)


def check_quote(before, body, page_text, page):
    """None when the quote holds, else what is wrong."""
    parts = [p.strip() for p in body.split("|")]
    if len(parts) != 3:
        raise QuoteError(f"'quote: {body.strip()}' is not 'SECTION | FILTERS | COLUMN'")
    where, filters, column = parts
    tests = []  # (column, accepted values, whether a match keeps the row)
    if filters != "*":
        for pair in filters.split(";"):
            match = re.fullmatch(r"\s*([^!=]+?)\s*(!?=)\s*(.+?)\s*", pair)
            if not match:
                raise QuoteError(f"filter '{pair.strip()}' is not column=value or column!=value")
            tests.append((match.group(1), {v.strip() for v in match.group(3).split("/")}, match.group(2) == "="))
    rows = [row for table in tables(section_text(page_text, where, page)) for row in table
            if all((row.get(column) in values) == keep for column, values, keep in tests)]
    if not rows:
        raise QuoteError(f"no row of '{where}' has {filters}")
    if any(column not in row for row in rows):
        raise QuoteError(f"'{where}' has no column '{column}' (its columns: {', '.join(k for k in rows[0] if k != 'heading')})")
    cells = [row[column] for row in rows]
    if match := WITH_INTERVAL.search(before):
        if len(cells) != 1:
            return f"a mean +- interval quotes one row, and {len(cells)} rows have {filters}"
        if not cells[0].startswith(f"{match.group(1)} +- {match.group(2)}"):
            return f"quoted '{match.group(0).strip()}', the table says '{cells[0]}'"
        return None
    values = [value(c) for c in cells]
    if match := RANGE.search(before):
        low, high = match.group(1), match.group(2)
        if not (same(low, min(values)) and same(high, max(values))):
            return f"quoted the range {low} to {high}, the table's rows range {min(values):g} to {max(values):g}"
        return None
    if match := SINGLE.search(before):
        if not all(same(match.group(1), v) for v in values):
            return f"quoted {match.group(1)}, the table's rows have {', '.join(f'{v:g}' for v in values)}"
        return None
    return "no number just before the quote"


def in_fence(text, position):
    """Whether position is inside a fenced code block (an odd number of ``` or ~~~ fence lines before it)."""
    return len(re.findall(r"^[ \t]*(?:```|~~~)", text[:position], re.M)) % 2 == 1


def check_page(path):
    """[(line, problem)] of the page's quotes."""
    text = pathlib.Path(path).read_text()
    problems = []
    for quote in QUOTE.finditer(text):
        line = text.count("\n", 0, quote.start()) + 1
        before = text[text.rfind("\n", 0, quote.start()) + 1:quote.start()]
        if before.count("`") % 2 == 1 or in_fence(text, quote.start()):
            continue  # an example of the syntax, in code
        try:
            problem = check_quote(before, quote.group("body"), text, path)
        except QuoteError as error:
            problem = str(error)
        if problem:
            problems.append((line, problem))
    return problems


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("pages", nargs="+")
    args = parser.parse_args(argv)
    failed = False
    for page in args.pages:
        for line, problem in check_page(page):
            print(f"{page}:{line}: {problem}", file=sys.stderr)
            failed = True
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
