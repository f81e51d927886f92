#!/usr/bin/env bash
# The MAPS training-step table of docs/performance.md: `maps bench step --vs-pytorch --json` for every set on 1 and
# 2 threads, one JSON object per line in OUT (default results/performance/step.jsonl), then the markdown table.
# Usage: experiments/bench/step_table.sh [MAPS_BIN] [OUT] [SECONDS]
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
maps="${1:-$here/build/bin/maps}"
out="${2:-$here/results/performance/step.jsonl}"
seconds="${3:-5}"
[[ -x "$maps" ]] || { echo "step_table.sh: '$maps' is not an executable maps binary (build it: cmake --build build)" >&2; exit 2; }
mkdir -p "$(dirname "$out")"
: > "$out.partial"
for set in gravity modified mt10; do
  for threads in 1 2; do
    echo "step_table.sh: $set, $threads thread(s)..." >&2
    "$maps" bench step --set "$set" --threads "$threads" --seconds "$seconds" --vs-pytorch --json >> "$out.partial"
  done
done
mv "$out.partial" "$out"
/usr/bin/python3 - "$out" <<'PY'
import json, sys
rows = [json.loads(line) for line in open(sys.argv[1]) if line.strip()]
print("| set | threads | ms/step | GFLOP/s | Eigen GEMM GFLOP/s | share of Eigen GEMM | own GEMM GFLOP/s | share of own GEMM "
      "| PyTorch ms/step | speed-up vs PyTorch |")
print("|---|---|---|---|---|---|---|---|---|---|")
for r in rows:
    torch_ms = r.get("pytorch_ms_per_step")
    torch = f"{torch_ms:.2f} | {r['speedup_vs_pytorch']:.2f}x" if torch_ms else "(no torch) |"
    print(f"| {r['set']} | {r['threads']} | {r['ms_per_step']:.2f} | {r['gflops']:.1f} | {r['gemm_gflops']:.1f} | "
          f"{r['ratio_to_gemm']:.2f} | {r['own_gemm_gflops']:.1f} | {r['ratio_to_own_gemm']:.2f} | {torch} |")
PY
