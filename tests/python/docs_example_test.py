#!/usr/bin/python3
"""docs/python.md's code runs as written: the "Example" section's bash block (collect, train, export PYTHONPATH,
run example.py) with its python block saved as example.py, in a temporary folder laid out like the repository
(build/ and experiments/ linked in), then every other python block on its own. Run by ctest as
docs_example_test.py <source dir> <build dir>."""
import os
import pathlib
import re
import subprocess
import sys
import tempfile


def blocks(text, language):
    return re.findall(rf"```{language}\n(.*?)```", text, re.S)


def main(source, build):
    doc = (source / "docs" / "python.md").read_text()
    example = doc.split("## Example", 1)[1].split("\n## ", 1)[0]
    (shell,) = blocks(example, "bash")
    (program,) = blocks(example, "python")
    with tempfile.TemporaryDirectory(prefix="maps-docs-python-") as work:
        work = pathlib.Path(work)
        (work / "build").symlink_to(build)
        (work / "experiments").symlink_to(source / "experiments")
        (work / "example.py").write_text(program)
        proc = subprocess.run(["bash", "-euo", "pipefail", "-c", shell], cwd=work, capture_output=True, text=True)
        print(proc.stdout[-3000:])
        if proc.returncode != 0:
            print(proc.stderr[-3000:])
            return f"docs/python.md's example exited {proc.returncode}"
        if not (work / "runs" / "python-example" / "returns.png").stat().st_size > 10000:
            return "docs/python.md's example wrote no plot"
        lines = [line for line in proc.stdout.splitlines() if re.match(r"gravity/[0-9.]+: return", line)]
        if len(lines) != 5:
            return f"expected a line per Gravity task, got {lines}"
        others = [b for b in blocks(doc, "python") if b != program]
        for i, code in enumerate(others):
            env = dict(os.environ, PYTHONPATH=str(build / "python"))
            proc = subprocess.run([sys.executable, "-c", code], cwd=work, capture_output=True, text=True, env=env)
            if proc.returncode != 0:
                return f"docs/python.md's python block {i + 2} failed:\n{proc.stderr[-3000:]}"
    print(f"docs/python.md: the example and {len(others)} other python block(s) ran")
    return None


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: docs_example_test.py <source dir> <build dir>")
    error = main(pathlib.Path(sys.argv[1]).resolve(), pathlib.Path(sys.argv[2]).resolve())
    sys.exit(error)
