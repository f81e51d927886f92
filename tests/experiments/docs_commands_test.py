#!/usr/bin/python3
"""Every command line the docs tell a user to run a script of this repository with (its path first, as in
`experiments/cluster/slurm/submit_suite.sh C.json OUT --shards 4`) names a script that runs that way: it has its run
bit and a #! line. docs/cluster.md's command answered "Permission denied" before (issue 42). Also every tracked file
with a #! line has its run bit, so a script the docs name later is covered. Run by ctest as: docs_commands_test.py."""
import pathlib
import re
import shlex
import subprocess
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]
WRAPPERS = {"nohup", "time", "sudo", "env", "exec"}


def tracked_files():
    out = subprocess.run(["git", "-C", str(ROOT), "ls-files", "-s"], capture_output=True, text=True, check=True).stdout
    return {line.split("\t", 1)[1]: line.split()[0] for line in out.splitlines()}


def command_lines(text):
    """The lines of fenced code blocks and the inline code spans of a markdown text."""
    in_block = False
    for line in text.splitlines():
        if line.lstrip().startswith("```"):
            in_block = not in_block
            continue
        if in_block:
            yield line.strip()
        else:
            yield from re.findall(r"`([^`]+)`", line)


def script_run_directly(line):
    """The first word of a command line once variable assignments and wrappers (nohup, time, ...) are passed."""
    try:
        words = shlex.split(line, comments=True)
    except ValueError:
        return None
    while words and (re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*=.*", words[0]) or words[0] in WRAPPERS):
        words = words[1:]
    return words[0] if words else None


class DocsCommands(unittest.TestCase):
    def test_every_script_the_docs_run_directly_can_be_run(self):
        files = tracked_files()
        checked = set()
        for doc in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
            for line in command_lines(doc.read_text()):
                first = script_run_directly(line)
                if not first or "/" not in first:
                    continue
                path = first[2:] if first.startswith("./") else first
                if path not in files:
                    continue  # build/bin/maps, a placeholder, a folder
                if not (path.endswith((".sh", ".py")) or (ROOT / path).read_bytes().startswith(b"#!")):
                    continue  # a config or a header the docs name, not a program
                checked.add(path)
                with self.subTest(doc=doc.name, command=line):
                    self.assertEqual(files[path], "100755", f"{doc.name} runs {path} directly, but git has no run bit")
                    self.assertTrue((ROOT / path).read_bytes().startswith(b"#!"), f"{path} has no #! line")
        self.assertIn("experiments/cluster/slurm/submit_suite.sh", checked)
        print(f"docs_commands: {len(checked)} scripts the docs run directly")

    def test_every_tracked_script_with_a_shebang_has_its_run_bit(self):
        for path, mode in tracked_files().items():
            if mode == "100644" and (ROOT / path).is_file():
                with open(ROOT / path, "rb") as f:
                    if f.read(2) == b"#!":
                        self.fail(f"{path} starts with #! but git has no run bit for it")


if __name__ == "__main__":
    unittest.main()
