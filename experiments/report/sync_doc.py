"""Refresh the generated blocks of a hand-written results page from a suite's report.md.

A block in the page is delimited by two HTML comments, each on a line of its own, invisible in the rendered page:

    <!-- report.md: The paper's claims -->
    ...replaced by the body of report.md's section "## The paper's claims"...
    <!-- /report.md -->

A page that shows more than one suite names the other suites' report in its markers, as check_quotes.py's quotes do
(FILE relative to the repository's root):

    <!-- report.md: results/zoo-modern/report/report.md#Main results -->

Given a report that blocks name so, only those blocks are refreshed; given any other report, only the blocks that
name none (a block naming another report is left as it is), so neither report's sections can land in the other's
blocks.

Everything outside the blocks (the discussion) is left as written. A marker inside a fenced code block counts too:
keep examples of markers off lines of their own. A block whose section is missing from
report.md is an error, so a renamed section cannot leave a stale table behind silently; so are a comment line
that is nearly a marker (indented, spaces missing: it would leave its block stale) and unpaired markers. The page
keeps its line endings (CRLF stays CRLF). Relative links and images in a section (report.md's figures, next to it)
are rewritten to be relative to the page's folder, so they still resolve there. A section's own headings are moved
to nest under the page's heading above the block (report.md's "### gravity" becomes "#### gravity" under a page's
"### Scores"), so the page's outline stays a tree.

    python3 experiments/report/sync_doc.py results/study/report/report.md docs/results.md
"""

import argparse
import os
import re
import sys
from pathlib import Path

# Markers count only on lines of their own, so a page can mention them in its text.
BLOCK = re.compile(r"^(<!-- report\.md: (?P<title>[^>\n]*?) -->[ \t]*\n)(?P<body>.*?)^(<!-- /report\.md -->)[ \t]*$",
                   re.S | re.M)
OPENER = re.compile(r"^<!-- report\.md: [^>\n]*? -->[ \t]*$", re.M)
CLOSER = re.compile(r"^<!-- /report\.md -->[ \t]*$", re.M)
# A markdown link or image target that is relative (not a URL, not absolute, not an anchor).
RELATIVE_LINK = re.compile(r"(\]\()(?![a-z][a-z0-9+.-]*:|/|#)([^)\s]+)(\))", re.I)
# A line that is a report.md comment but not a marker (indented, spaces missing): an error, not a block left stale.
NEAR_MISS = re.compile(r"^[ \t]*<!--[ \t]*(/[ \t]*report\.md[ \t]*|report\.md[ \t]*:.*)-->[ \t]*$")
HEADING = re.compile(r"^(#{1,6})(?= )")
# A block's title naming its report: FILE#SECTION, FILE a .md path relative to the repository's root.
NAMED = re.compile(r"^(?P<file>[^#\s][^#]*\.md)#(?P<section>.+)$")
ROOT = Path(__file__).resolve().parents[2]
FENCE = re.compile(r"^[ \t]*(```|~~~)")


def headings(text):
    """The (line index, level) of each markdown heading of text, outside fenced code blocks."""
    found, fenced = [], False
    for index, line in enumerate(text.split("\n")):
        if FENCE.match(line):
            fenced = not fenced
        elif not fenced and (match := HEADING.match(line)):
            found.append((index, len(match.group(1))))
    return found


def nest(body, page_before):
    """body with its headings moved so that its shallowest is one level below the page's last heading in
    page_before, earlier blocks' headings not counted (unchanged where the page has no heading above the block or
    the body has none); levels stay within 1-6."""
    above, inside = headings(BLOCK.sub("", page_before)), headings(body)
    if not above or not inside:
        return body
    shift = above[-1][1] + 1 - min(level for _, level in inside)
    lines = body.split("\n")
    for index, level in inside:
        lines[index] = "#" * max(1, min(6, level + shift)) + lines[index][level:]
    return "\n".join(lines)


def sections(report_text):
    """Map each '## title' of report.md to its body: the lines up to the next '## ' heading, stripped of
    leading and trailing blank lines."""
    found = {}
    title, body = None, []
    for line in report_text.splitlines():
        if line.startswith("## "):
            if title is not None:
                found[title] = body
            title, body = line[3:].strip(), []
        elif title is not None:
            body.append(line)
    if title is not None:
        found[title] = body
    return {name: "\n".join(lines).strip("\n") for name, lines in found.items()}


def named_reports(doc_text):
    """The report files the page's blocks name (FILE of each FILE#SECTION title), in order of first mention."""
    found = []
    for match in BLOCK.finditer(doc_text):
        if (named := NAMED.match(match.group("title").strip())) and named.group("file") not in found:
            found.append(named.group("file"))
    return found


