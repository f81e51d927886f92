#!/usr/bin/env bash
# The MAPS training-step table of docs/performance.md (issue 44): per set, precision and build, ms/step, the share
# of each single-core SGEMM ceiling (OpenBLAS's through numpy, Eigen's, maps's own) and of the best of them, and the
# speed-up over PyTorch's step, with the CPU model. One JSON object per line in OUT (default
# results/performance/step.jsonl), then the markdown table.
#
# Usage: experiments/bench/step_table.sh [MAPS_BIN] [OUT] [SECONDS]
#   PRECISIONS="float32 bf16"  the precisions (a precision the CPU lacks is reported as refused, not run)
#   THREADS="1"                the op threads of each row (the ceilings are one thread)
#   AVX2_BIN=PATH              a maps built for AVX2-only x86 (-DMAPS_NATIVE=OFF -DCMAKE_CXX_FLAGS=-march=x86-64-v3):
#                              adds its float32 rows: with MAPS_F32_KERNEL=avx2, judged against AVX2 ceilings
#                              (OpenBLAS forced to its Haswell kernel, that build's Eigen and own kernel); and with
#                              the kernel it picks at run time (the portable binary's speed on this CPU).
#                              AVX2_BIN=build builds build-avx2 first.
#
# OpenBLAS: the environment may force OPENBLAS_CORETYPE and OPENBLAS_L2_SIZE (this project's VMs do); they are
# unset for the native ceilings and for PyTorch (which calls OpenBLAS) in those commands alone, and the kernel
# OpenBLAS chose is recorded in the JSON.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
maps="${1:-$here/build/bin/maps}"
out="${2:-$here/results/performance/step.jsonl}"
seconds="${3:-5}"
precisions="${PRECISIONS:-float32 bf16}"
threads_list="${THREADS:-1}"
avx2="${AVX2_BIN:-}"
python=/usr/bin/python3
[[ -x "$maps" ]] || { echo "step_table.sh: '$maps' is not an executable maps binary (build it: cmake --build build)" >&2; exit 2; }
[[ "$seconds" =~ ^[0-9]+([.][0-9]+)?$ ]] || { echo "step_table.sh: SECONDS must be a positive number, got '$seconds'" >&2; exit 2; }
for p in $precisions; do
  [[ "$p" == float32 || "$p" == bf16 ]] || { echo "step_table.sh: PRECISIONS: '$p' is not float32 or bf16" >&2; exit 2; }
done
for t in $threads_list; do
  [[ "$t" =~ ^[1-9][0-9]*$ ]] || { echo "step_table.sh: THREADS: '$t' is not a positive whole number" >&2; exit 2; }
done
if [[ "$avx2" == build ]]; then
  if [[ ! -x "$here/build-avx2/bin/maps" ]]; then
    echo "step_table.sh: building the AVX2-only maps in build-avx2 (-march=x86-64-v3)..." >&2
    cmake -S "$here" -B "$here/build-avx2" -DCMAKE_BUILD_TYPE=Release -DMAPS_NATIVE=OFF \
      -DCMAKE_CXX_FLAGS=-march=x86-64-v3 -DMAPS_BUILD_TESTS=OFF -DMAPS_BUILD_BENCHMARKS=OFF -DMAPS_BUILD_PYTHON=OFF -DMAPS_BUILD_RENDER=OFF > "$here/build-avx2.log" 2>&1 \
      && cmake --build "$here/build-avx2" --target maps -j "$(nproc)" >> "$here/build-avx2.log" 2>&1 \
      || { echo "step_table.sh: the AVX2 build failed; see build-avx2.log" >&2; exit 1; }
  fi
  avx2="$here/build-avx2/bin/maps"
fi
[[ -z "$avx2" || -x "$avx2" ]] || { echo "step_table.sh: AVX2_BIN '$avx2' is not an executable maps binary" >&2; exit 2; }

native_blas=(env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE)
mkdir -p "$(dirname "$out")"
partial="$out.partial"
: > "$partial"

# One line {"kind": ..., ...} per measurement; the table below joins them.
record() { "$python" -c 'import json,sys; r=json.loads(sys.argv[2]); r["kind"]=sys.argv[1]; print(json.dumps(r))' "$1" "$2" >> "$partial"; }

echo "step_table.sh: OpenBLAS's SGEMM ceiling (its own kernel choice)..." >&2
record openblas_native "$("${native_blas[@]}" "$python" "$here/experiments/bench/openblas_ceiling.py" --seconds 3 | tail -n 1)"
if [[ -n "$avx2" ]]; then
  echo "step_table.sh: OpenBLAS's SGEMM ceiling on its AVX2 (Haswell) kernel..." >&2
  record openblas_avx2 "$(env -u OPENBLAS_L2_SIZE OPENBLAS_CORETYPE=Haswell "$python" "$here/experiments/bench/openblas_ceiling.py" --seconds 3 | tail -n 1)"
fi
for set in gravity modified mt10; do
  for threads in $threads_list; do
    echo "step_table.sh: PyTorch, $set, $threads thread(s)..." >&2
    record pytorch "$("${native_blas[@]}" "$python" "$here/experiments/bench/peer_pytorch.py" --set "$set" --threads "$threads" --seconds "$seconds" --json | tail -n 1)"
    for precision in $precisions; do
      echo "step_table.sh: maps, $set, $precision, $threads thread(s)..." >&2
      if result="$("$maps" bench step --set "$set" --precision "$precision" --threads "$threads" --seconds "$seconds" --json 2> "$partial.err")"; then
        record "step_native" "$result"
      elif grep -q "needs a CPU with" "$partial.err"; then
        record "refused" "$("$python" -c 'import json,sys; print(json.dumps({"set": sys.argv[1], "threads": int(sys.argv[2]), "matmul_precision": sys.argv[3], "reason": open(sys.argv[4]).read().strip()}))' "$set" "$threads" "$precision" "$partial.err")"
      else
        cat "$partial.err" >&2
        exit 1
      fi
    done
    if [[ -n "$avx2" ]]; then
      # The kernel is chosen at run time (autograd/gemm_f32.h): forced to AVX2 for the AVX2 row, and left to choose
      # for the portable row (on an AVX-512 CPU the x86-64-v3 build then runs the AVX-512 kernel).
      echo "step_table.sh: maps (AVX2 build, AVX2 kernel), $set, float32, $threads thread(s)..." >&2
      record "step_avx2" "$(MAPS_F32_KERNEL=avx2 "$avx2" bench step --set "$set" --precision float32 --threads "$threads" --seconds "$seconds" --json)"
      echo "step_table.sh: maps (AVX2 build, kernel chosen at run time), $set, float32, $threads thread(s)..." >&2
      record "step_portable" "$("$avx2" bench step --set "$set" --precision float32 --threads "$threads" --seconds "$seconds" --json)"
    fi
  done
done
rm -f "$partial.err"
mv "$partial" "$out"
"$python" "$here/experiments/bench/step_table.py" "$out"
