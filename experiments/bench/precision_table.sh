#!/usr/bin/env bash
# docs/performance.md's bfloat16 table (issue 44): `maps bench step --precision float32|bf16 --json` for every set,
# the two precisions alternating in ROUNDS paired rounds (so both see the same drift of this shared VM's clock),
# one thread; one JSON object per line in OUT (default results/performance/precision.jsonl), then the markdown
# table: per set the median ms/step of each precision, the median of the rounds' float32/bf16 ratios and their
# range. Needs a CPU with AVX512-BF16 (the tool refuses bf16 by name elsewhere).
# Usage: experiments/bench/precision_table.sh [MAPS_BIN] [OUT] [ROUNDS] [SECONDS]
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
maps="${1:-$here/build/bin/maps}"
out="${2:-$here/results/performance/precision.jsonl}"
rounds="${3:-5}"
seconds="${4:-3}"
[[ -x "$maps" ]] || { echo "precision_table.sh: '$maps' is not an executable maps binary (build it: cmake --build build)" >&2; exit 2; }
[[ "$rounds" =~ ^[1-9][0-9]*$ ]] || { echo "precision_table.sh: ROUNDS must be a positive integer, not '$rounds'" >&2; exit 2; }
mkdir -p "$(dirname "$out")"
: > "$out.partial"
for round in $(seq "$rounds"); do
  for set in gravity modified mt10; do
    for precision in float32 bf16; do
      echo "precision_table.sh: round $round/$rounds, $set, $precision..." >&2
      "$maps" bench step --set "$set" --precision "$precision" --seconds "$seconds" --json |
        /usr/bin/python3 -c "import json, sys; r = json.loads(sys.stdin.read()); r['round'] = $round; print(json.dumps(r))" \
          >> "$out.partial"
    done
  done
done
mv "$out.partial" "$out"
/usr/bin/python3 - "$out" <<'PY'
import json, statistics, sys
rows = [json.loads(line) for line in open(sys.argv[1]) if line.strip()]
print(f"CPU: {rows[0]['cpu']}; float32 kernel: {rows[0]['float32_gemm_kernel']}; one thread")
print("| set | float32 ms/step | bf16 ms/step | bf16 speed-up (median of rounds) | range | forward | backward |")
print("|---|---|---|---|---|---|---|")
for name in ("gravity", "modified", "mt10"):
    by_round = {}
    for r in rows:
        if r["set"] == name:
            by_round.setdefault(r["round"], {})[r["matmul_precision"]] = r
    pairs = [p for p in by_round.values() if "float32" in p and "bf16" in p]
    if not pairs:
        continue
    ratio = [p["float32"]["ms_per_step"] / p["bf16"]["ms_per_step"] for p in pairs]
    med = lambda key, precision: statistics.median(p[precision][key] for p in pairs)
    print(f"| {name} | {med('ms_per_step', 'float32'):.2f} | {med('ms_per_step', 'bf16'):.2f} | "
          f"{statistics.median(ratio):.2f}x | {min(ratio):.2f}-{max(ratio):.2f}x | "
          f"{med('forward_ms', 'float32') / med('forward_ms', 'bf16'):.2f}x | "
          f"{med('backward_ms', 'float32') / med('backward_ms', 'bf16'):.2f}x |")
PY
