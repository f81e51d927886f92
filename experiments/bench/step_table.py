#!/usr/bin/python3
"""The markdown table of experiments/bench/step_table.sh from its JSON lines: per set, precision and build, the
MAPS step's ms/step, its share of each single-core SGEMM ceiling (OpenBLAS's through numpy, Eigen's and maps's own,
each timed in the same run) and of the best of them, and its speed-up over PyTorch's float32 step.

Usage: /usr/bin/python3 experiments/bench/step_table.py results/performance/step.jsonl
"""
import json
import sys


def load(path):
    try:
        with open(path) as f:
            lines = [(number, line) for number, line in enumerate(f, 1) if line.strip()]
    except OSError as error:
        sys.exit(f"step_table.py: cannot read {path}: {error}")
    records = []
    for number, line in lines:
        try:
            record = json.loads(line)
        except json.JSONDecodeError as error:
            sys.exit(f"step_table.py: {path}, line {number}: not JSON ({error})")
        if not isinstance(record, dict) or "kind" not in record:
            sys.exit(f"step_table.py: {path}, line {number}: expected an object with a \"kind\"")
        records.append(record)
    return records


def ceiling_text(record):
    if record is None or "gflops" not in record:
        return "not measured" + (f" ({record['skipped']})" if record and "skipped" in record else "")
    blas = record.get("openblas", {})
    core = blas.get("core", blas.get("error", "?"))
    forced = record.get("env", {}).get("OPENBLAS_CORETYPE")
    return f"{record['gflops']:.1f} GFLOP/s (kernel {core}{', forced' if forced else ', its own choice'})"


def share(step_gflops, ceiling):
    return f"{step_gflops / ceiling:.2f}" if ceiling else "-"


def table(records):
    by_kind = {}
    for record in records:
        by_kind.setdefault(record["kind"], []).append(record)
    openblas = {"native": (by_kind.get("openblas_native") or [None])[0],
                "avx2": (by_kind.get("openblas_avx2") or [None])[0]}
    torch = {(r["set"], r["threads"]): r for r in by_kind.get("pytorch", []) if "ms_per_step" in r}
    steps = by_kind.get("step_native", []) + by_kind.get("step_avx2", []) + by_kind.get("step_portable", [])
    cpus = sorted({r["cpu"] for r in steps if "cpu" in r})
    lines = [f"CPU: {', '.join(cpus) or 'unknown'}. OpenBLAS SGEMM 1024^3, one thread: "
             f"{ceiling_text(openblas['native'])}"
             + (f"; on its AVX2 kernel: {ceiling_text(openblas['avx2'])}" if openblas["avx2"] else "") + ".", ""]
    torch_names = sorted({f"PyTorch {r['torch']} ({r['blas']})" for r in torch.values()})
    lines.append("| set | precision | build (float32 kernel) | threads | ms/step | GFLOP/s | share of OpenBLAS "
                 "| share of Eigen | share of own | share of the best | over float32 | PyTorch ms/step "
                 "| speed-up vs PyTorch |")
    lines.append("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    float32_ms = {(r["set"], r["threads"]): r["ms_per_step"] for r in by_kind.get("step_native", [])
                  if r.get("matmul_precision") == "float32"}
    order = {"gravity": 0, "modified": 1, "mt10": 2}
    kinds = {"step_avx2": 0, "step_portable": 1, "step_native": 2}
    for r in sorted(steps, key=lambda r: (order.get(r["set"], 9), r["threads"], kinds[r["kind"]],
                                          r.get("matmul_precision") != "float32")):
        # The AVX2 build forced to its AVX2 kernel (step_avx2), or left to choose at run time (step_portable: on an
        # AVX-512 CPU the AVX-512 kernel, judged against the native ceilings).
        build = {"step_native": "native", "step_avx2": "x86-64-v3", "step_portable": "x86-64-v3, run-time choice"}[
            r["kind"]]
        blas = openblas["avx2" if r["float32_gemm_kernel"] == "maps AVX2" else "native"]
        blas_gflops = blas.get("gflops") if blas else None
        ceilings = [c for c in (blas_gflops, r["gemm_gflops"], r["own_gemm_gflops"]) if c]
        peer = torch.get((r["set"], r["threads"]))
        over = ("-" if r["matmul_precision"] == "float32" or r["kind"] != "step_native"
                else f"{float32_ms[(r['set'], r['threads'])] / r['ms_per_step']:.2f}x"
                if (r["set"], r["threads"]) in float32_ms else "-")
        lines.append(
            f"| {r['set']} | {r['matmul_precision']} | {build} ({r['float32_gemm_kernel']}) | {r['threads']} "
            f"| {r['ms_per_step']:.2f} | {r['gflops']:.1f} | {share(r['gflops'], blas_gflops)} "
            f"| {share(r['gflops'], r['gemm_gflops'])} | {share(r['gflops'], r['own_gemm_gflops'])} "
            f"| {share(r['gflops'], max(ceilings))} | {over} "
            + (f"| {peer['ms_per_step']:.2f} | {peer['ms_per_step'] / r['ms_per_step']:.2f}x |" if peer
               else "| (no PyTorch) | - |"))
    for r in by_kind.get("refused", []):
        lines.append(f"| {r['set']} | {r['matmul_precision']} | native | {r['threads']} | refused: {r['reason']} "
                     "| | | | | | | | |")
    if torch_names:
        lines += ["", "PyTorch: " + ", ".join(torch_names) + " (float32; OPENBLAS_CORETYPE and OPENBLAS_L2_SIZE unset)."]
    return "\n".join(lines)


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: step_table.py STEP_JSONL")
    print(table(load(sys.argv[1])))
    return 0


if __name__ == "__main__":
    sys.exit(main())
