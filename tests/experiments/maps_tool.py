"""What the tests that drive the `maps` tool share: running it in a scratch folder, and their main()."""
import csv
import pathlib
import subprocess
import sys
import tempfile
import unittest

MAPS = None  # the tool, from argv (main)
WORK = None  # a scratch folder for the whole run (main)


def run(*args, check=True, timeout=600):
    """`maps ARGS` in WORK; with check, a non-zero exit fails the test with its stderr."""
    proc = subprocess.run([MAPS, *map(str, args)], cwd=WORK, capture_output=True, text=True, timeout=timeout)
    if check and proc.returncode != 0:
        raise AssertionError(f"maps {' '.join(map(str, args))} exited {proc.returncode}:\n{proc.stderr}")
    return proc


def work(*parts):
    return pathlib.Path(WORK, *parts)


def curve_without_timing(path):
    """curve.csv's rows without its timing columns (steps per second, CPU seconds), which differ from run to run."""
    with open(path) as f:
        rows = list(csv.reader(f))
    keep = [i for i, name in enumerate(rows[0]) if name not in ("steps_per_second", "cpu_seconds")]
    return [[row[i] for i in keep] for row in rows]


def main(script):
    """`script path/to/maps [unittest args]`: the tests with MAPS set and WORK a fresh temporary folder."""
    global MAPS, WORK
    if len(sys.argv) < 2:
        sys.exit(f"usage: {script} path/to/maps")
    MAPS = str(pathlib.Path(sys.argv.pop(1)).resolve())
    with tempfile.TemporaryDirectory(prefix=f"maps-{pathlib.Path(script).stem}-") as folder:
        WORK = folder
        result = unittest.main(module="__main__", exit=False, verbosity=2).result
    sys.exit(0 if result.wasSuccessful() else 1)
