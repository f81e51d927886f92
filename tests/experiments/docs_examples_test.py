#!/usr/bin/python3
"""A code block in README.md or docs/*.md whose first line is a comment naming a file of the tree (`// path` or
`# path`) shows that file whole, as it is: the file is compiled or run by a test, so the page cannot drift from
code that works (issue 43: docs/selector-losses.md's example, followed as written, once left a test failing).
Run by ctest as: docs_examples_test.py."""
import pathlib
import re
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]


def code_blocks(text):
    """(first line number, lines) of each fenced code block."""
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        if lines[i].lstrip().startswith("```"):
            start = i + 1
            j = start
            while j < len(lines) and not lines[j].lstrip().startswith("```"):
                j += 1
            yield start + 1, lines[start:j]
            i = j + 1
        else:
            i += 1


class DocsExamples(unittest.TestCase):
    def test_a_block_that_names_a_file_shows_it_whole(self):
        shown = 0
        for doc in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
            for number, block in code_blocks(doc.read_text()):
                if not block:
                    continue
                named = re.fullmatch(r"\s*(?://|#)\s*((?:tests|examples|experiments|maps|envs|nn|autograd|io|python)"
                                     r"/[\w./-]+)\s*", block[0])
                if not named or not (ROOT / named.group(1)).is_file():
                    continue
                shown += 1
                with self.subTest(doc=f"{doc.name}:{number}", file=named.group(1)):
                    self.assertEqual("\n".join(block[1:]) + "\n", (ROOT / named.group(1)).read_text(),
                                     f"{doc.name}:{number} shows {named.group(1)} otherwise than it is")
        self.assertGreater(shown, 0, "no doc shows a file of the tree whole")


if __name__ == "__main__":
    unittest.main()
