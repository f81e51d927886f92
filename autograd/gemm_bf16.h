#pragma once

// The bfloat16 matrix product (issue 44, mixed precision): float32 operands rounded to bfloat16 (round to nearest
// even) as they are packed, their products summed in float32 by AVX512-BF16's dot-product instruction (VDPBF16PS:
// two products of bfloat16 pairs added to each float32 lane per instruction, twice the multiply-adds of a float32
// FMA). Internal to the autograd layer.
//
// The instruction set is chosen at run time: the code is compiled for it whatever the build's -march, and
// gemm_bf16 runs only where cpu_has_avx512_bf16() says the CPU has it (else it throws naming what is missing, never
// an illegal instruction).

#include <cstdint>
#include <string>

#include "autograd/gemm_f32.h"

namespace maps::ag::detail {

// Whether this CPU runs AVX512-BF16 (and the AVX-512 foundation and byte/word instructions the kernel also uses),
// from cpuid, with the operating system saving the AVX-512 registers.
bool cpu_has_avx512_bf16();

// What the CPU lacks for the bfloat16 kernel, for errors ("" when it has everything).
std::string avx512_bf16_missing();

// x rounded to the nearest bfloat16 (ties to even; a NaN stays a NaN), as the float it represents.
float round_to_bf16(float x);

// C [m, n] (row-major, `ldc` between rows) = A [m, k] B [k, n], or += when `accumulate`, with A's and B's elements
// rounded to bfloat16 and the products summed in float32. Each element of C is summed in the same order wherever
// its tile falls (as gemm_f32's). Throws std::logic_error when !cpu_has_avx512_bf16().
void gemm_bf16(StridedF32 a, StridedF32 b, float* c, std::int64_t ldc, std::int64_t m, std::int64_t n, std::int64_t k,
               bool accumulate);

}  // namespace maps::ag::detail
