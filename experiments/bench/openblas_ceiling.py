#!/usr/bin/python3
"""OpenBLAS's single-thread SGEMM ceiling: float32 [1024, 1024] x [1024, 1024] through numpy, the third GEMM ceiling
of experiments/bench/step_table.sh beside Eigen's and maps's own (which `maps bench step` times itself).

OpenBLAS picks its kernel for the CPU at load time unless OPENBLAS_CORETYPE forces one, and OPENBLAS_L2_SIZE
changes its blocking; a machine's environment may set both (this project's VMs set Haswell and 512). Run this with
them unset to measure the kernel OpenBLAS would choose (step_table.sh does), and read which it chose in the
output: the "core" field is OpenBLAS's own name for it (openblas_get_corename). Prints one JSON object.

Usage: env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE /usr/bin/python3 experiments/bench/openblas_ceiling.py [--seconds S]
"""
import argparse
import ctypes
import json
import os
import statistics
import sys
import time

SIZE = 1024


def loaded_openblas():
    """The OpenBLAS library this process loaded (numpy's BLAS), from /proc/self/maps, or None."""
    try:
        with open("/proc/self/maps") as maps:
            paths = {line.split(None, 5)[-1].strip() for line in maps if "/" in line}
    except OSError:
        return None
    found = sorted(path for path in paths if "openblas" in path.lower() and ".so" in path)
    return found[0] if found else None


def openblas_facts(path):
    """OpenBLAS's core name and build configuration, asked of the loaded library itself."""
    facts = {"library": path}
    try:
        lib = ctypes.CDLL(path)
    except OSError as error:
        facts["error"] = f"cannot open {path}: {error}"
        return facts
    for field, symbol in (("core", "openblas_get_corename"), ("config", "openblas_get_config")):
        function = getattr(lib, symbol, None)
        if function is not None:
            function.restype = ctypes.c_char_p
            facts[field] = function().decode()
    return facts


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3.0, help="time spent in timed products (default 3)")
    args = parser.parse_args()
    if not args.seconds > 0:
        parser.error(f"--seconds must be > 0, got {args.seconds}")
    os.environ["OPENBLAS_NUM_THREADS"] = "1"  # read when numpy loads OpenBLAS: one thread, as the other ceilings
    try:
        import numpy
    except ImportError:
        print(json.dumps({"skipped": "numpy is not installed (apt-get install python3-numpy libopenblas0-pthread)"}))
        return 0
    rng = numpy.random.default_rng(0)
    a = rng.standard_normal((SIZE, SIZE), dtype=numpy.float32)
    b = rng.standard_normal((SIZE, SIZE), dtype=numpy.float32)
    c = numpy.empty((SIZE, SIZE), dtype=numpy.float32)
    for _ in range(3):
        numpy.matmul(a, b, out=c)
    times, start = [], time.perf_counter()
    while len(times) < 10 or time.perf_counter() - start < args.seconds:
        t0 = time.perf_counter()
        numpy.matmul(a, b, out=c)
        times.append(time.perf_counter() - t0)
    seconds = statistics.median(times)
    path = loaded_openblas()
    result = {"gflops": 2.0 * SIZE**3 / seconds * 1e-9, "products_timed": len(times), "numpy": numpy.__version__,
              "openblas": openblas_facts(path) if path else {"error": "numpy's BLAS is not OpenBLAS"},
              "env": {name: os.environ.get(name) for name in ("OPENBLAS_CORETYPE", "OPENBLAS_L2_SIZE",
                                                              "OPENBLAS_NUM_THREADS")}}
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