def names_report(report):
    """A test of a block's FILE: whether it names `report` (a path): the same file from the repository's root, or,
    for a report in another checkout, a path ending in FILE's parts ("results/zoo-modern/report/report.md")."""
    report = Path(report).resolve()

    def test(file):
        parts = [part for part in Path(file).parts if part not in (".", "")]
        return (ROOT / file).resolve() == report or (bool(parts) and list(report.parts[-len(parts):]) == parts)
    return test


def sync(report_text, doc_text, link_prefix="", report_name=None):
    """Return (new doc text, titles of the blocks refreshed). `link_prefix` is the path from the page's folder to
    report.md's ("../results/study/report"): relative link targets in the sections get it. `report_name` says which
    blocks are this report's: a test of a block's FILE (names_report) or a FILE to compare with as written; where
    blocks name it (FILE#SECTION) only they are refreshed, else only the blocks that name no report. Raises
    ValueError naming a block whose section report.md lacks, or a page with an opening marker that is never
    closed."""
    is_report = report_name if callable(report_name) else (lambda file: report_name is not None and file == report_name)
    available = sections(report_text)
    if link_prefix:
        prefix = link_prefix.rstrip("/") + "/"
        available = {title: RELATIVE_LINK.sub(lambda m: m.group(1) + prefix + m.group(2) + m.group(3), body)
                     for title, body in available.items()}
    refreshed, blocks = [], 0
    mine = any(is_report(file) for file in named_reports(doc_text))

    def replace(match):
        nonlocal blocks
        blocks += 1
        title = match.group("title").strip()
        named = NAMED.match(title)
        if named and is_report(named.group("file")):
            section = named.group("section").strip()
        elif not named and not mine:
            section = title
        else:  # another report's block, or an unnamed one while this report has blocks of its own
            return match.group(0)
        if section not in available:
            raise ValueError(f"the page's block '{title}' has no section '## {section}' in report.md "
                             f"(its sections: {', '.join(sorted(available)) or 'none'})")
        refreshed.append(title)
        return f"{match.group(1)}{nest(available[section], doc_text[:match.start()])}\n{match.group(4)}"

    for number, line in enumerate(doc_text.split("\n"), 1):
        if NEAR_MISS.match(line) and not (OPENER.fullmatch(line) or CLOSER.fullmatch(line)):
            raise ValueError(f"line {number} looks like a block marker but is not one: {line.strip()!r} (a marker is "
                             "'<!-- report.md: TITLE -->' or '<!-- /report.md -->', alone on its line, unindented)")
    result = BLOCK.sub(replace, doc_text)
    opened, closed = len(OPENER.findall(doc_text)), len(CLOSER.findall(doc_text))
    if opened != blocks or closed != blocks:
        raise ValueError(f"the page has {opened} opening and {closed} closing report.md markers, {blocks} "
                         "of them in pairs (each '<!-- report.md: TITLE -->' needs one '<!-- /report.md -->' after it)")
    return result, refreshed


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("report", type=Path, help="a suite's report.md (maps report DIR writes DIR/report/report.md)")
    parser.add_argument("doc", type=Path, help="the page whose blocks to refresh, rewritten in place")
    args = parser.parse_args(argv)
    for path in (args.report, args.doc):
        if not path.is_file():
            parser.error(f"{path}: no such file")
    # Read and written with the page's own line endings (a CRLF page stays CRLF outside the blocks too).
    with open(args.doc, newline="") as f:
        page = f.read()
    crlf = "\r\n" in page
    if crlf and "\n" in page.replace("\r\n", ""):
        sys.exit(f"sync_doc.py: {args.doc} mixes CRLF and LF line endings: make them one kind first (the blocks "
                 "would be written in one of them)")
    page = page.replace("\r\n", "\n") if crlf else page
    for named in named_reports(page):
        if not (ROOT / named).is_file():
            sys.exit(f"sync_doc.py: {args.doc}: a block names the report {named}, which is not a file (FILE#SECTION: "
                     f"FILE relative to the repository's root, {ROOT})")
    report = args.report.resolve()
    report_name = str(report.relative_to(ROOT)) if report.is_relative_to(ROOT) else str(report)
    try:
        prefix = os.path.relpath(report.parent, args.doc.resolve().parent)
        text, refreshed = sync(args.report.read_text(), page, "" if prefix == "." else prefix, names_report(report))
    except ValueError as error:
        sys.exit(f"sync_doc.py: {args.doc}: {error}")
    if not refreshed:
        sys.exit(f"sync_doc.py: {args.doc} has no blocks for {args.report}: neither '<!-- report.md: TITLE -->' "
                 f"blocks nor '<!-- report.md: {report_name}#TITLE -->' ones")
    with open(args.doc, "w", newline="") as f:
        f.write(text.replace("\n", "\r\n") if crlf else text)
    print(f"{args.doc}: refreshed {', '.join(refreshed)} from {args.report}")


if __name__ == "__main__":
    main()
